//! Horizon-shadowed terrain: [`HorizonTerrain`] on an entity becomes the bundle's heightfield
//! grid drawn with [`TerrainMaterial`] — Bevy's `StandardMaterial` whose first directional
//! light is shadowed by the baked horizon map and whose occlusion is the baked AO.

use bevy_asset::{Asset, Handle};
use bevy_ecs::prelude::*;
use bevy_image::Image;
use bevy_math::Vec2;
use bevy_mesh::Mesh;
use bevy_pbr::{ExtendedMaterial, MaterialExtension, StandardMaterial};
use bevy_reflect::Reflect;
use bevy_render::render_resource::{AsBindGroup, ShaderType};
use bevy_shader::ShaderRef;
use hikage_bundle::AssetKind;

use crate::HikageBundle;
use crate::attach::FromBundle;
use crate::diagnostics::{NamesBundle, Problems, SunShadowed};

/// Bevy's `StandardMaterial` with horizon shadows and baked ambient occlusion.
pub type TerrainMaterial = ExtendedMaterial<StandardMaterial, TerrainExtension>;

/// Draws a bundle's terrain: put it on an entity with a `Transform`, and once the bundle has
/// loaded the entity gets the heightfield's grid mesh and a [`TerrainMaterial`].
///
/// The sun is the scene's first `DirectionalLight`; it must have `shadow_maps_enabled` (Bevy
/// applies a material's shadow factor only to a light with shadow maps; without one the entity
/// gets a [`HikageError`](crate::HikageError)), and the angular size of its disc (a `SunDisk` on
/// the light, Earth's sun by default) is the disc whose visible share the horizon test returns.
/// Bevy's cascades still shadow the terrain (other casters on it, and the terrain on itself):
/// the two visibilities multiply. An AO map must be of the same terrain (its horizon's
/// heightfield, its size).
///
/// ```no_run
/// use bevy::prelude::*;
/// use hikage_bevy::HorizonTerrain;
///
/// fn setup(mut commands: Commands, assets: Res<AssetServer>) {
///     let bundle = assets.load("bundle/bundle.ron");
///     commands.spawn(HorizonTerrain::new(bundle, "terrain.horizon").with_ao("terrain.ao"));
/// }
/// ```
#[derive(Component, Clone, Debug)]
#[require(bevy_transform::components::Transform, bevy_camera::visibility::Visibility, Problems)]
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

impl TerrainUniform {
    /// The uniform of a horizon map stored as `encoding` with texels of `texel_size`, with the
    /// horizon test on, reading an AO map when `has_ao`.
    pub fn new(
        encoding: &hikage_runtime::horizon::HorizonEncoding,
        texel_size: (f32, f32),
        has_ao: bool,
    ) -> TerrainUniform {
        TerrainUniform {
            format: encoding.format,
            distance_scale: encoding.distance_scale,
            open_sky_slope: encoding.open_sky_slope,
            has_ao: u32::from(has_ao),
            texel_size: Vec2::new(texel_size.0, texel_size.1),
            horizon: 1,
            _pad: 0,
        }
    }
}

impl MaterialExtension for TerrainExtension {
    fn fragment_shader() -> ShaderRef {
        crate::shaders::TERRAIN.into()
    }
}

impl NamesBundle for HorizonTerrain {
    fn bundle(&self) -> &Handle<HikageBundle> {
        &self.bundle
    }
}

impl SunShadowed for HorizonTerrain {}

impl FromBundle for HorizonTerrain {
    type Material = TerrainMaterial;

    fn build(&self, bundle: &HikageBundle) -> Result<(TerrainMaterial, Option<Handle<Mesh>>), String> {
        let (settings, horizon, encoding) = bundle.horizon(&self.horizon)?;
        let grid = bundle.grid(&settings.heightfield).cloned().ok_or_else(|| {
            format!("heightfield `{}` (of `{}`) is not in the bundle", settings.heightfield, self.horizon)
        })?;
        let ao = match &self.ao {
            None => None,
            Some(id) => Some(ambient_occlusion(bundle, id, &self.horizon, &settings.heightfield)?),
        };
        let uniform = TerrainUniform::new(&encoding, settings.texel_size, ao.is_some());
        let extension = TerrainExtension { uniform, horizon, ao };
        Ok((ExtendedMaterial { base: self.base.clone(), extension }, Some(grid)))
    }
}

/// The image of AO asset `id` for the terrain of `horizon` (of heightfield `heightfield`): of
/// that heightfield and of its size, or why not (another map's AO would be stretched over it).
fn ambient_occlusion(
    bundle: &HikageBundle,
    id: &str,
    horizon: &str,
    heightfield: &str,
) -> Result<Handle<Image>, String> {
    let image = bundle.image_of_kind(id, AssetKind::AmbientOcclusion)?;
    let size = |asset: &str| {
        let desc = bundle.asset(asset).and_then(|a| a.payload.texture());
        desc.map(|d| (d.width, d.height)).ok_or_else(|| format!("asset `{asset}` is not a texture"))
    };
    let (ao, map) = (size(id)?, size(horizon)?);
    if ao != map {
        return Err(format!(
            "AO `{id}` is {}×{}, but terrain `{horizon}` is {}×{}: an AO map must be baked from the same terrain",
            ao.0, ao.1, map.0, map.1
        ));
    }
    let of = bundle.asset(id).and_then(|a| match &a.settings {
        hikage_bundle::Settings::AmbientOcclusion(s) => Some(s.horizon.as_str()),
        _ => None,
    });
    let of_heightfield = of.and_then(|h| bundle.asset(h)).and_then(|a| match &a.settings {
        hikage_bundle::Settings::Horizon(s) => Some(s.heightfield.as_str()),
        _ => None,
    });
    if let Some(other) = of_heightfield.filter(|&h| h != heightfield) {
        return Err(format!(
            "AO `{id}` was baked from heightfield `{other}`, but terrain `{horizon}` is heightfield `{heightfield}`"
        ));
    }
    Ok(image)
}
