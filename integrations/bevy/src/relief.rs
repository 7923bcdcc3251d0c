//! Relief mapping on a game's meshes: [`ReliefSurface`] on an entity with a `Mesh3d` (normals,
//! tangents, UVs) gives it a [`ReliefMaterial`] — Bevy's `StandardMaterial` read at the relief's
//! hit, shaded with the relief's normal, shadowed by the depth maps toward the first directional
//! light and occluded by the same maps.

use std::collections::HashSet;

use bevy_asset::{Asset, AssetEvent, AssetId, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_math::UVec2;
use bevy_mesh::{Mesh, Mesh3d, PrimitiveTopology};
use bevy_pbr::{ExtendedMaterial, MaterialExtension, StandardMaterial};
use bevy_reflect::Reflect;
use bevy_render::render_resource::{AsBindGroup, ShaderType};
use bevy_shader::ShaderRef;
use hikage_bundle::{AssetKind, Settings};
pub use hikage_runtime::relief::{DirectionRule, Tracer, VisibilityPath};

use crate::HikageBundle;
use crate::attach::FromBundle;
use crate::diagnostics::{Check, NamesBundle, Problems, SunShadowed};

/// Bevy's `StandardMaterial` under relief mapping with self-shadowing and ambient occlusion.
pub type ReliefMaterial = ExtendedMaterial<StandardMaterial, ReliefExtension>;

/// Relief-maps an entity's mesh with a bundle's `Relief` asset: put it next to a `Mesh3d`
/// whose mesh has normals and UVs; one relief tile spans one unit of UV, and the relief's depth
/// is its `depth_scale` of a tile's width. A mesh without tangents gets them generated
/// (`Mesh::generate_tangents`, said once in the log); an entity without a `Mesh3d`, or a mesh
/// without normals or UVs, gets a [`HikageError`](crate::HikageError), as does a sun without
/// shadow maps while `shadows` is on.
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::ReliefSurface;
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>, mut meshes: ResMut<Assets<Mesh>>) {
///     let bundle = assets.load("bundle/bundle.ron");
///     let wall = Plane3d::default().mesh().size(4.0, 4.0).build().with_generated_tangents().unwrap();
///     commands.spawn((Mesh3d(meshes.add(wall)), ReliefSurface::new(bundle, "relief_bricks.relief")));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(Problems)]
pub struct ReliefSurface {
    /// The bundle holding the assets.
    pub bundle: Handle<HikageBundle>,
    /// The `Relief` asset's id; its max-mip pyramid is the one its settings name.
    pub relief: String,
    /// The surface read at the hit: colour, textures, roughness.
    pub base: StandardMaterial,
    /// How the view ray is traced.
    pub tracer: Tracer,
    /// Which stored direction a ray reads.
    pub rule: DirectionRule,
    /// How shadows and occlusion decide visibility.
    pub visibility: VisibilityPath,
    /// Depth-map shadows toward the first directional light.
    pub shadows: bool,
    /// Ambient occlusion over every n-th stored direction; 0 turns it off.
    pub ao_stride: u32,
    /// Depth a stored hit may lie above a point that still counts as lit.
    pub bias: f32,
}

impl ReliefSurface {
    /// Relief asset `relief` of `bundle` with hikage-runtime's defaults: the combined tracer
    /// (depth-map estimate pulled back 10%, max-mip from level 3), shadows, AO over every 16th
    /// direction.
    pub fn new(bundle: Handle<HikageBundle>, relief: impl Into<String>) -> ReliefSurface {
        ReliefSurface {
            bundle,
            relief: relief.into(),
            base: StandardMaterial::default(),
            tracer: Tracer::Combined { margin: 0.1, start_level: 3 },
            rule: DirectionRule::default(),
            visibility: VisibilityPath::default(),
            shadows: true,
            ao_stride: 16,
            bias: 0.02,
        }
    }

    /// The same over `base` (colour, textures, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> ReliefSurface {
        self.base = base;
        self
    }
}

/// The relief half of [`ReliefMaterial`].
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub struct ReliefExtension {
    /// Shadows, occlusion and bias.
    #[uniform(100)]
    pub shading: ReliefShading,
    /// The max-mip pyramid of the heights.
    #[texture(101, sample_type = "float", filterable = false)]
    pub heights: Handle<Image>,
    /// The depth maps, one layer per stored direction.
    #[texture(102, dimension = "2d_array", sample_type = "float", filterable = false)]
    pub depths: Handle<Image>,
    /// The maps' sizes and direction table, the tracer and its settings.
    #[uniform(103)]
    pub tracing: ReliefTracing,
}

/// The shading uniform of [`ReliefExtension`] (WGSL `HikageRelief`).
#[derive(ShaderType, Reflect, Debug, Clone, Copy, Default)]
pub struct ReliefShading {
    /// Ambient occlusion over every n-th direction; 0 off.
    pub ao_stride: u32,
    /// 1: depth-map shadows.
    pub shadows: u32,
    /// Depth a stored hit may lie above a point that still counts as lit.
    pub bias: f32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

/// hikage-runtime's `ReliefUniform` as Bevy's uniform type (WGSL `ReliefUniform`).
#[derive(ShaderType, Reflect, Debug, Clone, Copy, Default)]
#[expect(missing_docs, reason = "the fields are hikage_runtime::relief::ReliefUniform's, documented there")]
pub struct ReliefTracing {
    pub size: UVec2,
    pub depth_size: UVec2,
    pub levels: u32,
    pub theta_rows: u32,
    pub phi_cols: u32,
    pub tracer: u32,
    pub thickness: f32,
    pub steps: u32,
    pub binary: u32,
    pub start_level: u32,
    pub stop_level: u32,
    pub margin: f32,
    pub direction_rule: u32,
    pub visibility: u32,
    pub visibility_steps: u32,
    pub visibility_binary: u32,
    pub _pad: UVec2,
}

impl From<hikage_runtime::relief::ReliefUniform> for ReliefTracing {
    fn from(u: hikage_runtime::relief::ReliefUniform) -> ReliefTracing {
        ReliefTracing {
            size: UVec2::from(u.size),
            depth_size: UVec2::from(u.depth_size),
            levels: u.levels,
            theta_rows: u.theta_rows,
            phi_cols: u.phi_cols,
            tracer: u.tracer,
            thickness: u.thickness,
            steps: u.steps,
            binary: u.binary,
            start_level: u.start_level,
            stop_level: u.stop_level,
            margin: u.margin,
            direction_rule: u.direction_rule,
            visibility: u.visibility,
            visibility_steps: u.visibility_steps,
            visibility_binary: u.visibility_binary,
            _pad: UVec2::ZERO,
        }
    }
}

impl MaterialExtension for ReliefExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::RELIEF.into()
    }
}

impl NamesBundle for ReliefSurface {
    fn bundle(&self) -> &Handle<HikageBundle> {
        &self.bundle
    }
}

impl SunShadowed for ReliefSurface {
    fn shadowed_by_sun(&self) -> bool {
        self.shadows
    }
}

impl FromBundle for ReliefSurface {
    type Material = ReliefMaterial;

    fn build(&self, bundle: &HikageBundle) -> Result<(ReliefMaterial, Option<Handle<Mesh>>), String> {
        let depths = bundle.image_of_kind(&self.relief, AssetKind::Relief)?;
        let asset = bundle.asset(&self.relief).ok_or_else(|| format!("no asset `{}`", self.relief))?;
        let Settings::Relief(settings) = &asset.settings else {
            return Err(format!("asset `{}` has no relief settings", self.relief));
        };
        let heights = bundle.image_of_kind(&settings.max_mip, AssetKind::MaxMip)?;
        let (Some(depth), Some(max_mip)) =
            (asset.payload.texture(), bundle.asset(&settings.max_mip).and_then(|a| a.payload.texture()))
        else {
            return Err(format!("asset `{}` or `{}` is not a texture", self.relief, settings.max_mip));
        };
        let tracing = hikage_runtime::relief::ReliefUniform::for_maps(settings, depth, max_mip)
            .with_tracer(self.tracer)
            .with_reads(self.rule, self.visibility);
        let shading =
            ReliefShading { ao_stride: self.ao_stride, shadows: u32::from(self.shadows), bias: self.bias, _pad: 0 };
        let extension = ReliefExtension { shading, heights, depths, tracing: tracing.into() };
        Ok((ExtendedMaterial { base: self.base.clone(), extension }, None))
    }
}

/// Checks the mesh of each [`ReliefSurface`]: there is one, a triangle list with normals and
/// UVs; tangents are generated where they are missing (on a copy, so a mesh that cannot take
/// them is left untouched, and not tried again until it changes). A mesh still loading, or whose
/// vertex data lives only in the render world, is not judged.
pub(crate) fn check_mesh(
    mut meshes: ResMut<Assets<Mesh>>,
    mut events: MessageReader<AssetEvent<Mesh>>,
    mut untangentable: Local<HashSet<AssetId<Mesh>>>,
    mut surfaces: Query<(Entity, Option<&Mesh3d>, &mut Problems), With<ReliefSurface>>,
) {
    for event in events.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            untangentable.remove(id);
        }
    }
    for (entity, mesh, mut problems) in &mut surfaces {
        let Some(mesh) = mesh else {
            if problems.get(Check::Mesh) != Some(NO_MESH) {
                Problems::set(&mut problems, Check::Mesh, Some(NO_MESH.to_string()));
            }
            continue;
        };
        let Some(m) = meshes.get(&mesh.0) else { continue };
        let problem = match relief_mesh(m) {
            Ok(true) => None,
            Ok(false) if untangentable.contains(&mesh.id()) => continue,
            Ok(false) => match m.clone().with_generated_tangents() {
                Ok(with) => {
                    if let Some(mut m) = meshes.get_mut(&mesh.0) {
                        *m = with;
                    }
                    bevy_log::warn!("hikage: entity {entity}: its mesh had no tangents, generated for relief mapping");
                    None
                }
                Err(e) => {
                    untangentable.insert(mesh.id());
                    Some(format!("its mesh has no tangents, and they cannot be generated: {e}"))
                }
            },
            Err(message) => Some(message),
        };
        Problems::set(&mut problems, Check::Mesh, problem);
    }
}

/// What a [`ReliefSurface`] without a `Mesh3d` says.
const NO_MESH: &str =
    "a ReliefSurface draws on the entity's own mesh, and this entity has no Mesh3d: add one with normals and UVs";

/// Whether `mesh` has tangents (`Ok(false)`: missing, but it has what generating them needs),
/// or why relief mapping cannot use it.
fn relief_mesh(mesh: &Mesh) -> Result<bool, String> {
    let has = |attribute| mesh.try_contains_attribute(attribute).unwrap_or(true);
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(format!("its mesh is a {:?}: relief mapping needs a triangle list", mesh.primitive_topology()));
    }
    let missing: Vec<&str> = [(Mesh::ATTRIBUTE_NORMAL, "normals"), (Mesh::ATTRIBUTE_UV_0, "UVs")]
        .into_iter()
        .filter(|(a, _)| !has(a.id))
        .map(|(_, name)| name)
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "its mesh has no {}: relief mapping needs normals, UVs and tangents",
            missing.join(" and ")
        ));
    }
    Ok(has(Mesh::ATTRIBUTE_TANGENT.id))
}
