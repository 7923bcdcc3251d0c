//! Relief mapping with depth maps (seed 003): the tracers of [`RELIEF_WGSL`], the
//! [`ReliefMaterial`] that draws with them, and their CPU reference ([`mod@reference`]), which
//! counts every height-map and depth-map read.
//!
//! Four tracers find where a view ray entering the top plane first meets the relief (geometry
//! and parameterisation: [`hikage_bundle::relief`]):
//! - [`Tracer::Linear`]: plain relief mapping — equal depth steps, then binary search (the
//!   baseline).
//! - [`Tracer::DepthMap`]: the seed's method — the depth map of the sample direction nearest the
//!   view gives a hit `P'`, projected onto the view ray (`|OP| = |OP'| cos θ`); from there a
//!   forward search if outside the solid or a backward one if inside, then binary search.
//! - [`Tracer::MaxMip`]: max-mip traversal (Tevs et al. 2008), exact on the box surface.
//! - [`Tracer::Combined`]: the depth-map estimate, pulled back by a margin, as the start of a
//!   max-mip traversal from a low level.
//!
//! Shadows use the same maps toward the light; ambient occlusion is the visibility over the
//! sampled directions. [`mod@reference`] runs every one of them on the CPU, line by line as the
//! WGSL does, so the GPU can be checked against it.

pub use hikage_bundle::relief::DirectionRule;
use hikage_bundle::{ReliefSettings, TextureDesc};

mod material;
pub mod reference;

pub use material::{ReliefFrame, ReliefMaterial, ReliefMaterialUniform, ReliefVertex};

/// WGSL of the tracers, shadows and ambient occlusion. Bindings (at `@group(0)`; a
/// [`ReliefMaterial`] moves them to the group the game chose): 0 the max-mip texture
/// (`texture_2d<f32>`, level 0 the heights), 1 the depth maps (`texture_2d_array<f32>`), 2 a
/// uniform [`ReliefUniform`].
pub const RELIEF_WGSL: &str = include_str!("../shaders/relief.wgsl");

/// The tracer's `ReliefUniform` in the WGSL: the maps' sizes and direction table, and the
/// tracer, direction rule and visibility path with their settings (80 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReliefUniform {
    /// Heightfield width and height (powers of two).
    pub size: [u32; 2],
    /// Depth-map width and height.
    pub depth_size: [u32; 2],
    /// Max-mip levels.
    pub levels: u32,
    /// Zenith rows of the direction table.
    pub theta_rows: u32,
    /// Azimuths per row.
    pub phi_cols: u32,
    /// [`Tracer::code`].
    pub tracer: u32,
    /// Relief depth in texels of the heightfield.
    pub thickness: f32,
    /// Linear and depth-map tracers: steps over the full depth.
    pub steps: u32,
    /// Linear and depth-map tracers: binary-search halvings.
    pub binary: u32,
    /// Max-mip tracers: the level the traversal starts at.
    pub start_level: u32,
    /// Max-mip tracer: the level it stops refining at.
    pub stop_level: u32,
    /// Combined tracer: share of the depth-map estimate stepped back.
    pub margin: f32,
    /// [`DirectionRule::code`].
    pub direction_rule: u32,
    /// [`VisibilityPath::code`].
    pub visibility: u32,
    /// Seed visibility path: search steps over the full depth.
    pub visibility_steps: u32,
    /// Seed visibility path: binary-search halvings.
    pub visibility_binary: u32,
    /// Padding.
    pub _pad: [u32; 2],
}

/// A tracer and its setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tracer {
    /// Equal depth steps (`steps` of them down to the bottom), then `binary` halvings.
    Linear {
        /// Depth steps from the top to the bottom plane.
        steps: u32,
        /// Binary-search halvings.
        binary: u32,
    },
    /// The seed's depth-map start, forward/backward search in steps of `1/steps` depth, then
    /// `binary` halvings.
    DepthMap {
        /// Search step as a share of the full depth.
        steps: u32,
        /// Binary-search halvings.
        binary: u32,
    },
    /// Max-mip traversal from `start_level`, refined down to `stop_level` (0: exact).
    MaxMip {
        /// Level the traversal starts at.
        start_level: u32,
        /// Level it stops refining at.
        stop_level: u32,
    },
    /// Depth-map estimate pulled back by `margin` (a share of its length), then max-mip
    /// traversal from `start_level`.
    Combined {
        /// Share of the estimated length to step back before traversing.
        margin: f32,
        /// Level the traversal starts at.
        start_level: u32,
    },
}

impl Tracer {
    /// Short name for tables.
    pub fn name(&self) -> &'static str {
        match self {
            Tracer::Linear { .. } => "(a) linear + binary",
            Tracer::DepthMap { .. } => "(b) depth map (seed)",
            Tracer::MaxMip { .. } => "(c) max-mip",
            Tracer::Combined { .. } => "(d) depth map + max-mip",
        }
    }

    /// Index used by the shader's `tracer` field.
    pub fn code(&self) -> u32 {
        match self {
            Tracer::Linear { .. } => 0,
            Tracer::DepthMap { .. } => 1,
            Tracer::MaxMip { .. } => 2,
            Tracer::Combined { .. } => 3,
        }
    }
}

/// How [`reference::ReliefMaps::lit`] and [`reference::ReliefMaps::ambient_occlusion`] decide whether a direction is
/// open from a point of the relief.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum VisibilityPath {
    /// A direction is open when the stored hit where its ray enters the top plane is not
    /// shallower than the point: one depth-map read. Otherwise the ray is traversed through the
    /// max-mip pyramid from the stored depth to the point, open when nothing is hit on the way
    /// (exact on the box surface).
    #[default]
    MaxMip,
    /// Seed 003 §4: the ray toward the point is traced from where it enters the top plane like
    /// a view ray — the depth-map estimate, a forward or backward search in steps of `1/steps`
    /// of the depth, `binary` halvings — and the point is open when the hit is the point itself.
    Seed {
        /// Search steps over the full depth.
        steps: u32,
        /// Binary-search halvings.
        binary: u32,
    },
}

impl VisibilityPath {
    /// Short name for tables.
    pub fn name(&self) -> &'static str {
        match self {
            VisibilityPath::MaxMip => "stored depth, then max-mip",
            VisibilityPath::Seed { .. } => "seed: estimate, search, binary",
        }
    }

    /// The value of the WGSL uniform's `visibility` field.
    pub fn code(&self) -> u32 {
        match self {
            VisibilityPath::MaxMip => 0,
            VisibilityPath::Seed { .. } => 1,
        }
    }
}

impl ReliefUniform {
    /// The uniform of a relief asset baked with `settings`: its depth maps `depth` and its
    /// max-mip pyramid `max_mip` (sizes, levels, direction table, thickness in texels); the
    /// tracer and read rules at their zero values, set with [`Self::with_tracer`] and
    /// [`Self::with_reads`].
    pub fn for_maps(settings: &ReliefSettings, depth: &TextureDesc, max_mip: &TextureDesc) -> ReliefUniform {
        ReliefUniform {
            size: [max_mip.width, max_mip.height],
            depth_size: [depth.width, depth.height],
            levels: max_mip.levels,
            theta_rows: settings.theta,
            phi_cols: settings.phi,
            thickness: settings.depth_scale * max_mip.width as f32,
            ..ReliefUniform::default()
        }
    }

    /// This uniform with `rule` and `visibility` in place of its own.
    pub fn with_reads(self, rule: DirectionRule, visibility: VisibilityPath) -> ReliefUniform {
        let (visibility_steps, visibility_binary) = match visibility {
            VisibilityPath::MaxMip => (0, 0),
            VisibilityPath::Seed { steps, binary } => (steps, binary),
        };
        ReliefUniform {
            direction_rule: rule.code(),
            visibility: visibility.code(),
            visibility_steps,
            visibility_binary,
            ..self
        }
    }

    /// This uniform with `tracer` and its setting in place of its own.
    pub fn with_tracer(self, tracer: Tracer) -> ReliefUniform {
        let (steps, binary, start_level, stop_level, margin) = match tracer {
            Tracer::Linear { steps, binary } | Tracer::DepthMap { steps, binary } => (steps, binary, 0, 0, 0.0),
            Tracer::MaxMip { start_level, stop_level } => (0, 0, start_level, stop_level, 0.0),
            Tracer::Combined { margin, start_level } => (0, 0, start_level, 0, margin),
        };
        ReliefUniform { tracer: tracer.code(), steps, binary, start_level, stop_level, margin, ..self }
    }
}
