//! The settings an asset was baked with, one struct per kind ([`Settings`]), as the manifest
//! records them: what a reader needs to use the payload (a horizon's texel size and encoding, a
//! heightfield's world heights, a tile's place in its map) and what a rebake compares.

use serde::{Deserialize, Serialize};

/// Settings an asset was baked with, by kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Settings {
    /// No hikage-specific settings (generic textures and meshes).
    Generic,
    /// A heightfield import.
    Heightfield(HeightfieldSettings),
    /// A horizon bake.
    Horizon(HorizonSettings),
    /// Ambient occlusion from horizons.
    AmbientOcclusion(AmbientOcclusionSettings),
    /// Curvature of a mesh.
    Curvature(CurvatureSettings),
    /// Relief depth maps.
    Relief(ReliefSettings),
    /// A max-mip pyramid.
    MaxMip(MaxMipSettings),
    /// Hair strips.
    Strands(StrandsSettings),
    /// Strand roots bound to a scalp.
    HairBinding(HairBindingSettings),
    /// A skinned scalp.
    Scalp(ScalpSettings),
}

impl Settings {
    /// Ids of the other assets these settings name and a reader needs with them: a horizon's
    /// heightfield, an ambient-occlusion map's horizon, relief maps' max-mip pyramid, a hair
    /// binding's strands and scalp.
    pub fn depends_on(&self) -> Vec<&str> {
        match self {
            Settings::Horizon(h) => vec![h.heightfield.as_str()],
            Settings::AmbientOcclusion(a) => vec![a.horizon.as_str()],
            Settings::Relief(r) => vec![r.max_mip.as_str()],
            Settings::HairBinding(b) => vec![b.strands.as_str(), b.scalp.as_str()],
            _ => Vec::new(),
        }
    }

    /// Where the asset lies in a map baked in tiles: a tile's heights, horizons or occlusion.
    /// `None` for whole maps and other kinds.
    pub fn tile(&self) -> Option<&TilePlacement> {
        match self {
            Settings::Horizon(h) => h.tile.as_ref(),
            Settings::Heightfield(h) => h.tile.as_ref(),
            Settings::AmbientOcclusion(a) => a.tile.as_ref(),
            _ => None,
        }
    }
}

/// `Settings::heightfield()` and its siblings: the settings of one kind, or `None`.
macro_rules! settings_accessors {
    ($($name:ident => $variant:ident($ty:ty)),* $(,)?) => {
        impl Settings {
            $(
                #[doc = concat!("The settings of a `", stringify!($variant), "` asset, or `None` for another kind.")]
                pub fn $name(&self) -> Option<&$ty> {
                    match self {
                        Settings::$variant(s) => Some(s),
                        _ => None,
                    }
                }
            )*
        }
    };
}

settings_accessors! {
    heightfield => Heightfield(HeightfieldSettings),
    horizon => Horizon(HorizonSettings),
    ambient_occlusion => AmbientOcclusion(AmbientOcclusionSettings),
    curvature => Curvature(CurvatureSettings),
    relief => Relief(ReliefSettings),
    max_mip => MaxMip(MaxMipSettings),
    strands => Strands(StrandsSettings),
    hair_binding => HairBinding(HairBindingSettings),
    scalp => Scalp(ScalpSettings),
}

/// How a hair's strands were bound to a skinned scalp: each root to the nearest point of the
/// scalp's triangles. At run time a strand moves rigidly with its triangle: its points keep
/// their place in the frame of the deformed triangle (origin at the bound point, axes from the
/// first edge and the face normal).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HairBindingSettings {
    /// Id of the `Strands` asset whose strands are bound (one binding element per strand id).
    pub strands: String,
    /// Id of the `Scalp` asset the triangles belong to.
    pub scalp: String,
    /// The farthest any root lies from its bound surface point (world units).
    pub max_distance: f32,
}

/// A skinned scalp: the triangles of a glTF skin's mesh that hair roots were bound to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScalpSettings {
    /// The skin's joints, in the skin's order (a vertex's `joints` index this list): the glTF
    /// nodes' names, `node N` for a node without one. A game's joint matrices come in this order.
    pub joints: Vec<String>,
    /// Triangles of the source mesh (those kept are the ones a root is bound to).
    pub source_triangles: u32,
}

/// How hair strips were baked (seed 004). Widths and opacities are those of a strand with the
/// source's default thickness and transparency; each point's record carries its own shading
/// width and opacity, and its opacity-set values are those times `opacity / shading`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StrandsSettings {
    /// Strands.
    pub strands: u32,
    /// Points (one record each).
    pub points: u32,
    /// Shading set: full width (world units) and opacity.
    pub shading: (f32, f32),
    /// Opacity set: full width (world units) and opacity.
    pub opacity: (f32, f32),
    /// Width at the tip as a share lost: width × (1 − taper × param). The renderer applies it
    /// (and may override it); the records hold untapered widths.
    pub taper: f32,
    /// Opacity-map resolution the opacity set was chosen for (`auto`), if it was.
    pub auto_resolution: Option<u32>,
    /// Light-independent bounds: the box around every strip of the wider set.
    pub bounds_min: [f32; 3],
    /// See `bounds_min`.
    pub bounds_max: [f32; 3],
    /// The widest shading width of any point before taper (world units): a record's
    /// `shape.x` is its width as a share of this (since format 1.5).
    #[serde(default)]
    pub max_width: f32,
    /// Levels of detail, finest first: `[strands, points]` of the first strands in the
    /// records that level draws, each level about half the strands of the one before
    /// (since format 1.5).
    #[serde(default)]
    pub levels: Vec<[u32; 2]>,
    /// The shading set's area weighted by opacity: Σ over segments of length × width ×
    /// opacity (world units², since format 1.5), the hair's density for the camera blend.
    #[serde(default)]
    pub opacity_area: f32,
}

/// How a set of relief depth maps was baked (seed 003).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReliefSettings {
    /// Id of the max-mip pyramid baked from the same heightfield (its level 0 is the surface).
    pub max_mip: String,
    /// Rows of zenith angle; layer `i × phi + j` is `θ_i = (i + ½)·90°/theta`.
    pub theta: u32,
    /// Azimuths per row; `φ_j = 360°·j/phi`, texel space from +u toward +v.
    pub phi: u32,
    /// Relief thickness as a share of the map width (depth 1 lies `depth_scale × width` texels
    /// below the top plane).
    pub depth_scale: f32,
    /// Width and height of the heightfield the maps were traced on.
    pub source_size: (u32, u32),
    /// `(θ, φ)` of every layer in degrees, in layer order: the table a shader indexes.
    pub directions: Vec<(f32, f32)>,
}

impl ReliefSettings {
    /// The direction table as the shared geometry type.
    pub fn table(&self) -> crate::relief::ReliefDirections {
        crate::relief::ReliefDirections { theta: self.theta, phi: self.phi }
    }
}

/// What a max-mip pyramid was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaxMipSettings {
    /// The heightfield samples' source channel, as in [`HeightfieldSettings`].
    pub source_channel: String,
}

/// How a curvature mesh was computed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvatureSettings {
    /// Distinct positions in the source mesh (curvature is computed per position and shared
    /// by the vertices that split it at UV seams).
    pub positions: u32,
    /// Neighbourhood of the quadric fit, in rings of edges.
    pub rings: u32,
}

/// What rays do at the edge of a heightfield.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum EdgeMode {
    /// Rays continue on the torus (tileable bump maps).
    #[default]
    Wrap,
    /// Rays stop at the map edge (terrain).
    Clamp,
}

/// How a horizon texture was baked and how to decode it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HorizonSettings {
    /// Id of the heightfield asset baked from the same input.
    pub heightfield: String,
    /// Number of azimuths `D`; direction `k` has `φ = 2πk/D`, measured in texel space from +u
    /// toward +v.
    pub directions: u32,
    /// Edge behaviour.
    pub edge: EdgeMode,
    /// Largest horizon distance searched, world units (`None`: to the edge for `Clamp`, one map
    /// length along the ray's major axis for `Wrap`).
    pub max_distance: Option<f32>,
    /// Texels per ray traced exactly before the line sweep.
    pub near_field: u32,
    /// World units per texel along `u` and `v`.
    pub texel_size: (f32, f32),
    /// Height scale of the heightfield (world = offset + scale × sample).
    pub height_scale: f32,
    /// `tan β` stored for a ray with no sample (open sky).
    pub open_sky_slope: f32,
    /// For `Rg8Unorm`: `tan β = tan((c0 − 0.5) π)`, `d = c1 × distance_scale`; 1 otherwise.
    pub distance_scale: f32,
    /// Where this texture lies in a map baked in tiles (`None`: it is the whole map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

/// The place of one tile of a map baked in tiles. A tile's texture covers texels
/// `origin .. origin + (its width, its height)` of the whole map at its level; at level 0 its
/// texels are those the whole map's bake would have there.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TilePlacement {
    /// The tiled map's name (the job id): every tile of one map has the same.
    pub map: String,
    /// Column and row of the tile in the grid of tiles.
    pub index: (u32, u32),
    /// Column and row of the tile's first texel in the whole map.
    pub origin: (u32, u32),
    /// The whole map's width and height in texels, at this tile's level of detail.
    pub map_size: (u32, u32),
    /// Level of detail: 0 is the map as baked, level `k` the map reduced by `2^k` (since format
    /// 1.9; older tiles are all level 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub level: u32,
}

fn is_zero(v: &u32) -> bool {
    *v == 0
}

impl TilePlacement {
    /// Where the tile's frame starts in the whole map's, in world units along `u` and `v`:
    /// its origin times the texel size. A game draws the tile translated by it.
    ///
    /// ```
    /// use hikage_bundle::TilePlacement;
    /// let t = TilePlacement { map: "dem".into(), index: (3, 1), origin: (3072, 1024), map_size: (8192, 8192), level: 0 };
    /// assert_eq!(t.offset((2.0, 0.5)), (6144.0, 512.0));
    /// ```
    pub fn offset(&self, (sx, sy): (f32, f32)) -> (f32, f32) {
        (self.origin.0 as f32 * sx, self.origin.1 as f32 * sy)
    }
}

impl HorizonSettings {
    /// Decodes a stored texel `(c0, c1)` (as the texture format returns it) to `(tan β, d)`.
    pub fn decode(&self, format: crate::TextureFormat, c0: f32, c1: f32) -> (f32, f32) {
        decode_horizon_texel(format, c0, c1, self.distance_scale, self.open_sky_slope)
    }
}

/// Decodes a stored horizon texel `(c0, c1)` (as the texture format returns it) to
/// `(tan β, d)`: float formats store them as they are; `Rg8Unorm` and `Bc5RgUnorm` store
/// `β/π + 0.5` (0 is open sky) and `d / distance_scale`. The one definition the baker's decoder
/// and export share.
pub fn decode_horizon_texel(
    format: crate::TextureFormat,
    c0: f32,
    c1: f32,
    distance_scale: f32,
    open_sky_slope: f32,
) -> (f32, f32) {
    if format.is_unorm() {
        let slope = if c0 <= 0.0 { open_sky_slope } else { ((c0 - 0.5) * std::f32::consts::PI).tan() };
        (slope, c1 * distance_scale)
    } else {
        (c0, c1)
    }
}

/// How an ambient-occlusion map was derived.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AmbientOcclusionSettings {
    /// Id of the horizon asset it was derived from.
    pub horizon: String,
    /// Directions averaged.
    pub directions: u32,
    /// Where this map lies in a map baked in tiles (`None`: the whole map; since format 1.9,
    /// older tiles say it only by their id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

/// How a heightfield's samples map to world space (see `docs/conventions.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeightfieldSettings {
    /// World units per texel along `u` (columns) and `v` (rows); may differ.
    pub texel_size: (f32, f32),
    /// World height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// Channel taken from the source image (`Y`, `R`, … or `luma` for grayscale PNG).
    pub source_channel: String,
    /// True when the source held integers normalised to [0, 1] before scaling.
    pub normalized: bool,
    /// Where these heights lie in a map baked in tiles (`None`: the whole map).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tile: Option<TilePlacement>,
}

impl HeightfieldSettings {
    /// The world height of stored sample `v` ([`world_height`]).
    pub fn world_height(&self, v: f32) -> f32 {
        world_height(self.height_offset, self.height_scale, v)
    }
}

/// The one rule from a heightfield's stored sample `v` to a world height:
/// `height_offset + height_scale × v` (a normalised integer sample as its 0–1 value). The baker,
/// the runtime's references and every reader of a `Heightfield` asset use it.
///
/// ```
/// assert_eq!(hikage_bundle::world_height(-100.0, 2000.0, 0.25), 400.0);
/// ```
pub fn world_height(height_offset: f32, height_scale: f32, v: f32) -> f32 {
    height_offset + height_scale * v
}
