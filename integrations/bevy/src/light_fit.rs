//! Shadow maps fitted to what the camera sees: [`FittedShadows`] on a `DirectionalLight`
//! replaces Bevy's cascades with one shadow map per view whose projection is fitted each frame
//! to the bounding sphere of the visible geometry (Iwao, Kanbara & Yokoya; hikage-runtime's
//! `shadow_fit`), optionally in the camera's post-perspective space (PSM), with texel
//! snapping so shadow edges hold still.

use std::collections::HashMap;

use bevy_asset::{AssetEvent, AssetId, Assets};
use bevy_camera::Camera;
use bevy_camera::primitives::Aabb;
use bevy_ecs::prelude::*;
use bevy_light::cascade::Cascade;
use bevy_light::{CascadeShadowConfig, Cascades, DirectionalLight, DirectionalLightShadowMap};
use bevy_math::{Mat4, Vec3A};
use bevy_mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology, VertexAttributeValues};
use bevy_transform::components::GlobalTransform;
use hikage_runtime::glam as rg;
use hikage_runtime::shadow_fit::{self, FitOptions, Light, MeshRef, Scratch, Sphere};
pub use hikage_runtime::shadow_fit::{FitKind, FitSpace, FitTarget, PullBack, Snap, VisibleTest};

/// Fits a `DirectionalLight`'s shadow map to the visible geometry each frame, in place of
/// Bevy's cascades: one map per camera covering exactly the meshes that camera sees (and the
/// casters between them and the light), so its texels land where they are looked at. The
/// light keeps `shadow_maps_enabled`; its `CascadeShadowConfig` becomes a single cascade that
/// reaches as far as the camera sees.
///
/// Meshes need their vertex data in the main world (Bevy's default `RenderAssetUsages`).
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::FittedShadows;
///
/// fn setup(mut commands: Commands) {
///     commands.spawn((
///         DirectionalLight { shadow_maps_enabled: true, ..default() },
///         Transform::from_xyz(1.0, 2.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
///         FittedShadows::default(),
///     ));
/// }
/// ```
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(DirectionalLight)]
pub struct FittedShadows {
    /// What the fit bounds: the visible geometry (the method's own) or the whole view frustum.
    pub target: FitTarget,
    /// World space, or the camera's post-perspective space (PSM).
    pub space: FitSpace,
    /// Keep the fitted size and centre on the texel grid (still edges as the camera moves).
    pub snap: Snap,
}

impl Default for FittedShadows {
    /// The visible geometry (triangles clipped to the view), in world space, snapped.
    fn default() -> FittedShadows {
        FittedShadows {
            target: FitTarget::Visible(VisibleTest::ClippedTriangles),
            space: FitSpace::World,
            snap: Snap::TexelGrid,
        }
    }
}

/// A mesh's positions and triangle list as the fit reads them.
#[derive(Default)]
pub(crate) struct MeshGeometry {
    positions: Vec<rg::Vec3>,
    indices: Vec<u32>,
}

/// What the fit keeps between frames: geometry per mesh asset (until the asset changes) and
/// the fit's buffers.
#[derive(Default)]
pub(crate) struct FitState {
    geometry: HashMap<AssetId<Mesh>, Option<MeshGeometry>>,
    scratch: Scratch,
}

/// A triangle-list mesh's positions and triangles (other topologies cast no shadow here).
fn geometry(mesh: &Mesh) -> Option<MeshGeometry> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return None;
    }
    let Some(VertexAttributeValues::Float32x3(positions)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        return None;
    };
    let indices = match mesh.indices() {
        Some(Indices::U32(i)) => i.clone(),
        Some(Indices::U16(i)) => i.iter().map(|&k| k as u32).collect(),
        None => (0..positions.len() as u32).collect(),
    };
    Some(MeshGeometry { positions: positions.iter().map(|&p| rg::Vec3::from_array(p)).collect(), indices })
}

fn to_rg(m: Mat4) -> rg::Mat4 {
    rg::Mat4::from_cols_array(&m.to_cols_array())
}

fn from_rg(m: rg::Mat4) -> Mat4 {
    Mat4::from_cols_array(&m.to_cols_array())
}

/// hikage's light clip space (depth 0 near the light, 1 far) to Bevy's reversed depth.
const REVERSE_DEPTH: Mat4 =
    Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 1.0]);

/// How far a fitted cascade reaches along the view: every fragment the camera draws.
const FITTED_REACH: f32 = 1.0e9;

/// Runs after Bevy builds its cascades and before it derives the lights' culling frusta from
/// them: each [`FittedShadows`] light's cascades become one fitted map per active camera.
pub(crate) fn fit_shadows(
    shadow_map: Res<DirectionalLightShadowMap>,
    meshes: Res<Assets<Mesh>>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    views: Query<(Entity, &GlobalTransform, &Camera)>,
    geometry_entities: Query<(&Mesh3d, &GlobalTransform, Option<&Aabb>)>,
    mut lights: Query<(&GlobalTransform, &DirectionalLight, &FittedShadows, &mut Cascades, &mut CascadeShadowConfig)>,
    mut state: Local<FitState>,
) {
    let FitState { geometry: cache, scratch } = &mut *state;
    for event in mesh_events.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            cache.remove(id);
        }
    }
    if lights.is_empty() {
        return;
    }
    let mut instances = Vec::new();
    let mut bounds = Vec::new();
    for (mesh, transform, aabb) in &geometry_entities {
        let Some(asset) = meshes.get(mesh.id()) else {
            continue; // not loaded yet
        };
        cache.entry(mesh.id()).or_insert_with(|| geometry(asset));
        let world = transform.to_matrix();
        if let Some(aabb) = aabb {
            for k in 0..8 {
                let corner = Vec3A::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -1.0 } else { 1.0 },
                    if k & 4 == 0 { -1.0 } else { 1.0 },
                );
                let p = world.transform_point3a(aabb.center + corner * aabb.half_extents);
                bounds.push(rg::Vec3::new(p.x, p.y, p.z));
            }
        }
        instances.push((mesh.id(), to_rg(world)));
    }
    let refs: Vec<MeshRef> = instances
        .iter()
        .filter_map(|(id, world)| {
            let g = cache.get(id)?.as_ref()?;
            Some(MeshRef { world: *world, positions: &g.positions, indices: &g.indices })
        })
        .collect();
    let scene = shadow_fit::bounding_sphere(&bounds).unwrap_or(Sphere { centre: rg::Vec3::ZERO, radius: 1.0 });
    let resolution = shadow_map.size as u32;
    for (transform, light, fitted, mut cascades, mut config) in &mut lights {
        if !light.shadow_maps_enabled {
            continue;
        }
        if config.bounds.len() != 1 || config.bounds[0] != FITTED_REACH {
            *config =
                CascadeShadowConfig { bounds: vec![FITTED_REACH], overlap_proportion: 0.0, minimum_distance: 0.0 };
        }
        let world_from_light = Mat4::from_quat(transform.rotation());
        let direction = world_from_light.transform_vector3(bevy_math::Vec3::NEG_Z);
        let sun = Light::Directional(rg::Vec3::new(direction.x, direction.y, direction.z));
        cascades.cascades.clear();
        for (view, camera_transform, camera) in &views {
            if !camera.is_active {
                continue;
            }
            let camera = shadow_fit::Camera {
                view: to_rg(camera_transform.to_matrix().inverse()),
                projection: to_rg(camera.clip_from_view()),
            };
            let options = FitOptions {
                resolution,
                target: fitted.target,
                space: fitted.space,
                snap: fitted.snap,
                ..FitOptions::new(scene)
            };
            let mut fit = shadow_fit::fit(sun, &camera, &refs, &options, scratch);
            if fit.kind == FitKind::InvertedPsm {
                // Bevy compares clip depths, which run backwards in the inverted projection.
                fit = shadow_fit::fit(sun, &camera, &refs, &FitOptions { space: FitSpace::World, ..options }, scratch);
            }
            let receivers = shadow_fit::bounding_sphere(&scratch.points).unwrap_or(scene);
            let clip_from_world = REVERSE_DEPTH * from_rg(fit.view_proj);
            cascades.cascades.insert(
                view,
                vec![Cascade {
                    world_from_cascade: world_from_light,
                    clip_from_cascade: clip_from_world * world_from_light,
                    clip_from_world,
                    texel_size: 2.0 * receivers.radius / resolution as f32,
                }],
            );
        }
    }
}
