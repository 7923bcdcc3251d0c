//! Horizon-shadowed terrain: [`HorizonTerrain`] on an entity becomes the bundle's heightfield
//! grid drawn with [`TerrainMaterial`] — Bevy's `StandardMaterial` whose first directional
//! light is shadowed by the baked horizon map and whose occlusion is the baked AO.

use bevy_asset::{Asset, AssetEvent, Assets, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_math::Vec2;
use bevy_mesh::{Mesh, Mesh3d};
use bevy_pbr::{ExtendedMaterial, MaterialExtension, MeshMaterial3d, StandardMaterial};
use bevy_reflect::Reflect;
use bevy_render::render_resource::{AsBindGroup, ShaderType};
use bevy_shader::ShaderRef;
use hikage_bundle::{AssetKind, Settings, TextureFormat};

use crate::{HikageBundle, HikageError};

/// Bevy's `StandardMaterial` with horizon shadows and baked ambient occlusion.
pub type TerrainMaterial = ExtendedMaterial<StandardMaterial, TerrainExtension>;

/// Draws a bundle's terrain: put it on an entity with a `Transform`, and once the bundle has
/// loaded the entity gets the heightfield's grid mesh and a [`TerrainMaterial`].
///
/// The sun is the scene's first `DirectionalLight`; it must have `shadows_enabled` (Bevy applies
/// a material's shadow factor only to shadow-casting lights), and its `sun_disk_angular_size`
/// is the disc whose visible share the horizon test returns. Bevy's cascades still shadow the
/// terrain (other casters on it, and the terrain on itself): the two visibilities multiply.
///
/// ```no_run
/// # use bevy_ecs::prelude::*;
/// # use bevy_asset::AssetServer;
/// use hikage_bevy::HorizonTerrain;
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>) {
///     let bundle = assets.load("bundle/bundle.ron");
///     commands.spawn(HorizonTerrain::new(bundle, "terrain.horizon").with_ao("terrain.ao"));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility)]
pub struct HorizonTerrain {
    /// The bundle holding the assets.
    pub bundle: Handle<HikageBundle>,
    /// The `Horizon` asset's id; its heightfield is the one its settings name.
    pub horizon: String,
    /// An `AmbientOcclusion` asset's id, or `None` for an open sky.
    pub ao: Option<String>,
    /// The surface under the shadows: colour, roughness, textures (UVs span the heightfield).
    pub base: StandardMaterial,
}

impl HorizonTerrain {
    /// The terrain of horizon asset `horizon` in `bundle`, white and rough, with no AO.
    pub fn new(bundle: Handle<HikageBundle>, horizon: impl Into<String>) -> HorizonTerrain {
        HorizonTerrain {
            bundle,
            horizon: horizon.into(),
            ao: None,
            base: StandardMaterial { perceptual_roughness: 1.0, ..StandardMaterial::default() },
        }
    }

    /// The same, with ambient occlusion asset `ao`.
    pub fn with_ao(mut self, ao: impl Into<String>) -> HorizonTerrain {
        self.ao = Some(ao.into());
        self
    }

    /// The same over `base` (colour, textures, roughness).
    pub fn with_base(mut self, base: StandardMaterial) -> HorizonTerrain {
        self.base = base;
        self
    }
}

/// The terrain half of [`TerrainMaterial`]: the horizon map, the AO map and how to read them.
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
pub struct TerrainExtension {
    /// How the horizon map stores texels and the terrain's texel size.
    #[uniform(100)]
    pub uniform: TerrainUniform,
    /// The horizon map (3D: u, v, azimuth).
    #[texture(101, dimension = "3d")]
    #[sampler(102)]
    pub horizon: Handle<Image>,
    /// The ambient occlusion map (occlusion, 0 open sky), if any.
    #[texture(103)]
    #[sampler(104)]
    pub ao: Option<Handle<Image>>,
}

/// The uniform of [`TerrainExtension`] (WGSL `HikageTerrain`).
#[derive(ShaderType, Reflect, Debug, Clone, Copy, Default)]
pub struct TerrainUniform {
    /// 0: float texels as they are; 1: `Rg8Unorm` (`β/π + ½`, 0 open sky).
    pub format: u32,
    /// World units of distance per unit of the distance channel (`Rg8Unorm`).
    pub distance_scale: f32,
    /// `tan β` of open sky (`Rg8Unorm`'s code 0).
    pub open_sky_slope: f32,
    /// 1 when `ao` holds the baked occlusion.
    pub has_ao: u32,
    /// World units per texel along u and v.
    pub texel_size: Vec2,
    /// 1 to apply the horizon test, 0 to leave the light as Bevy computes it.
    pub horizon: u32,
    /// Padding to 16 bytes.
    pub _pad: u32,
}

impl MaterialExtension for TerrainExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::TERRAIN.into()
    }
}

/// What a terrain's assets give: its grid, its material's extension.
fn terrain_parts(bundle: &HikageBundle, terrain: &HorizonTerrain) -> Result<(Handle<Mesh>, TerrainExtension), String> {
    let asset =
        bundle.asset(&terrain.horizon).ok_or_else(|| format!("no asset `{}` in the bundle", terrain.horizon))?;
    let Settings::Horizon(settings) = &asset.settings else {
        return Err(format!("asset `{}` is a {:?}, expected a Horizon", terrain.horizon, asset.kind));
    };
    let format = asset.payload.texture().map(|d| d.format);
    let horizon =
        bundle.image(&terrain.horizon).cloned().ok_or_else(|| format!("asset `{}` has no image", asset.id))?;
    let grid = bundle
        .grid(&settings.heightfield)
        .cloned()
        .ok_or_else(|| format!("heightfield `{}` (of `{}`) is not in the bundle", settings.heightfield, asset.id))?;
    let ao = match &terrain.ao {
        None => None,
        Some(id) => {
            let a = bundle.asset(id).ok_or_else(|| format!("no ambient occlusion asset `{id}` in the bundle"))?;
            if a.kind != AssetKind::AmbientOcclusion {
                return Err(format!("asset `{id}` is a {:?}, expected an AmbientOcclusion", a.kind));
            }
            Some(bundle.image(id).cloned().ok_or_else(|| format!("asset `{id}` has no image"))?)
        }
    };
    let uniform = TerrainUniform {
        format: u32::from(format == Some(TextureFormat::Rg8Unorm)),
        distance_scale: settings.distance_scale,
        open_sky_slope: settings.open_sky_slope,
        has_ao: u32::from(ao.is_some()),
        texel_size: Vec2::new(settings.texel_size.0, settings.texel_size.1),
        horizon: 1,
        _pad: 0,
    };
    Ok((grid, TerrainExtension { uniform, horizon, ao }))
}

/// A terrain entity as [`build_terrains`] sees it: built already, or failed.
type TerrainState<'a> = (Entity, Ref<'a, HorizonTerrain>, Has<MeshMaterial3d<TerrainMaterial>>, Has<HikageError>);

/// Gives each [`HorizonTerrain`] its mesh and material once its bundle has loaded, and again
/// when the component changes or the bundle is reloaded.
pub(crate) fn build_terrains(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<HikageBundle>>,
    bundles: Res<Assets<HikageBundle>>,
    mut materials: ResMut<Assets<TerrainMaterial>>,
    terrains: Query<TerrainState>,
) {
    let reloaded: Vec<_> =
        events.read().filter_map(|e| if let AssetEvent::Modified { id } = e { Some(*id) } else { None }).collect();
    for (entity, terrain, built, failed) in &terrains {
        let stale = terrain.is_changed() || reloaded.contains(&terrain.bundle.id());
        if (built || failed) && !stale {
            continue;
        }
        let Some(bundle) = bundles.get(&terrain.bundle) else {
            continue;
        };
        match terrain_parts(bundle, &terrain) {
            Ok((grid, extension)) => {
                let material = materials.add(ExtendedMaterial { base: terrain.base.clone(), extension });
                commands.entity(entity).remove::<HikageError>().insert((Mesh3d(grid), MeshMaterial3d(material)));
            }
            Err(message) => {
                bevy_log::error!("hikage terrain: {message}");
                commands.entity(entity).insert(HikageError(message));
            }
        }
    }
}
