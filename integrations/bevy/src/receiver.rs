//! The terrain's far shadows on what stands on it: [`TerrainReceiver`] draws its mesh with Bevy's
//! `StandardMaterial` whose sun is hidden wherever the terrain hides it — a house or a tree
//! kilometres away in a mountain's shadow at sunset, far past Bevy's cascades: with
//! [`TerrainReceiverMaterial`] over a [`HorizonTerrain`], with
//! [`FieldReceiverMaterial`] over a [`StreamedTerrain`].

use bevy_asset::{Asset, AssetEvent, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_math::{Mat4, UVec2, Vec2};
use bevy_pbr::{ExtendedMaterial, MaterialExtension, MeshMaterial3d, StandardMaterial};
use bevy_reflect::Reflect;
use bevy_render::render_resource::{AsBindGroup, ShaderType};
use bevy_shader::ShaderRef;
use bevy_transform::components::GlobalTransform;
use hikage_bundle::AssetKind;

use crate::diagnostics::{Check, Problems, ShadesOwnMesh, SunShadowed};
use crate::field::{FieldReceiverExtension, FieldReceiverMaterial};
use crate::stream::{StreamedTerrain, Streaming};
use crate::{HikageBundle, HorizonTerrain};

/// Bevy's `StandardMaterial` in the shadow of a baked terrain.
pub type TerrainReceiverMaterial = ExtendedMaterial<StandardMaterial, TerrainReceiverExtension>;

/// Shades its entity's mesh with the far shadow of the terrain on entity `terrain`: each
/// point's sun visibility comes from the terrain's baked horizons, as a point that high above the
/// ground under it sees past them (the walk of hikage-runtime's `horizon_raised_sun_visible`),
/// with the sun disc's softness. Put it on an entity with a `Mesh3d`; once the terrain's bundle
/// has loaded it gets a material over `base`, again when the terrain moves or is rebaked:
///
/// - naming a [`HorizonTerrain`], a [`TerrainReceiverMaterial`], which walks the terrain's map
///   per fragment;
/// - naming a [`StreamedTerrain`], a [`FieldReceiverMaterial`], which reads the terrain's
///   sun-visibility field: hikage-runtime's `SunField`, built in the render world from the tiles
///   the stream draws (28 MiB a streamed terrain with receivers).
///
/// It composes with Bevy's cascades: where a cascade covers the point, the darker of the two
/// shadows is drawn (not their product, which would darken the terrain's shadow twice where the
/// cascades draw it too); past the cascades, the terrain's shadow alone, so the shadow goes on
/// without a seam where the cascades end. As for the terrain, the scene's first
/// `DirectionalLight` is the sun and must have `shadow_maps_enabled`.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::{HorizonTerrain, TerrainReceiver};
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
///     let terrain = commands.spawn(HorizonTerrain::new(assets.load("bundle/bundle.ron"), "terrain.horizon")).id();
///     let walls = StandardMaterial { base_color: Color::srgb(0.8, 0.7, 0.6), ..default() };
///     commands.spawn((
///         Mesh3d(meshes.add(Cuboid::new(8.0, 6.0, 10.0))),
///         Transform::from_xyz(12_000.0, 640.0, 9_000.0),
///         TerrainReceiver::new(terrain).with_base(walls),
///     ));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility, Problems)]
pub struct TerrainReceiver {
    /// The entity with the `HorizonTerrain` or `StreamedTerrain` whose shadow this mesh receives.
    pub terrain: Entity,
    /// The surface under the shadow.
    pub base: StandardMaterial,
}

impl TerrainReceiver {
    /// A white surface receiving the shadow of the terrain on `terrain`.
    pub fn new(terrain: Entity) -> TerrainReceiver {
        TerrainReceiver { terrain, base: StandardMaterial::default() }
    }

    /// The same over `base` (colour, textures, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> TerrainReceiver {
        self.base = base;
        self
    }
}

/// The terrain half of [`TerrainReceiverMaterial`]: the terrain's horizon map and heights, and
/// where the terrain lies.
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub struct TerrainReceiverExtension {
    /// Where the terrain lies and how its maps are read.
    #[uniform(120)]
    pub uniform: ReceiverUniform,
    /// The horizon map (3D: u, v, azimuth), read texel by texel.
    #[texture(121, dimension = "3d", sample_type = "float", filterable = false)]
    pub horizon: Handle<Image>,
    /// The heightfield the horizons were baked from.
    #[texture(122, sample_type = "float", filterable = false)]
    pub heights: Handle<Image>,
}

/// The uniform of [`TerrainReceiverExtension`] (WGSL `HikageReceiver`).
#[derive(ShaderType, Reflect, Debug, Clone, Copy, Default)]
pub struct ReceiverUniform {
    /// World → the terrain's frame (`x` along +u, `y` up, `z` along +v).
    pub to_map: Mat4,
    /// World units per texel along u and v.
    pub texel_size: Vec2,
    /// The heightfield's texels along u and v.
    pub size: UVec2,
    /// 0: float texels as they are; 1: `Rg8Unorm` or BC5 (`β/π + ½`, 0 open sky).
    pub format: u32,
    /// World units of distance per unit of the distance channel (`Rg8Unorm`, BC5).
    pub distance_scale: f32,
    /// `tan β` of open sky (code 0).
    pub open_sky_slope: f32,
    /// The bake's farthest horizon distance (world units).
    pub reach: f32,
    /// World height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// 1 to apply the terrain's shadow, 0 to leave the light as Bevy computes it.
    pub shadow: u32,
    /// Padding.
    pub _pad: u32,
}

impl MaterialExtension for TerrainReceiverExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::TERRAIN_RECEIVER.into()
    }
}

impl TerrainReceiverExtension {
    /// The extension for the terrain of `terrain` in `bundle`, placed by `placed`; or why not.
    pub(crate) fn new(
        bundle: &HikageBundle,
        terrain: &HorizonTerrain,
        placed: &GlobalTransform,
    ) -> Result<TerrainReceiverExtension, String> {
        let (settings, horizon, encoding) = bundle.horizon(&terrain.horizon)?;
        let channels = bundle.asset(&terrain.horizon).and_then(|a| a.payload.texture()).map(|t| t.format.channels());
        if channels != Some(2) {
            return Err(format!(
                "horizon `{}` holds no distances to its horizons (one channel): a receiver needs them; bake it \
                 again with this hikage",
                terrain.horizon
            ));
        }
        let heights = bundle.image_of_kind(&settings.heightfield, AssetKind::Heightfield)?;
        let hf = bundle.asset(&settings.heightfield).and_then(|a| a.settings.heightfield());
        let desc = bundle.asset(&settings.heightfield).and_then(|a| a.payload.texture());
        let (Some(hf), Some(desc)) = (hf, desc) else {
            return Err(format!("heightfield `{}` has no settings or texture", settings.heightfield));
        };
        let (sx, sy) = settings.texel_size;
        let reach = settings.max_distance.unwrap_or((desc.width as f32 * sx).hypot(desc.height as f32 * sy));
        let uniform = ReceiverUniform {
            to_map: placed.to_matrix().inverse(),
            texel_size: Vec2::new(sx, sy),
            size: UVec2::new(desc.width, desc.height),
            format: encoding.format,
            distance_scale: encoding.distance_scale,
            open_sky_slope: encoding.open_sky_slope,
            reach,
            height_scale: hf.height_scale,
            height_offset: hf.height_offset,
            shadow: 1,
            _pad: 0,
        };
        Ok(TerrainReceiverExtension { uniform, horizon, heights })
    }
}

/// A receiver as [`attach`] sees it: which material it holds, and for a streamed terrain, the
/// stream its material reads.
type Receiver<'a> = (
    Entity,
    Ref<'a, TerrainReceiver>,
    Has<MeshMaterial3d<TerrainReceiverMaterial>>,
    Option<&'a MeshMaterial3d<FieldReceiverMaterial>>,
    Mut<'a, Problems>,
);

/// A terrain as a receiver sees it: what it draws and where it lies, or its stream.
type Terrain<'a> =
    (Option<Ref<'a, HorizonTerrain>>, Option<Ref<'a, GlobalTransform>>, Option<&'a Streaming>, Has<StreamedTerrain>);

/// Builds each receiver that is new or changed, whose terrain changed, moved, was rebaked or
/// (streamed) restarted its stream; a receiver naming an entity without a terrain says so until
/// it names one.
pub(crate) fn attach(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<HikageBundle>>,
    bundles: Res<Assets<HikageBundle>>,
    mut receivers: Query<Receiver>,
    terrains: Query<Terrain>,
    mut materials: ResMut<Assets<TerrainReceiverMaterial>>,
    mut field_materials: ResMut<Assets<FieldReceiverMaterial>>,
) {
    let reloaded: Vec<_> =
        events.read().filter_map(|e| if let AssetEvent::Modified { id } = e { Some(*id) } else { None }).collect();
    for (entity, receiver, built, on_field, mut problems) in &mut receivers {
        let (terrain, placed, streaming, streamed) =
            terrains.get(receiver.terrain).unwrap_or((None, None, None, false));
        if streamed && streaming.is_none() {
            // Its stream has not started (its manifest is read), or cannot (said on the terrain).
            Problems::set(&mut problems, Check::Names, None);
            continue;
        }
        if let Some(streaming) = streaming {
            Problems::set(&mut problems, Check::Names, None);
            let map = match &streaming.field {
                Ok(_) => None,
                Err(message) => Some(format!("terrain receiver: {message}")),
            };
            let failed = map.is_some();
            Problems::set(&mut problems, Check::Build, map);
            let current = on_field.and_then(|m| field_materials.get(&m.0)).is_some_and(|m| {
                m.extension.terrain == receiver.terrain && m.extension.generation == streaming.generation
            });
            if failed || (current && !receiver.is_changed()) {
                continue;
            }
            let extension = FieldReceiverExtension { terrain: receiver.terrain, generation: streaming.generation };
            let material = ExtendedMaterial { base: receiver.base.clone(), extension };
            commands
                .entity(entity)
                .remove::<MeshMaterial3d<TerrainReceiverMaterial>>()
                .insert(MeshMaterial3d(field_materials.add(material)));
            continue;
        }
        let (Some(terrain), Some(placed)) = (terrain, placed) else {
            let message = format!(
                "terrain receiver {entity}: entity {} has no HorizonTerrain or StreamedTerrain",
                receiver.terrain
            );
            Problems::set(&mut problems, Check::Names, Some(message));
            continue;
        };
        Problems::set(&mut problems, Check::Names, None);
        let stale = receiver.is_changed()
            || terrain.is_changed()
            || placed.is_changed()
            || reloaded.contains(&terrain.bundle.id());
        if (built || problems.get(Check::Build).is_some()) && !stale {
            continue;
        }
        let Some(bundle) = bundles.get(&terrain.bundle) else { continue };
        match TerrainReceiverExtension::new(bundle, &terrain, &placed) {
            Ok(extension) => {
                let material = ExtendedMaterial { base: receiver.base.clone(), extension };
                commands
                    .entity(entity)
                    .remove::<MeshMaterial3d<FieldReceiverMaterial>>()
                    .insert(MeshMaterial3d(materials.add(material)));
                Problems::set(&mut problems, Check::Build, None);
            }
            Err(message) => Problems::set(&mut problems, Check::Build, Some(format!("terrain receiver: {message}"))),
        }
    }
}

impl SunShadowed for TerrainReceiver {}

impl ShadesOwnMesh for TerrainReceiver {
    const NO_MESH: &'static str = "a TerrainReceiver shades the entity's own mesh, and this entity has no Mesh3d";
}
