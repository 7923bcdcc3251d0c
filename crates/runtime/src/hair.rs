//! Hair strips with anti-aliased deep opacity maps (seed 004): the WGSL of [`HAIR_WGSL`] and a
//! CPU reference of its opacity accumulation.
//!
//! A `strands` asset holds two vertices per strand point; the vertex shader pushes them apart
//! across the strand so the strip faces whoever looks (the light in the light passes, the camera
//! when shading). Either set — thin shading strips or the wide faint opacity set — can be drawn
//! into the opacity maps; the camera always draws the shading set.
//!
//! Light passes are orthographic with the depth range of the hair's bounding box (from the
//! manifest): a depth map of the nearest hair `z0`, then 4 cumulative opacity layers with far
//! boundaries at `z0 + d·k(k+1)/2` for k = 1…4 — integer multiples of `d`, layer k being k·d
//! deep so far layers are wider (our reading of the seed's Fig. 2), with `d` the box's depth
//! range / 10 so the last boundary reaches the far side of the box from the nearest hair.
//! Opacities add in an `Rgba16Float` target (alpha-to-coverage cannot hold 0.0165). Shading
//! interpolates the cumulative opacity between boundaries; visibility = 1 − min(opacity, 1).

use glam::camera::rh::proj::directx;
use glam::camera::rh::view::look_to_mat4;
use glam::{Mat4, Vec3, Vec4};

/// WGSL of the passes (see the module docs).
pub const HAIR_WGSL: &str = include_str!("shaders/hair.wgsl");

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

/// The strips as plain arrays, for the CPU reference.
#[derive(Clone, Debug, PartialEq)]
pub struct StripArrays {
    /// Centre-line positions.
    pub position: Vec<Vec3>,
    /// −1 or +1.
    pub side: Vec<f32>,
    /// Unit tangents.
    pub tangent: Vec<Vec3>,
    /// (shading, opacity set) widths.
    pub width: Vec<[f32; 2]>,
    /// (shading, opacity set) opacities.
    pub opacity: Vec<[f32; 2]>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

/// The vertex `hair_expand` makes: the centre pushed half the width across the strand, facing
/// `toward`.
pub fn expand(p: Vec3, side: f32, t: Vec3, width: f32, toward: Vec3) -> Vec3 {
    let mut across = t.cross(toward);
    if across.length() < 1e-6 {
        across = t.cross(Vec3::Z);
        if across.length() < 1e-6 {
            across = Vec3::X;
        }
    }
    p + across.normalize() * (side * 0.5 * width)
}

/// Far boundary of layer `k` (1-based) above `z0`.
pub fn boundary(z0: f32, step: f32, k: usize) -> f32 {
    z0 + step * (k * (k + 1) / 2) as f32
}

/// CPU reference of the two light passes: the nearest depth per texel (1 where no hair) and
/// the cumulative opacity layers, rasterising each triangle at texel centres.
pub fn accumulate_cpu(s: &StripArrays, light: &HairLight, set: HairSet, resolution: u32) -> (Vec<f32>, Vec<[f32; 4]>) {
    let r = resolution as usize;
    let pick = usize::from(set == HairSet::Opacity);
    let screen: Vec<(Vec3, f32)> = (0..s.position.len())
        .map(|v| {
            let w = expand(s.position[v], s.side[v], s.tangent[v], s.width[v][pick], light.to_light);
            let c: Vec4 = light.view_proj * w.extend(1.0);
            let ndc = c.truncate() / c.w;
            (Vec3::new((ndc.x * 0.5 + 0.5) * r as f32, (0.5 - ndc.y * 0.5) * r as f32, ndc.z), s.opacity[v][pick])
        })
        .collect();
    let mut z0 = vec![1.0f32; r * r];
    let mut layers = vec![[0.0f32; 4]; r * r];
    for pass in 0..2 {
        for tri in s.indices.chunks_exact(3) {
            let (a, b, c) = (screen[tri[0] as usize], screen[tri[1] as usize], screen[tri[2] as usize]);
            let (pa, pb, pc) = (a.0, b.0, c.0);
            let area = (pb.x - pa.x) * (pc.y - pa.y) - (pb.y - pa.y) * (pc.x - pa.x);
            if area.abs() < 1e-12 {
                continue;
            }
            let (x0, x1) = (
                pa.x.min(pb.x).min(pc.x).floor().max(0.0) as usize,
                pa.x.max(pb.x).max(pc.x).ceil().min(r as f32) as usize,
            );
            let (y0, y1) = (
                pa.y.min(pb.y).min(pc.y).floor().max(0.0) as usize,
                pa.y.max(pb.y).max(pc.y).ceil().min(r as f32) as usize,
            );
            for y in y0..y1 {
                for x in x0..x1 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let e = |p: Vec3, q: Vec3| ((q.x - p.x) * (py - p.y) - (q.y - p.y) * (px - p.x)) / area;
                    let (wa, wb, wc) = (e(pb, pc), e(pc, pa), e(pa, pb));
                    if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                        continue;
                    }
                    let z = wa * pa.z + wb * pb.z + wc * pc.z;
                    let i = y * r + x;
                    if pass == 0 {
                        z0[i] = z0[i].min(z);
                    } else {
                        // Opacity is constant along a segment's cross-section; interpolate it too.
                        let alpha = wa * a.1 + wb * b.1 + wc * c.1;
                        let near = z0[i];
                        for (k, layer) in layers[i].iter_mut().enumerate() {
                            if z < boundary(near, light.step, k + 1) {
                                *layer += alpha;
                            }
                        }
                    }
                }
            }
        }
    }
    (z0, layers)
}
