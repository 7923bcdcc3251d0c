//! Hair strips with anti-aliased deep opacity maps (seed 004): [`HairRenderer`], the WGSL of
//! [`HAIR_WGSL`], and the CPU reference of both in [`reference`](mod@reference).
//!
//! A `strands` asset holds one record per strand point; each instance draws a segment from two
//! consecutive records as a 4-vertex strip whose vertex shader pushes the sides apart
//! across the strand so the strip faces whoever looks (the light in the light passes, the camera
//! when shading). Either set — thin shading strips or the wide faint opacity set — can be drawn
//! into the opacity maps; the camera always draws the shading set, blended at its own opacity
//! (weighted blended order-independent transparency, each fragment weighted by the opacity of
//! the hair in front of it in its pixel, from 8 cumulative camera layers of view depth) or
//! opaque, shaded with Kajiya-Kay.
//!
//! Light passes are orthographic with the depth range of the hair's bounding box (from the
//! manifest): a depth map of the nearest hair `z0`, then 4 cumulative opacity layers with far
//! boundaries at `z0 + d·k(k+1)/2` for k = 1…4 — integer multiples of `d`, layer k being k·d
//! deep so far layers are wider (our reading of the seed's Fig. 2). The seed computes `d` "from
//! the depth value and the bounding box": [`LayerRule::PerTexel`] takes, at each texel, the
//! span from its nearest hair `z0` to where its light ray leaves the box, over 10, so the last
//! boundary is the box's far side behind that texel; [`LayerRule::Box`] uses the box's whole
//! depth range / 10 everywhere. Opacities add in an `Rgba16Float` target (alpha-to-coverage
//! cannot hold 0.0165). Shading interpolates the cumulative opacity between boundaries;
//! visibility = 1 − min(opacity, 1), read at the nearest texel or filtered over the 2×2 texels
//! around the point ([`Lookup`]).

mod frame;
pub mod reference;
mod renderer;
mod skin;
mod targets;

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3};

pub use frame::{AUTO_LOD_PIXELS, BlendWeight, HairFrame, HairLod, HairOptions, HairStyle, HairUniform, Lod, Lookup};
pub use renderer::HairRenderer;
pub use skin::{HairSkin, SKIN_WORKGROUP};

/// WGSL of the passes and of `hair_visibility` for receivers (see the module docs).
pub const HAIR_WGSL: &str =
    concat!(include_str!("../shaders/hair_octahedral.wgsl"), include_str!("../shaders/hair.wgsl"));

/// WGSL of the skinning pass ([`HairSkin`]): strand records posed by a skinned scalp.
pub const HAIR_SKIN_WGSL: &str =
    concat!(include_str!("../shaders/hair_octahedral.wgsl"), include_str!("../shaders/hair_skin.wgsl"));

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

/// How the layer step `d` of the opacity maps is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LayerRule {
    /// The same `d` at every texel: the box's depth range / 10.
    Box,
    /// The seed's: at each texel, the span from its nearest hair to where its light ray leaves
    /// the bounding box, / 10.
    #[default]
    PerTexel,
}

/// An orthographic light around the hair's bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairLight {
    /// World → light clip; the box spans depth 0..1.
    pub view_proj: Mat4,
    /// Unit vector toward the light.
    pub to_light: Vec3,
    /// Layer step `d` in light NDC depth under [`LayerRule::Box`].
    pub step: f32,
    /// How `d` is chosen per texel.
    pub rule: LayerRule,
    /// The hair's bounding box (world), lower and upper corners.
    pub bounds: (Vec3, Vec3),
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
        HairLight { view_proj: proj * view, to_light, step: 1.0 / 10.0, rule: LayerRule::default(), bounds: (lo, hi) }
    }

    /// The layer step `d` at light NDC position `(x, y)` (a texel centre) above a nearest hair
    /// depth `z0`, by [`Self::rule`] (`hair_step` in the WGSL).
    pub fn step_at(&self, x: f32, y: f32, z0: f32) -> f32 {
        match self.rule {
            LayerRule::Box => self.step,
            LayerRule::PerTexel => (box_exit(self.view_proj.inverse(), self.bounds, x, y) - z0).max(1e-6) / 10.0,
        }
    }
}

/// Light NDC depth (0..1) where the light's ray through NDC `(x, y)` leaves the box `bounds`
/// (`hair_box_exit` in the WGSL); 1 when it misses the box.
pub fn box_exit(inverse_view_proj: Mat4, (lo, hi): (Vec3, Vec3), x: f32, y: f32) -> f32 {
    let p0 = inverse_view_proj.project_point3(Vec3::new(x, y, 0.0));
    let dp = inverse_view_proj.project_point3(Vec3::new(x, y, 1.0)) - p0;
    let (mut enter, mut exit) = (0.0f32, 1.0f32);
    for axis in 0..3 {
        if dp[axis].abs() < 1e-9 {
            continue;
        }
        let (t1, t2) = ((lo[axis] - p0[axis]) / dp[axis], (hi[axis] - p0[axis]) / dp[axis]);
        enter = enter.max(t1.min(t2));
        exit = exit.min(t1.max(t2));
    }
    if enter > exit { 1.0 } else { exit }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-texel step against a march along each texel's light ray: the last boundary
    /// `z0 + 10·d` is where the ray leaves the box, for `z0` where it enters; the box rule keeps
    /// the box's range / 10 everywhere.
    #[test]
    fn per_texel_step_reaches_where_the_light_ray_leaves_the_box() {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(3.0, 2.0, 1.0));
        let light = HairLight::for_bounds(lo, hi, Vec3::new(0.4, 1.0, -0.3));
        let inverse = light.view_proj.inverse();
        let inside = |p: Vec3| (p.cmpge(lo - 1e-4) & p.cmple(hi + 1e-4)).all();
        let (mut checked, mut short) = (0, 0);
        for j in 0..20 {
            for i in 0..20 {
                let (x, y) = (-0.95 + 0.1 * i as f32, -0.95 + 0.1 * j as f32);
                let zs: Vec<f32> = (0..=20_000)
                    .map(|k| k as f32 / 20_000.0)
                    .filter(|&z| inside(inverse.project_point3(Vec3::new(x, y, z))))
                    .collect();
                // Rays that only graze an edge (a span below the march's resolution) are skipped.
                let (Some(&enter), Some(&exit)) = (zs.first(), zs.last()) else { continue };
                if exit - enter < 1e-2 {
                    continue;
                }
                let step = light.step_at(x, y, enter);
                assert!(
                    (reference::boundary(enter, step, 4) - exit).abs() < 2e-4,
                    "({x}, {y}): {step} vs {enter}..{exit}"
                );
                checked += 1;
                short += (exit < 0.99) as u32;
                let boxed = HairLight { rule: LayerRule::Box, ..light };
                assert_eq!(boxed.step_at(x, y, enter), 0.1);
            }
        }
        // Rays that cross the box's corners leave it early: the rules differ there.
        assert!(checked > 100 && short > 20, "{checked} rays, {short} leaving early");
    }
}
