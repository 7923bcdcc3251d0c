//! What a game fills for [`HairRenderer`]: its options at build time, its frame each
//! frame (camera, light, level of detail, style), and the uniform the shaders read.

use glam::{Mat4, Vec3};

#[cfg(doc)]
use super::HairRenderer;
use super::{HairLight, HairSet};
use crate::draw::DrawOptions;

/// The `HairUniform` of the hair WGSL, as it is in the uniform buffer (480 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HairUniform {
    /// World → light clip, column-major.
    pub light: [[f32; 4]; 4],
    /// Light clip → world, column-major (for the per-texel layer step).
    pub light_inverse: [[f32; 4]; 4],
    /// The hair's bounding box, lower corner (world).
    pub bounds_min: [f32; 4],
    /// The hair's bounding box, upper corner (world).
    pub bounds_max: [f32; 4],
    /// World → camera clip, column-major.
    pub camera: [[f32; 4]; 4],
    /// Camera position.
    pub eye: [f32; 4],
    /// Unit vector toward the light.
    pub to_light: [f32; 4],
    /// Light RGB.
    pub light_color: [f32; 4],
    /// Ambient RGB.
    pub ambient: [f32; 4],
    /// Colour factor (rgb) and opacity factor (a) at the root.
    pub root_tint: [f32; 4],
    /// Colour factor (rgb) and opacity factor (a) at the tip.
    pub tip_tint: [f32; 4],
    /// Layer step `d` in light NDC depth.
    pub step: f32,
    /// The set drawn into the opacity maps: 0 shading, 1 opacity.
    pub opacity_set: u32,
    /// Opacity-map texels per side.
    pub resolution: u32,
    /// Kajiya-Kay exponent.
    pub specular_power: f32,
    /// Kajiya-Kay specular strength.
    pub specular: f32,
    /// 0: [`LayerRule::Box`](super::LayerRule::Box), 1: per texel.
    pub layer_rule: u32,
    /// [`Lookup::code`].
    pub lookup: u32,
    /// A record's width scale (the asset's `max_width`).
    pub max_width: f32,
    /// Opacity set width / shading set width.
    pub width_ratio: f32,
    /// Opacity set opacity / shading set opacity.
    pub alpha_ratio: f32,
    /// Share of the width lost at the tip.
    pub taper: f32,
    /// Narrowest camera strip in pixels (0: off).
    pub min_pixel_width: f32,
    /// The camera target's size in pixels.
    pub viewport: [f32; 2],
    /// Distance from the eye to the nearest and farthest point of the hair's box.
    pub depth_range: [f32; 2],
    /// Width factor of the camera passes' level of detail.
    pub camera_widen: f32,
    /// Width factor of the light passes' level of detail.
    pub light_widen: f32,
    /// Per-strand brightness spread.
    pub color_variation: f32,
    /// The blend's weight falloff: the hair's optical depth across its box.
    pub oit_falloff: f32,
    /// The hair's frame (its coordinates as baked) → world, column-major ([`HairFrame::model`]).
    pub model: [[f32; 4]; 4],
    /// Factor on strand widths from `model`: the cube root of its 3×3 determinant.
    pub model_width: f32,
    /// Padding to the WGSL struct's 16-byte alignment.
    pub _pad: [f32; 3],
}

/// How receivers read the opacity maps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lookup {
    /// The texel under the point (the seed's: its wide faint set does the anti-aliasing).
    #[default]
    Nearest,
    /// The visibility of the 2×2 texels around the point, each at the point's depth, weighted
    /// bilinearly: percentage-closer filtering, the usual filtered lookup of plain deep opacity
    /// maps.
    Bilinear,
}

impl Lookup {
    /// The value of the WGSL uniform's `lookup` field.
    pub fn code(self) -> u32 {
        match self {
            Lookup::Nearest => 0,
            Lookup::Bilinear => 1,
        }
    }
}

/// Which level of detail a pass draws: level `l` draws about `1 / 2^l` of the strands, each
/// widened so the hair's coverage is kept ([`hikage_bundle::StrandsSettings::levels`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lod {
    /// Chosen per frame from the hair's projected size ([`AUTO_LOD_PIXELS`]).
    #[default]
    Auto,
    /// This level (0: every strand), or the coarsest the asset has.
    Level(u32),
}

/// [`Lod::Auto`] drops strands while the widened strips stay at most this wide, in pixels of
/// the camera (or texels of the opacity maps), at the centre of the hair's box.
pub const AUTO_LOD_PIXELS: f32 = 0.1;

/// The levels of detail of the camera passes and of the light passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HairLod {
    /// The camera's (blended or opaque hair).
    pub camera: Lod,
    /// The opacity maps'.
    pub light: Lod,
}

/// How strands look beyond what the asset holds: a gradient from root to tip, a taper, and a
/// per-strand variation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairStyle {
    /// Factor on the strand colour at the root (linear RGB).
    pub root_tint: Vec3,
    /// Factor on the strand colour at the tip; mixed with `root_tint` by `param`.
    pub tip_tint: Vec3,
    /// Factor on the opacity at the root.
    pub root_alpha: f32,
    /// Factor on the opacity at the tip (a fade toward the tips below 1).
    pub tip_alpha: f32,
    /// Share of the width lost at the tip, or `None` for the asset's.
    pub taper: Option<f32>,
    /// Spread of a per-strand brightness factor, hashed from the strand's id (0: none; 0.2:
    /// ±10%).
    pub color_variation: f32,
}

impl Default for HairStyle {
    fn default() -> HairStyle {
        HairStyle {
            root_tint: Vec3::ONE,
            tip_tint: Vec3::ONE,
            root_alpha: 1.0,
            tip_alpha: 1.0,
            taper: None,
            color_variation: 0.0,
        }
    }
}

/// What changes from frame to frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairFrame {
    /// The hair's frame (the strands' coordinates as baked) → world: where the hair is drawn,
    /// as the model matrix of the head or bone it sits on. Widths scale with it (by the cube
    /// root of its determinant); the light ([`HairRenderer::light_at`]) must be fitted with the
    /// same matrix. `Mat4::IDENTITY` draws the hair where it was baked.
    pub model: Mat4,
    /// World → camera clip (wgpu: depth 0..1).
    pub camera: Mat4,
    /// The camera's position, world space (strips face it).
    pub eye: Vec3,
    /// The light and its opacity-map projection ([`HairRenderer::light`]).
    pub light: HairLight,
    /// The set drawn into the opacity maps: the wide faint opacity set (the seed's) or the
    /// shading set itself (plain deep opacity maps).
    pub set: HairSet,
    /// Linear RGB of the light.
    pub light_color: Vec3,
    /// Linear RGB of the ambient light.
    pub ambient: Vec3,
    /// Kajiya-Kay specular strength.
    pub specular: f32,
    /// Kajiya-Kay specular exponent.
    pub specular_power: f32,
    /// How receivers (and the hair itself) read the opacity maps.
    pub lookup: Lookup,
    /// The narrowest strip the camera draws, in pixels: a thinner one is widened to it with
    /// its opacity lowered by the same factor (its coverage kept), so sub-pixel strands blend
    /// instead of speckling. 0 draws them at their own width.
    pub min_pixel_width: f32,
    /// Levels of detail.
    pub lod: HairLod,
    /// Gradient, taper and variation.
    pub style: HairStyle,
    /// The part of the frame the camera draws, `[x, y, width, height]` in pixels of the target
    /// (a split screen's half, a picture in picture); `None` for the whole frame. The camera
    /// passes, the composite and the opaque draw keep to it, and strip widths in pixels are
    /// the viewport's.
    pub viewport: Option<[u32; 4]>,
    /// The box the strands lie in this frame, in the hair's frame (before `model`), when they
    /// move within it: skinned hair's [`super::HairSkin::update`]. `None`: the asset's baked
    /// bounds. Levels of detail and the blend's depth range are measured on it.
    pub bounds: Option<(Vec3, Vec3)>,
}

impl HairFrame {
    /// A frame for `camera` at `eye` lit by `light` through the opacity set, with white light,
    /// a little ambient light, a specular highlight, strips at least 1 pixel wide and automatic
    /// levels of detail.
    pub fn new(camera: Mat4, eye: Vec3, light: HairLight) -> HairFrame {
        HairFrame {
            model: Mat4::IDENTITY,
            camera,
            eye,
            light,
            set: HairSet::Opacity,
            light_color: Vec3::ONE,
            ambient: Vec3::splat(0.15),
            specular: 0.25,
            specular_power: 40.0,
            lookup: Lookup::Nearest,
            min_pixel_width: 1.0,
            lod: HairLod::default(),
            style: HairStyle::default(),
            viewport: None,
            bounds: None,
        }
    }
}

/// How the renderer's pipelines are built.
#[derive(Clone, Debug, PartialEq)]
pub struct HairOptions {
    /// The game's targets, as every component takes them: the colour target
    /// [`HairRenderer::composite`] and [`HairRenderer::draw_opaque`] draw into (its format;
    /// blending is the renderer's), the depth format the camera passes test so hair hides
    /// behind geometry (`None` without depth), and the bind group index of the renderer's group
    /// in every pipeline and of the receivers' group in the game's own shaders. Culling and the
    /// visibility target do not apply to hair.
    pub draw: DrawOptions,
    /// Opacity-map texels per side.
    pub resolution: u32,
    /// The frame's size in pixels (the order-independent blend keeps two targets of it, four
    /// with [`BlendWeight::Layers`]; [`HairRenderer::resize`] changes it).
    pub size: (u32, u32),
    /// How the camera's order-independent blend weighs each fragment.
    pub blend: BlendWeight,
}

impl HairOptions {
    /// 256² opacity maps, a `size` frame drawn into `color_format` with no depth, group 0, the
    /// blend weighted by the hair in front of each fragment ([`BlendWeight::Layers`]).
    pub fn new(color_format: wgpu::TextureFormat, size: (u32, u32)) -> HairOptions {
        HairOptions { draw: DrawOptions::new(color_format), resolution: 256, size, blend: BlendWeight::default() }
    }
}

/// How the camera's order-independent blend weighs a fragment against the others in its pixel.
/// Sorted front to back, a fragment counts by the light its pixel's hair in front of it lets
/// through; the blend has no order, so it estimates that.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BlendWeight {
    /// From the hair in front of the fragment in its own pixel: a camera pass first adds every
    /// fragment's opacity into 8 cumulative layers of view depth across the hair's box (two
    /// `Rgba16Float` targets of the frame's size), and each fragment's weight is
    /// `exp(−opacity in front)`, interpolated between the layers' boundaries. One more draw of
    /// the strips, 16 bytes a pixel; it follows dense hair whose front strands hide the rest,
    /// where one falloff per hair cannot.
    #[default]
    Layers,
    /// From the fragment's depth across the hair's box alone, falling off by the hair's mean
    /// optical depth: no extra pass and no extra targets, close on sparse or evenly dense hair.
    Depth,
}

impl HairUniform {
    /// A uniform with nothing set but the opacity maps' resolution (before the first frame).
    pub(super) fn zeroed_for(resolution: u32) -> HairUniform {
        HairUniform { resolution, ..bytemuck::Zeroable::zeroed() }
    }
}
