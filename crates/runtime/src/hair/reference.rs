//! The CPU reference of the hair passes: the same strips, maps and shading as the WGSL, by
//! function of the same name where there is one, for the tests and for tools without a device.

use glam::{Vec3, Vec4};
use hikage_bundle::{StrandPoint, StrandsSettings};

use super::{HairLight, HairUniform, Lookup};

/// A strands asset's records and settings, for the CPU reference.
#[derive(Clone, Debug, PartialEq)]
pub struct StripArrays {
    /// Every record, in stored order.
    pub points: Vec<StrandPoint>,
    /// The asset's settings.
    pub settings: StrandsSettings,
}

impl StripArrays {
    /// The records of a `Strands` asset's mesh, or `None` when its layout is not format 1.5's.
    pub fn from_mesh(mesh: &hikage_bundle::MeshData, settings: &StrandsSettings) -> Option<StripArrays> {
        Some(StripArrays { points: hikage_bundle::read_strand_points(mesh, settings)?, settings: settings.clone() })
    }

    /// The records a level of detail draws (its first points), every one for a level the asset
    /// lacks.
    pub fn points_of_level(&self, level: u32) -> u32 {
        self.settings.levels.get(level as usize).map_or(self.points.len() as u32, |l| l[1])
    }
}

/// `hair_point`: a record as a pass uses it, in the drawn set at the pass's widening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairPoint {
    /// Centre-line position.
    pub position: Vec3,
    /// Unit tangent.
    pub tangent: Vec3,
    /// Full width (tapered, widened).
    pub width: f32,
    /// Opacity.
    pub alpha: f32,
    /// Linear RGB, tinted.
    pub color: Vec3,
    /// Whether the segment from this point exists.
    pub drawn: bool,
}

/// `hair_strand_variation`: a strand's brightness factor from its id.
pub fn strand_variation(u: &HairUniform, id: u32) -> f32 {
    let mut h = id.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    h = ((h >> ((h >> 28) + 4)) ^ h).wrapping_mul(277_803_737);
    h ^= h >> 22;
    1.0 + u.color_variation * (h as f32 / 4_294_967_295.0 - 0.5)
}

/// `hair_point` of the WGSL: the record's point in world space (through the uniform's model
/// matrix).
pub fn hair_point(u: &HairUniform, p: &StrandPoint, opacity_set: bool, widen: f32) -> HairPoint {
    let param = p.param();
    let mut width = p.width * (1.0 - u.taper * param) * widen;
    let mut alpha = p.alpha * (u.root_tint[3] + (u.tip_tint[3] - u.root_tint[3]) * param);
    if opacity_set {
        width *= u.width_ratio;
        alpha = (alpha * u.alpha_ratio).min(1.0);
    }
    let (root, tip) = (Vec3::from_slice(&u.root_tint), Vec3::from_slice(&u.tip_tint));
    let tint = (root + (tip - root) * param) * strand_variation(u, p.strand_id);
    let model = glam::Mat4::from_cols_array_2d(&u.model);
    HairPoint {
        position: model.transform_point3(Vec3::from(p.position)),
        tangent: model.transform_vector3(Vec3::from(p.tangent)).normalize(),
        width: width * u.model_width,
        alpha,
        color: Vec3::from(p.color) * tint,
        drawn: p.index < p.segments,
    }
}

/// `hair_across`: the unit vector across tangent `t` facing `toward`.
pub fn across(t: Vec3, toward: Vec3) -> Vec3 {
    let mut a = t.cross(toward);
    if a.length() < 1e-6 {
        a = t.cross(Vec3::Z);
        if a.length() < 1e-6 {
            a = Vec3::X;
        }
    }
    a.normalize()
}

/// `hair_pixel_width`: pixels across a strip `width` wide at `p` along `across`.
pub fn pixel_width(u: &HairUniform, p: Vec3, across: Vec3, width: f32) -> f32 {
    let camera = glam::Mat4::from_cols_array_2d(&u.camera);
    let (c0, c1) = (camera * p.extend(1.0), camera * (p + across * width).extend(1.0));
    if c0.w <= 0.0 || c1.w <= 0.0 {
        return 0.0;
    }
    let d = (c1.truncate().truncate() / c1.w - c0.truncate().truncate() / c0.w) * 0.5 * glam::Vec2::from(u.viewport);
    d.length()
}

/// The strips a pass draws, as triangles: per segment four vertices (its two ends, each side)
/// and two triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expanded {
    /// World position of each vertex.
    pub world: Vec<Vec3>,
    /// Unit tangent.
    pub tangent: Vec<Vec3>,
    /// Linear RGB.
    pub color: Vec<Vec3>,
    /// Opacity.
    pub alpha: Vec<f32>,
    /// Distance from the strip's centre line in pixels, signed (filtered camera strips).
    pub across_px: Vec<f32>,
    /// The strip's width in pixels, 0 where it is drawn as it is.
    pub footprint: Vec<f32>,
    /// Distance to the eye (camera strips).
    pub view_depth: Vec<f32>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

/// Which way a pass's strips face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Facing {
    /// The light passes: toward the light, the set of `opacity_set`, widened by `light_widen`.
    Light,
    /// The blended camera pass: toward the eye, the shading set, widened by `camera_widen`,
    /// filtered to at least `min_pixel_width` pixels.
    Camera,
    /// The opaque camera draw: as [`Facing::Camera`] at the strips' own width.
    CameraOpaque,
}

/// `hair_vs_light` / `hair_vs_camera` / `hair_vs_camera_opaque` over the first `points`
/// records (one instance per record but the last).
pub fn expand(s: &StripArrays, u: &HairUniform, facing: Facing, points: u32) -> Expanded {
    let mut out = Expanded::default();
    let eye = Vec3::from_slice(&u.eye);
    let to_light = Vec3::from_slice(&u.to_light);
    let points = (points as usize).min(s.points.len());
    let (opacity_set, widen) = match facing {
        Facing::Light => (u.opacity_set == 1, u.light_widen),
        Facing::Camera | Facing::CameraOpaque => (false, u.camera_widen),
    };
    for i in 0..points.saturating_sub(1) {
        let a = hair_point(u, &s.points[i], opacity_set, widen);
        if !a.drawn {
            continue;
        }
        let b = hair_point(u, &s.points[i + 1], opacity_set, widen);
        let base = out.world.len() as u32;
        for p in [a, b] {
            let toward = if facing == Facing::Light { to_light } else { (eye - p.position).normalize() };
            let side = across(p.tangent, toward);
            let (mut width, mut alpha, mut footprint) = (p.width, p.alpha, 0.0);
            let pixels = pixel_width(u, p.position, side, width);
            if facing == Facing::Camera && u.min_pixel_width > 0.0 && pixels > 0.0 {
                footprint = pixels.max(u.min_pixel_width);
                alpha *= pixels / footprint;
                width *= (footprint + 1.0) / pixels;
            }
            for sign in [-1.0f32, 1.0] {
                let w = p.position + side * (sign * 0.5 * width);
                out.world.push(w);
                out.tangent.push(p.tangent);
                out.color.push(p.color);
                out.alpha.push(alpha);
                out.across_px.push(if footprint > 0.0 { sign * 0.5 * (footprint + 1.0) } else { 0.0 });
                out.footprint.push(footprint);
                out.view_depth.push((w - eye).length());
            }
        }
        out.indices.extend([base, base + 1, base + 2, base + 2, base + 1, base + 3]);
    }
    out
}

/// `hair_coverage`: the share of a pixel a filtered strip covers across, from the fragment's
/// distance to the centre line and the strip's width in pixels (1 when `footprint` is 0).
pub fn coverage(across_px: f32, footprint: f32) -> f32 {
    if footprint <= 0.0 {
        return 1.0;
    }
    let d = across_px.abs();
    ((d + 0.5).min(0.5 * footprint) - (d - 0.5).max(-0.5 * footprint)).clamp(0.0, 1.0)
}

/// Far boundary of layer `k` (1-based) above `z0`.
pub fn boundary(z0: f32, step: f32, k: usize) -> f32 {
    z0 + step * (k * (k + 1) / 2) as f32
}

/// Every fragment the light passes rasterise from strips expanded toward the light:
/// `fragment(texel index, light NDC depth, opacity)` for each texel centre a triangle covers,
/// triangle by triangle.
pub fn for_each_light_fragment(
    e: &Expanded,
    light: &HairLight,
    resolution: u32,
    mut fragment: impl FnMut(usize, f32, f32),
) {
    let r = resolution as usize;
    let screen: Vec<(Vec3, f32)> = (0..e.world.len())
        .map(|v| {
            let c: Vec4 = light.view_proj * e.world[v].extend(1.0);
            let ndc = c.truncate() / c.w;
            (Vec3::new((ndc.x * 0.5 + 0.5) * r as f32, (0.5 - ndc.y * 0.5) * r as f32, ndc.z), e.alpha[v])
        })
        .collect();
    for tri in e.indices.chunks_exact(3) {
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

/// CPU reference of the two light passes over strips expanded toward the light: the nearest
/// depth per texel (1 where no hair) and the cumulative opacity layers, rasterising each
/// triangle at texel centres.
pub fn accumulate_cpu(e: &Expanded, light: &HairLight, resolution: u32) -> (Vec<f32>, Vec<[f32; 4]>) {
    let r = resolution as usize;
    let mut z0 = vec![1.0f32; r * r];
    for_each_light_fragment(e, light, resolution, |i, z, _| z0[i] = z0[i].min(z));
    let steps: Vec<f32> = (0..r * r)
        .map(|i| {
            let (nx, ny) = texel_ndc(i % r, i / r, resolution);
            light.step_at(nx, ny, z0[i])
        })
        .collect();
    let mut layers = vec![[0.0f32; 4]; r * r];
    for_each_light_fragment(e, light, resolution, |i, z, alpha| {
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
/// tangent and light and the specular lobe, both scaled by `visibility`; ambient unshadowed;
/// each channel saturating at 1.
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
    (base * (Vec3::from_slice(&uniform.ambient[..3]) + direct * sin_l) + direct * spec).min(Vec3::ONE)
}

/// `hair_oit_weight`: a fragment's weight in the order-independent blend, from its distance
/// to the eye `z` (within the hair box's `depth_range`) and opacity.
pub fn hair_oit_weight(u: &HairUniform, z: f32, a: f32) -> f32 {
    let [near, far] = u.depth_range;
    let t = ((z - near) / (far - near).max(1e-6)).clamp(0.0, 1.0);
    a * (-u.oit_falloff * t).exp().max(1e-4)
}

/// `hair_camera_boundary`: far boundary (view depth) of camera layer `k` (1-based, 1…8): the
/// hair box's nearest distance plus its depth range × k(k+1)/72.
pub fn hair_camera_boundary(u: &HairUniform, k: usize) -> f32 {
    let [near, far] = u.depth_range;
    near + (far - near).max(1e-6) * (k * (k + 1) / 2) as f32 / 36.0
}

/// The camera layers of one pixel: each of `fragments` (view depth, opacity) added to every
/// layer whose far boundary lies beyond it.
pub fn hair_camera_layers(u: &HairUniform, fragments: impl IntoIterator<Item = (f32, f32)>) -> [f32; 8] {
    let bounds: [f32; 8] = std::array::from_fn(|k| hair_camera_boundary(u, k + 1));
    let mut layers = [0.0f32; 8];
    for (z, alpha) in fragments {
        for (layer, &b) in layers.iter_mut().zip(&bounds) {
            if z < b {
                *layer += alpha;
            }
        }
    }
    layers
}

/// `hair_opacity_in_front`: the opacity of a pixel's hair in front of view depth `z`, its
/// camera `layers` interpolated between their boundaries.
pub fn hair_opacity_in_front(u: &HairUniform, layers: &[f32; 8], z: f32) -> f32 {
    let (mut lo, mut before) = (u.depth_range[0], 0.0);
    for (k, &layer) in layers.iter().enumerate() {
        let hi = hair_camera_boundary(u, k + 1);
        if z < hi {
            return before + (layer - before) * ((z - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0);
        }
        (lo, before) = (hi, layer);
    }
    layers[7]
}

/// `hair_layered_weight`: a fragment's weight in the blend weighted by the camera layers, at
/// view depth `z` with opacity `a`: the light the hair in front of it lets through.
pub fn hair_layered_weight(u: &HairUniform, layers: &[f32; 8], z: f32, a: f32) -> f32 {
    a * (-hair_opacity_in_front(u, layers, z)).exp().max(1e-4)
}

/// `skin_posed_vertex`: scalp vertex `v` skinned by `joints` (Σ weight × joint matrix ×
/// bind-pose position, over the vertex's joints with a weight above 0).
pub fn skin_posed_vertex(scalp: &hikage_bundle::Scalp, v: u32, joints: &[glam::Mat4]) -> Vec3 {
    let p = Vec3::from(scalp.positions[v as usize]);
    let (j, w) = (scalp.joints[v as usize], scalp.weights[v as usize]);
    (0..4)
        .filter(|&k| w[k] > 0.0)
        .map(|k| w[k] * joints[(j[k] as usize).min(joints.len() - 1)].transform_point3(p))
        .fold(Vec3::ZERO, |a, b| a + b)
}

/// `skin_frame`: the frame of triangle `(a, b, c)`: its first edge, the axis across, its normal.
pub fn skin_frame(a: Vec3, b: Vec3, c: Vec3) -> glam::Mat3 {
    let t = (b - a).normalize();
    let n = (b - a).cross(c - a).normalize();
    glam::Mat3::from_cols(t, n.cross(t), n)
}

/// The rigid motion of a strand bound by `binding` to `scalp` posed by `joints`, and where its
/// bound surface point is posed: `(rotation, rest point, posed point)`, so a strand point `p`
/// goes to `posed + rotation × (p − rest)`.
pub fn skin_strand(
    scalp: &hikage_bundle::Scalp,
    binding: &hikage_bundle::StrandBinding,
    joints: &[glam::Mat4],
) -> (glam::Mat3, Vec3, Vec3) {
    let tri = scalp.triangles[binding.triangle as usize];
    let rest = tri.map(|v| Vec3::from(scalp.positions[v as usize]));
    let posed = tri.map(|v| skin_posed_vertex(scalp, v, joints));
    let w = binding.weights();
    let rotation = skin_frame(posed[0], posed[1], posed[2]) * skin_frame(rest[0], rest[1], rest[2]).transpose();
    let at = |p: [Vec3; 3]| w[0] * p[0] + w[1] * p[1] + w[2] * p[2];
    (rotation, at(rest), at(posed))
}

/// `hair_skin`: every record posed by the triangle its strand is bound to (position and tangent
/// moved rigidly; a record whose strand has no binding is kept as it is).
pub fn hair_skin(
    points: &[StrandPoint],
    bindings: &[hikage_bundle::StrandBinding],
    scalp: &hikage_bundle::Scalp,
    joints: &[glam::Mat4],
) -> Vec<StrandPoint> {
    points
        .iter()
        .map(|p| {
            let Some(b) = bindings.get(p.strand_id as usize) else { return *p };
            let (rotation, rest, posed) = skin_strand(scalp, b, joints);
            StrandPoint {
                position: (posed + rotation * (Vec3::from(p.position) - rest)).to_array(),
                tangent: (rotation * Vec3::from(p.tangent)).normalize().to_array(),
                ..*p
            }
        })
        .collect()
}

/// The box the hair bound to `scalp` lies in when posed by `joints`: every skinned scalp vertex
/// grown by its reach (each strand point lies within its vertex's reach of its root's point,
/// and that point within its triangle).
pub fn skin_bounds(scalp: &hikage_bundle::Scalp, joints: &[glam::Mat4]) -> (Vec3, Vec3) {
    (0..scalp.positions.len()).fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), v| {
        let p = skin_posed_vertex(scalp, v as u32, joints);
        let r = Vec3::splat(scalp.reach[v]);
        (lo.min(p - r), hi.max(p + r))
    })
}

/// Strand polylines (`segments[s] + 1` points each, strand after strand, as a `.hair` file
/// holds them) posed as [`hair_skin`] poses their records: for tools that re-export posed hair.
pub fn skin_polylines(
    segments: &[u16],
    points: &[[f32; 3]],
    bindings: &[hikage_bundle::StrandBinding],
    scalp: &hikage_bundle::Scalp,
    joints: &[glam::Mat4],
) -> Vec<[f32; 3]> {
    let mut out = Vec::with_capacity(points.len());
    let mut at = 0;
    for (&n, binding) in segments.iter().zip(bindings) {
        let (rotation, rest, posed) = skin_strand(scalp, binding, joints);
        let strand = &points[at..(at + n as usize + 1).min(points.len())];
        out.extend(strand.iter().map(|&p| (posed + rotation * (Vec3::from(p) - rest)).to_array()));
        at += n as usize + 1;
    }
    out
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
