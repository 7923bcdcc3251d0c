//! The CPU reference of the hair passes: the same strips, maps and shading as the WGSL, by
//! function of the same name where there is one, for the tests and for tools without a device.

use glam::{Vec3, Vec4};

use super::{HairLight, HairSet, HairUniform, Lookup};

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
    /// Linear RGB colour.
    pub color: Vec<Vec3>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

impl StripArrays {
    /// The streams of a `Strands` asset's mesh, or `None` when one is missing.
    pub fn from_mesh(mesh: &hikage_bundle::MeshData) -> Option<StripArrays> {
        let vec3s = |name| Some(mesh.read_f32(name)?.chunks_exact(3).map(Vec3::from_slice).collect());
        let pairs = |name| Some(mesh.read_f32(name)?.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
        Some(StripArrays {
            position: vec3s("position")?,
            side: mesh.read_f32("side")?,
            tangent: vec3s("tangent")?,
            width: pairs("width")?,
            opacity: pairs("opacity")?,
            color: vec3s("color")?,
            indices: mesh.read_indices()?,
        })
    }
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

/// Every fragment the light passes rasterise from `set`: `fragment(texel index, light NDC
/// depth, opacity)` for each texel centre a strip triangle covers, triangle by triangle.
pub fn for_each_light_fragment(
    s: &StripArrays,
    light: &HairLight,
    set: HairSet,
    resolution: u32,
    mut fragment: impl FnMut(usize, f32, f32),
) {
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
                // Opacity is constant along a segment's cross-section; interpolate it too.
                fragment(y * r + x, wa * pa.z + wb * pb.z + wc * pc.z, wa * a.1 + wb * b.1 + wc * c.1);
            }
        }
    }
}

/// CPU reference of the two light passes: the nearest depth per texel (1 where no hair) and
/// the cumulative opacity layers, rasterising each triangle at texel centres.
pub fn accumulate_cpu(s: &StripArrays, light: &HairLight, set: HairSet, resolution: u32) -> (Vec<f32>, Vec<[f32; 4]>) {
    let r = resolution as usize;
    let mut z0 = vec![1.0f32; r * r];
    for_each_light_fragment(s, light, set, resolution, |i, z, _| z0[i] = z0[i].min(z));
    let steps: Vec<f32> = (0..r * r)
        .map(|i| {
            let (nx, ny) = texel_ndc(i % r, i / r, resolution);
            light.step_at(nx, ny, z0[i])
        })
        .collect();
    let mut layers = vec![[0.0f32; 4]; r * r];
    for_each_light_fragment(s, light, set, resolution, |i, z, alpha| {
        for (k, layer) in layers[i].iter_mut().enumerate() {
            if z < boundary(z0[i], steps[i], k + 1) {
                *layer += alpha;
            }
        }
    });
    (z0, layers)
}

/// `hair_texel_ndc`: light NDC `(x, y)` of the centre of texel `(x, y)` of `resolution`².
pub fn texel_ndc(x: usize, y: usize, resolution: u32) -> (f32, f32) {
    let r = resolution as f32;
    ((x as f32 + 0.5) / r * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / r * 2.0)
}

/// `hair_texel_visibility`: the light reaching light NDC depth `z` through texel `(x, y)` of
/// opacity maps read back as `z0` and `layers`.
pub fn texel_visibility(
    light: &HairLight,
    z0: &[f32],
    layers: &[[f32; 4]],
    resolution: u32,
    (x, y): (i64, i64),
    z: f32,
) -> f32 {
    let r = resolution as i64;
    if x < 0 || y < 0 || x >= r || y >= r {
        return 1.0;
    }
    let i = (y * r + x) as usize;
    let (near, l) = (z0[i], layers[i]);
    if z <= near {
        return 1.0;
    }
    let (nx, ny) = texel_ndc(x as usize, y as usize, resolution);
    let step = light.step_at(nx, ny, near);
    let mut opacity = l[3];
    let (mut lo, mut before) = (near, 0.0);
    for (k, &layer) in l.iter().enumerate() {
        let hi = boundary(near, step, k + 1);
        if z < hi {
            opacity = before + (layer - before) * ((z - lo) / (hi - lo).max(1e-9));
            break;
        }
        (lo, before) = (hi, layer);
    }
    1.0 - opacity.min(1.0)
}

/// `hair_visibility`: the light reaching `world` through opacity maps read back as `z0` (the
/// nearest depth per texel) and `layers` (the four cumulative layers), `resolution`² texels,
/// read by `lookup`.
pub fn hair_visibility(
    light: &HairLight,
    (z0, layers): (&[f32], &[[f32; 4]]),
    resolution: u32,
    lookup: Lookup,
    world: Vec3,
) -> f32 {
    let c: Vec4 = light.view_proj * world.extend(1.0);
    let ndc = c.truncate() / c.w;
    let r = resolution as f32;
    let (tx, ty) = ((ndc.x * 0.5 + 0.5) * r, (0.5 - ndc.y * 0.5) * r);
    let at = |x: f32, y: f32| texel_visibility(light, z0, layers, resolution, (x as i64, y as i64), ndc.z);
    match lookup {
        Lookup::Nearest => at(tx.floor(), ty.floor()),
        Lookup::Bilinear => {
            let (bx, by) = ((tx - 0.5).floor(), (ty - 0.5).floor());
            let (fx, fy) = (tx - 0.5 - bx, ty - 0.5 - by);
            let top = at(bx, by) + (at(bx + 1.0, by) - at(bx, by)) * fx;
            let bottom = at(bx, by + 1.0) + (at(bx + 1.0, by + 1.0) - at(bx, by + 1.0)) * fx;
            top + (bottom - top) * fy
        }
    }
}

/// `hair_specular`: the Kajiya-Kay lobe, 1 on the cone of mirror directions around tangent `t`,
/// where `t·to_eye = −t·to_light`.
pub fn hair_specular(t: Vec3, to_light: Vec3, to_eye: Vec3, power: f32) -> f32 {
    let (tl, te) = (t.dot(to_light), t.dot(to_eye));
    let (sin_l, sin_e) = ((1.0 - tl * tl).max(0.0).sqrt(), (1.0 - te * te).max(0.0).sqrt());
    (sin_l * sin_e - tl * te).max(0.0).powf(power)
}

/// `hair_kajiya_kay` with the light and material of `uniform`: diffuse by the sine between
/// tangent and light and the specular lobe, both scaled by `visibility`; ambient unshadowed.
pub fn hair_kajiya_kay(
    uniform: &HairUniform,
    t: Vec3,
    to_light: Vec3,
    to_eye: Vec3,
    base: Vec3,
    visibility: f32,
) -> Vec3 {
    let tl = t.dot(to_light);
    let sin_l = (1.0 - tl * tl).max(0.0).sqrt();
    let direct = Vec3::from_slice(&uniform.light_color[..3]) * visibility;
    let spec = uniform.specular * hair_specular(t, to_light, to_eye, uniform.specular_power);
    base * (Vec3::from_slice(&uniform.ambient[..3]) + direct * sin_l) + direct * spec
}

/// `hair_oit_weight`: a fragment's weight in the order-independent blend, from its view depth
/// and opacity (McGuire & Bavoil 2013, eq. 10).
pub fn hair_oit_weight(z: f32, a: f32) -> f32 {
    a * (0.03 / (1e-5 + (z / 200.0).powi(4))).clamp(1e-2, 3e3)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The specular lobe peaks where T·E = −T·L (the cone of mirror directions), not where
    /// T·E = T·L (back-scatter): scanning the eye over a great circle through the tangent.
    #[test]
    fn kajiya_kay_highlight_sits_on_the_mirror_cone() {
        let t = Vec3::X;
        for light_angle in [20f32, 45.0, 70.0, 110.0] {
            let a = light_angle.to_radians();
            let to_light = Vec3::new(a.cos(), a.sin(), 0.0);
            let (mut best, mut best_angle) = (-1.0f32, 0.0f32);
            for k in 0..3600 {
                let e = (k as f32 * 0.1).to_radians();
                let to_eye = Vec3::new(e.cos(), 0.0, e.sin());
                let s = hair_specular(t, to_light, to_eye, 40.0);
                if s > best {
                    (best, best_angle) = (s, e);
                }
            }
            let te = best_angle.cos();
            assert!(
                (te + to_light.dot(t)).abs() < 2e-3,
                "light at {light_angle}°: peak at T·E {te}, T·L {}",
                to_light.dot(t)
            );
            assert!((best - 1.0).abs() < 1e-4, "the peak is 1: {best}");
            // Back-scatter (T·E = +T·L) is far from the peak unless the light is across.
            let back = Vec3::new(a.cos(), 0.0, a.sin());
            assert!(hair_specular(t, to_light, back, 40.0) < 0.5 || light_angle == 90.0);
        }
    }
}
