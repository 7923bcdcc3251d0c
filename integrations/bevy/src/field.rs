//! The far shadow of a [`StreamedTerrain`](crate::StreamedTerrain) on its receivers: each
//! streamed terrain that a [`TerrainReceiver`] names gets a hikage-runtime `SunField` in Bevy's
//! render world, built from the device textures of the tiles the stream draws, and its
//! receivers are drawn with [`FieldReceiverMaterial`], which reads it.

use std::collections::HashMap;

use bevy_app::App;
use bevy_asset::{Asset, AssetId, Handle};
use bevy_camera::{Camera, Camera3d};
use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParamItem;
use bevy_ecs::system::lifetimeless::SRes;
use bevy_image::Image;
use bevy_light::{DirectionalLight, SunDisk};
use bevy_pbr::{ExtendedMaterial, MaterialExtension, StandardMaterial};
use bevy_reflect::TypePath;
use bevy_render::render_asset::RenderAssets;
use bevy_render::render_resource::binding_types::{texture_2d_array, uniform_buffer_sized};
use bevy_render::render_resource::{
    AsBindGroup, AsBindGroupError, BindGroupBuilder, BindGroupLayout, BindGroupLayoutEntry, ShaderStages,
    TextureSampleType, TextureViewDimension, UnpreparedBindingResource,
};
use bevy_render::renderer::{RenderDevice, RenderQueue};
use bevy_render::texture::GpuImage;
use bevy_render::{Extract, ExtractSchedule, Render, RenderApp, RenderSystems};
use bevy_shader::ShaderRef;
use bevy_transform::components::GlobalTransform;
use hikage_runtime::glam::{Mat4, Vec2, Vec3};
use hikage_runtime::horizon::{
    FieldMap, FieldTileTextures, Sun, SunField, SunFieldOptions, SunFieldTiles, TerrainFrame, TerrainUniform, TileKey,
};
use hikage_runtime::wgpu;

use crate::receiver::TerrainReceiver;
use crate::stream::Streaming;

/// Bevy's `StandardMaterial` in the far shadow of a streamed terrain: what a [`TerrainReceiver`]
/// naming a [`StreamedTerrain`](crate::StreamedTerrain) is drawn with.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::FieldReceiverMaterial;
///
/// // The receivers of streamed terrains, once their materials are built.
/// fn count(receivers: Query<&MeshMaterial3d<FieldReceiverMaterial>>) {
///     info!("{} meshes in a streamed terrain's far shadow", receivers.iter().count());
/// }
/// ```
pub type FieldReceiverMaterial = ExtendedMaterial<StandardMaterial, FieldReceiverExtension>;

/// The terrain half of [`FieldReceiverMaterial`]: which streamed terrain's sun field it reads
/// (the field itself lives in the render world, rebuilt as the sun, the camera and the tiles
/// move).
#[derive(Asset, TypePath, Debug, Clone)]
pub struct FieldReceiverExtension {
    /// The entity with the `StreamedTerrain`.
    pub terrain: Entity,
    /// The stream it was built for (a rebuilt stream has a new field).
    pub(crate) generation: u64,
}

/// One tile as the field reads it: its place and the handles of its horizon and heights.
#[derive(Clone, Debug)]
pub(crate) struct FieldPiece {
    pub key: TileKey,
    /// Where its texel `(0, 0)`'s lower corner lies in the map frame.
    pub offset: Vec2,
    pub horizon: Handle<Image>,
    /// Its heights with the neighbours' apron, `R32Float`.
    pub heights: Handle<Image>,
    pub constants: TerrainUniform,
}

/// A streamed terrain's field as the render world builds it this frame.
struct ExtractedField {
    terrain: Entity,
    generation: u64,
    map: FieldMap,
    /// The map frame → world.
    model: Mat4,
    drawn: Vec<ExtractedPiece>,
    /// The sun and the camera; `None` in a frame without either (the field then keeps what it
    /// holds).
    view: Option<(Sun, Vec3)>,
}

/// A drawn tile as the render world finds it: its place, its images' ids and its constants.
struct ExtractedPiece {
    key: TileKey,
    offset: Vec2,
    horizon: AssetId<Image>,
    heights: AssetId<Image>,
    constants: TerrainUniform,
}

/// A directional light as the sun is chosen from.
pub(crate) type SceneLight<'a> = (Entity, &'a DirectionalLight, &'a GlobalTransform, Option<&'a SunDisk>);

/// The fields to build this frame.
#[derive(Resource, Default)]
struct ExtractedFields(Vec<ExtractedField>);

/// A terrain's field and the tiles it reads.
struct RenderField {
    generation: u64,
    tiles: SunFieldTiles,
    field: SunField,
}

/// The render world's sun fields, by the main-world entity of their streamed terrain: what a
/// [`FieldReceiverMaterial`]'s bind group reads (public only as the bind group's parameter).
#[derive(Resource, Default)]
pub struct RenderFields(HashMap<Entity, RenderField>, std::collections::HashSet<(Entity, u64)>);

/// The sun a terrain's shadows are drawn for: the scene's first `DirectionalLight` with shadow
/// maps, else its first (by entity); its direction toward the light and its disc's radius.
pub(crate) fn scene_sun<'a>(lights: impl Iterator<Item = SceneLight<'a>>) -> Option<(Entity, Vec3, f32)> {
    let (entity, _, placed, disc) = lights.min_by_key(|(e, l, _, _)| (!l.shadow_maps_enabled, *e))?;
    let back = placed.back();
    Some((entity, Vec3::new(back.x, back.y, back.z), disc.map_or(0.0, |d| 0.5 * d.angular_size)))
}

pub(crate) fn build(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .init_resource::<ExtractedFields>()
        .init_resource::<RenderFields>()
        .add_systems(ExtractSchedule, extract)
        .add_systems(Render, prepare.in_set(RenderSystems::PrepareResources));
}

/// Copies each streamed terrain that a receiver names, with the tiles it draws, the sun and the
/// camera, into the render world.
fn extract(
    mut out: ResMut<ExtractedFields>,
    terrains: Extract<Query<(&Streaming, &GlobalTransform)>>,
    receivers: Extract<Query<&TerrainReceiver>>,
    lights: Extract<Query<SceneLight>>,
    cameras: Extract<Query<(&Camera, &GlobalTransform), With<Camera3d>>>,
) {
    out.0.clear();
    let eye = cameras.iter().find(|(c, _)| c.is_active).map(|(_, t)| t.translation());
    let sun = scene_sun(lights.iter()).map(|(_, toward, radius)| Sun {
        direction: toward,
        angular_radius: radius,
        ..Sun::default()
    });
    let view = sun.zip(eye).map(|(sun, eye)| (sun, Vec3::new(eye.x, eye.y, eye.z)));
    let mut named: Vec<Entity> = receivers.iter().map(|r| r.terrain).collect();
    named.sort_unstable();
    named.dedup();
    for terrain in named {
        let Ok((streaming, placed)) = terrains.get(terrain) else { continue };
        let Ok(map) = streaming.field else { continue };
        let drawn = streaming
            .drawn_pieces()
            .map(|p| ExtractedPiece {
                key: p.key,
                offset: p.offset,
                horizon: p.horizon.id(),
                heights: p.heights.id(),
                constants: p.constants,
            })
            .collect();
        out.0.push(ExtractedField {
            terrain,
            generation: streaming.generation,
            map,
            model: Mat4::from_cols_array(&placed.to_matrix().to_cols_array()),
            drawn,
            view,
        });
    }
}

/// Builds or updates each extracted terrain's field from the tiles whose textures are on the
/// device; drops the fields no receiver reads any more.
fn prepare(
    extracted: Res<ExtractedFields>,
    mut fields: ResMut<RenderFields>,
    images: Res<RenderAssets<GpuImage>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let (device, queue): (&wgpu::Device, &wgpu::Queue) = (device.wgpu_device(), &queue);
    fields.0.retain(|terrain, _| extracted.0.iter().any(|e| e.terrain == *terrain));
    for e in &extracted.0 {
        let fresh = fields.0.get(&e.terrain).is_none_or(|f| f.generation != e.generation || *f.tiles.map() != e.map);
        if fresh {
            let tiles = SunFieldTiles::new(device, queue, e.map);
            match SunField::new(device, &tiles, SunFieldOptions::default()) {
                Ok(field) => {
                    fields.0.insert(e.terrain, RenderField { generation: e.generation, tiles, field });
                }
                Err(error) => {
                    // Its receivers wait for a field (they are not drawn); said once per stream.
                    if fields.1.insert((e.terrain, e.generation)) {
                        bevy_log::error!("hikage: the sun field of terrain {}: {error}", e.terrain);
                    }
                    fields.0.remove(&e.terrain);
                    continue;
                }
            }
        }
        let f = fields.0.get_mut(&e.terrain).expect("inserted above");
        // A tile whose images are not on the device yet is left out: coarser tiles answer there
        // until it is.
        let drawn = e.drawn.iter().filter_map(|p| {
            Some(FieldTileTextures {
                key: p.key,
                offset: p.offset,
                horizon: &images.get(p.horizon)?.texture_view,
                heights: &images.get(p.heights)?.texture_view,
                constants: p.constants,
            })
        });
        f.tiles.set(device, queue, drawn);
        let Some((sun, eye)) = e.view else { continue };
        let frame = TerrainFrame { model: e.model, sun, ..TerrainFrame::default() };
        // A device that cannot hold the work keeps the last field.
        if let Err(error) = f.field.update(device, queue, &f.tiles, &frame, eye)
            && fields.1.insert((e.terrain, e.generation))
        {
            bevy_log::error!("hikage: the sun field of terrain {}: {error}", e.terrain);
        }
    }
}

impl AsBindGroup for FieldReceiverExtension {
    type Data = ();
    type Param = SRes<RenderFields>;

    fn label() -> &'static str {
        "hikage_field_receiver"
    }

    fn bind_group_data(&self) -> Self::Data {}

    fn build_bind_group(
        &self,
        _layout: &BindGroupLayout,
        _render_device: &RenderDevice,
        fields: &mut SystemParamItem<'_, '_, Self::Param>,
        _force_no_bindless: bool,
        output: &mut BindGroupBuilder,
    ) -> Result<(), AsBindGroupError> {
        // Until the field of this stream exists (its first frame in the render world).
        let Some(f) = fields.0.get(&self.terrain).filter(|f| f.generation == self.generation) else {
            return Err(AsBindGroupError::RetryNextUpdate);
        };
        let (uniform, thresholds) = f.field.bindings();
        output.push((120, UnpreparedBindingResource::Buffer(uniform.clone().into())));
        output.push((
            121,
            UnpreparedBindingResource::TextureView(TextureViewDimension::D2Array, thresholds.clone().into()),
        ));
        Ok(())
    }

    fn bind_group_layout_entries(_render_device: &RenderDevice, _force_no_bindless: bool) -> Vec<BindGroupLayoutEntry>
    where
        Self: Sized,
    {
        let uniform = std::num::NonZeroU64::new(hikage_runtime::horizon::SUN_FIELD_UNIFORM_BYTES);
        vec![
            uniform_buffer_sized(false, uniform).build(120, ShaderStages::FRAGMENT),
            texture_2d_array(TextureSampleType::Float { filterable: false }).build(121, ShaderStages::FRAGMENT),
        ]
    }
}

impl MaterialExtension for FieldReceiverExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::FIELD_RECEIVER.into()
    }
}
