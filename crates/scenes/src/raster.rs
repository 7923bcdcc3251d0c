//! A CPU rasteriser for the GPU tests: which triangle covers each pixel centre, and with which
//! barycentric weights, so a test can interpolate a mesh's streams there and run a shader's CPU
//! reference on them. Coverage and depth are affine in screen space; the weights are
//! perspective-correct, as the GPU interpolates vertex outputs. Nearest surface wins; back faces
//! (clockwise in NDC, the opposite of wgpu's default counter-clockwise front face) are culled
//! when asked.

use glam::{Vec3, Vec4};

/// Per pixel, row-major: the covering triangle's index and its vertices' weights.
pub type Coverage = Vec<Option<(usize, [f32; 3])>>;

/// Rasterises triangles `indices` of clip-space `clip` positions into `width × height` pixels:
/// the nearest triangle per pixel.
pub fn rasterise(clip: &[Vec4], indices: &[u32], size: (u32, u32), cull_back: bool) -> Coverage {
    let mut cover: Coverage = vec![None; (size.0 * size.1) as usize];
    let mut depth = vec![f32::INFINITY; cover.len()];
    for_each_fragment(clip, indices, size, cull_back, |i, t, weights, z| {
        if z < depth[i] {
            depth[i] = z;
            cover[i] = Some((t, weights));
        }
    });
    cover
}

/// Calls `f(pixel, triangle, weights, ndc_depth)` for every pixel centre every triangle covers,
/// in triangle order (a pixel covered by several triangles is visited once for each).
pub fn for_each_fragment(
    clip: &[Vec4],
    indices: &[u32],
    (width, height): (u32, u32),
    cull_back: bool,
    mut f: impl FnMut(usize, usize, [f32; 3], f32),
) {
    let (w, h) = (width as usize, height as usize);
    // Framebuffer coordinates (y down) and NDC depth.
    let inv_w: Vec<f32> = clip.iter().map(|c| 1.0 / c.w).collect();
    let screen: Vec<Vec3> = clip
        .iter()
        .map(|c| {
            let n = c.truncate() / c.w;
            Vec3::new((n.x * 0.5 + 0.5) * width as f32, (0.5 - n.y * 0.5) * height as f32, n.z)
        })
        .collect();
    for (t, tri) in indices.chunks_exact(3).enumerate() {
        let (a, b, c) = (screen[tri[0] as usize], screen[tri[1] as usize], screen[tri[2] as usize]);
        // Signed area in framebuffer coordinates: negative is counter-clockwise in NDC.
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-12 || (cull_back && area > 0.0) {
            continue;
        }
        let x0 = a.x.min(b.x).min(c.x).floor().max(0.0) as usize;
        let x1 = (a.x.max(b.x).max(c.x).ceil().max(0.0) as usize).min(w);
        let y0 = a.y.min(b.y).min(c.y).floor().max(0.0) as usize;
        let y1 = (a.y.max(b.y).max(c.y).ceil().max(0.0) as usize).min(h);
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let edge = |p: Vec3, q: Vec3| ((q.x - p.x) * (py - p.y) - (q.y - p.y) * (px - p.x)) / area;
                let weights = [edge(b, c), edge(c, a), edge(a, b)];
                if weights.iter().any(|&k| k < 0.0) {
                    continue;
                }
                let z = weights[0] * a.z + weights[1] * b.z + weights[2] * c.z;
                let q = [0, 1, 2].map(|k| weights[k] * inv_w[tri[k] as usize]);
                let sum = q[0] + q[1] + q[2];
                f(y * w + x, t, q.map(|v| v / sum), z);
            }
        }
    }
}

/// A stream of `components` floats per vertex interpolated with `weights` over triangle `t`.
pub fn interpolate(stream: &[f32], components: usize, indices: &[u32], t: usize, weights: [f32; 3]) -> Vec<f32> {
    let mut out = vec![0.0; components];
    for (k, &wk) in weights.iter().enumerate() {
        let v = indices[3 * t + k] as usize;
        for (c, o) in out.iter_mut().enumerate() {
            *o += wk * stream[v * components + c];
        }
    }
    out
}
