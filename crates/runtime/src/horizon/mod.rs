//! Horizon shadows (seed 000, Onoue, Max & Nishita): the WGSL, its CPU reference, and two
//! components that draw with it.
//!
//! - [`TerrainShadows`]: a heightfield drawn as a grid, lit by a sun with a soft edge from its
//!   angular radius, with the baked ambient occlusion; horizon maps' most common use in games.
//! - [`SurfaceShadows`]: a bump map on a curved mesh, with the curvature correction of eq. (1)–(3)
//!   from the mesh's baked curvature.
//!
//! [`HORIZON_WGSL`] holds the functions both use, for a game's own shaders; each has a CPU
//! function of the same name and argument order here, which the tests compare with the GPU.
//! The conventions (texel space, azimuth, world units) and the equations are stated in the
//! repository's `docs/conventions.md`; in short:
//!
//! - the horizon map lives in the *bump frame*: `x` along +u, `y` along +v, `z` up, in the
//!   heightfield's world units;
//! - the azimuth is taken in texel space: a bump-frame direction `(x, y)` has texel direction
//!   `(x / sx, y / sy)` for texel size `(sx, sy)` ([`reference::horizon_texel_azimuth`]);
//! - a light on a mesh enters the bump frame through the seed's frame `(P_u, P_v, N/|N|^½)`
//!   scaled so one tile of the map spans its world size ([`reference::horizon_surface_light`]).

mod field_tiles;
pub mod reference;
mod residency;
mod stream;
pub(crate) mod sun_field;
mod surface;
mod terrain;
mod tile_data;
mod tile_plan;

use hikage_bundle::{EdgeMode, HorizonSettings, TextureFormat};

pub use field_tiles::{FieldMap, FieldTileTextures, SunFieldTiles};
pub use residency::{BudgetShortfall, ResidencyFrame, TileReads, TileResidency, TileStore, check_budgets};
pub use stream::{MAX_TILE_SIDE, StreamOptions, StreamStats, TerrainStream};
pub use sun_field::{
    FieldTerrain, MAX_SUN_FIELD_LEVELS, SUN_FIELD_UNIFORM_BYTES, SUN_FIELD_WGSL, SunField, SunFieldOptions,
    SunFieldSource, SunFieldStats,
};
pub use surface::{SurfaceFrame, SurfaceShadows, SurfaceUniform};
pub use terrain::{Sun, TerrainExtent, TerrainFrame, TerrainShadows, TerrainUniform};
pub use tile_data::{apron_neighbours, heights_with_apron, tile_device_bytes, tile_unchanged};
pub use tile_plan::{MAX_PENDING_TILES, TileKey, TileLayout, TileLevel, TileParts, TilePlan};

/// WGSL of the horizon functions (no bindings); include it in a shader module. The components
/// prepend it to their own WGSL.
pub const HORIZON_WGSL: &str = include_str!("../shaders/horizon.wgsl");

/// How a horizon texture stores its texels, as the WGSL `HorizonEncoding` uniform field takes
/// it: format 0 float (values as they are), 1 `Rg8Unorm` or `Bc5RgUnorm` (`β/π + 0.5`, 0 open
/// sky; distance over `distance_scale`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HorizonEncoding {
    /// 0 float, 1 rg8 or BC5.
    pub format: u32,
    /// World units of distance per unit of channel 1 (rg8).
    pub distance_scale: f32,
    /// `tan β` of open sky (rg8's code 0).
    pub open_sky_slope: f32,
    /// Padding to 16 bytes.
    pub _pad: f32,
}

impl HorizonEncoding {
    /// The encoding of a horizon texture of `format` baked with `settings`.
    pub fn new(format: TextureFormat, settings: &HorizonSettings) -> HorizonEncoding {
        HorizonEncoding {
            format: u32::from(format.is_unorm()),
            distance_scale: settings.distance_scale,
            open_sky_slope: settings.open_sky_slope,
            _pad: 0.0,
        }
    }
}

/// The sampler a horizon texture wants: linear filtering (nearest for `Rg32Float` on devices
/// without `FLOAT32_FILTERABLE`), `Repeat` on `w` so directions interpolate and wrap 2π → 0,
/// and on `u`, `v` what the bake's edge mode means: `Repeat` for tiling bump maps,
/// `ClampToEdge` for terrain (a clamped map's edge texels are not blended with the far side).
pub fn horizon_sampler(device: &wgpu::Device, edge: EdgeMode, filterable: bool) -> wgpu::Sampler {
    let uv = match edge {
        EdgeMode::Wrap => wgpu::AddressMode::Repeat,
        EdgeMode::Clamp => wgpu::AddressMode::ClampToEdge,
    };
    let filter = if filterable { wgpu::FilterMode::Linear } else { wgpu::FilterMode::Nearest };
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("hikage horizon"),
        address_mode_u: uv,
        address_mode_v: uv,
        address_mode_w: wgpu::AddressMode::Repeat,
        mag_filter: filter,
        min_filter: filter,
        ..Default::default()
    })
}

/// True when `device` can filter a horizon texture of `format` (32-bit floats need
/// `Features::FLOAT32_FILTERABLE`).
pub fn horizon_filterable(device: &wgpu::Device, format: TextureFormat) -> bool {
    format != TextureFormat::Rg32Float || device.features().contains(wgpu::Features::FLOAT32_FILTERABLE)
}
