//! Hair strips with anti-aliased deep opacity maps (seed 004): [`HairRenderer`], the WGSL of
//! [`HAIR_WGSL`], and the CPU reference of both in [`reference`].
//!
//! A `strands` asset holds two vertices per strand point; the vertex shader pushes them apart
//! across the strand so the strip faces whoever looks (the light in the light passes, the camera
//! when shading). Either set — thin shading strips or the wide faint opacity set — can be drawn
//! into the opacity maps; the camera always draws the shading set, blended at its own opacity
//! (weighted blended order-independent transparency) or opaque, shaded with Kajiya-Kay.
//!
//! Light passes are orthographic with the depth range of the hair's bounding box (from the
//! manifest): a depth map of the nearest hair `z0`, then 4 cumulative opacity layers with far
//! boundaries at `z0 + d·k(k+1)/2` for k = 1…4 — integer multiples of `d`, layer k being k·d
//! deep so far layers are wider (our reading of the seed's Fig. 2), with `d` the box's depth
//! range / 10 so the last boundary reaches the far side of the box from the nearest hair.
//! Opacities add in an `Rgba16Float` target (alpha-to-coverage cannot hold 0.0165). Shading
//! interpolates the cumulative opacity between boundaries; visibility = 1 − min(opacity, 1).

pub mod reference;
mod renderer;

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3};

pub use renderer::{HairFrame, HairOptions, HairRenderer, HairUniform};

/// WGSL of the passes and of `hair_visibility` for receivers (see the module docs).
pub const HAIR_WGSL: &str = include_str!("../shaders/hair.wgsl");

/// Opacity layers per texel.
pub const LAYERS: usize = 4;

/// Which set a light pass draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HairSet {
    /// Thin strips at the shading opacity (plain deep opacity maps).
    Shading,
    /// The wide, faint opacity set.
    Opacity,
}

/// An orthographic light around the hair's bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairLight {
    /// World → light clip; the box spans depth 0..1.
    pub view_proj: Mat4,
    /// Unit vector toward the light.
    pub to_light: Vec3,
    /// Layer step `d` in light NDC depth.
    pub step: f32,
}

impl HairLight {
    /// The light along `to_light` fitted to the box `[lo, hi]` (near and far from the box:
    /// nothing outside it is drawn into the maps).
    pub fn for_bounds(lo: Vec3, hi: Vec3, to_light: Vec3) -> HairLight {
        let to_light = to_light.normalize();
        let helper = if to_light.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = look_to_mat4(Vec3::ZERO, -to_light, helper);
        let (mut a, mut b) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let v = view.transform_point3(c);
            (a, b) = (a.min(v), b.max(v));
        }
        // Looking along −z: the near side of the box has the largest z.
        let proj = directx::orthographic(a.x, b.x, a.y, b.y, -b.z, -a.z);
        HairLight { view_proj: proj * view, to_light, step: 1.0 / 10.0 }
    }
}
