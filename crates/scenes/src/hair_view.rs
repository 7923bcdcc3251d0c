//! The hair as the camera sees it, against the same renderer supersampled (demo code): one
//! frame of hair over black rendered at a multiple of the size and box-filtered down in linear
//! light, and the measures of issue-style comparisons — RMS and largest difference, noise (mean
//! absolute Laplacian) and flicker under a small orbit. Used by the `hair_view` example and the
//! GPU tests.

use glam::{Mat4, Vec3};
use hikage_runtime::hair::{BlendWeight, HairFrame, HairOptions, HairRenderer};
use hikage_runtime::{GpuBundle, RuntimeError};

use crate::hair_scene::{HairBlend, render_frame, srgb_to_linear};
use crate::headless::{COLOR_FORMAT, DEPTH_FORMAT, Headless};

/// An image of sRGB-encoded RGB values in 0–1, row-major.
pub type Image = Vec<[f32; 3]>;

/// A camera around the hair: `view_proj` for a target of aspect 1, and the eye.
pub fn orbit_camera(lo: Vec3, hi: Vec3, degrees: f32) -> (Mat4, Vec3) {
    use glam::camera::rh::proj::directx;
    use glam::camera::rh::view::look_at_mat4;
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let a = degrees.to_radians();
    let eye = centre + Vec3::new(0.55 * a.sin() + 0.8 * a.cos(), 0.25, 0.8 * -a.sin() + 0.55 * a.cos()) * 2.0 * radius;
    let view = look_at_mat4(eye, centre, Vec3::Y);
    (directx::perspective(40f32.to_radians(), 1.0, 0.05 * radius, 6.0 * radius) * view, eye)
}

/// Renderers of `strips` for a `size` frame and for `factor` times it (the reference), with
/// `resolution`² opacity maps and the default blend.
pub fn renderers(
    g: &Headless,
    gpu: &GpuBundle,
    strips: &str,
    size: u32,
    factor: u32,
    resolution: u32,
) -> Result<(HairRenderer, HairRenderer), RuntimeError> {
    let blend = BlendWeight::default();
    Ok((
        renderer(g, gpu, strips, size, resolution, blend)?,
        renderer(g, gpu, strips, size * factor, resolution, blend)?,
    ))
}

/// The renderer of `strips` for a `side`² frame with depth, `resolution`² opacity maps and the
/// blend weighted by `blend`.
pub fn renderer(
    g: &Headless,
    gpu: &GpuBundle,
    strips: &str,
    side: u32,
    resolution: u32,
    blend: BlendWeight,
) -> Result<HairRenderer, RuntimeError> {
    let mut options = HairOptions { resolution, blend, ..HairOptions::new(COLOR_FORMAT, (side, side)) };
    options.draw.depth_format = Some(DEPTH_FORMAT);
    HairRenderer::new(&g.device, &g.queue, gpu, strips, &options)
}

/// `frame` drawn by `renderer` (whose frame targets are `size·factor` square) over black, the
/// order-independent blend, box-filtered `factor`× in linear light and encoded as sRGB again.
pub fn render_view(g: &Headless, renderer: &HairRenderer, frame: &HairFrame, size: u32, factor: u32) -> Image {
    renderer.update(&g.queue, frame);
    let side = size * factor;
    let rgba = render_frame(g, renderer, None, HairBlend::OrderIndependent, (side, side), wgpu::Color::BLACK);
    let (n, f) = (size as usize, factor as usize);
    let mut sum = vec![[0.0f32; 3]; n * n];
    for (i, px) in rgba.chunks_exact(4).enumerate() {
        let (x, y) = (i % (n * f), i / (n * f));
        let s = &mut sum[(y / f) * n + x / f];
        for k in 0..3 {
            s[k] += srgb_to_linear(px[k]);
        }
    }
    let encode = |c: f32| if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    sum.into_iter().map(|s| s.map(|c| encode(c / (f * f) as f32))).collect()
}

/// The pixels where either image shows hair (any channel above half a step of 8 bits).
pub fn hair_mask(a: &Image, b: &Image) -> Vec<bool> {
    a.iter().zip(b).map(|(p, q)| p.iter().chain(q).any(|&c| c > 0.5 / 255.0)).collect()
}

/// RMS and largest difference of every channel over the `mask` pixels.
pub fn difference(a: &Image, b: &Image, mask: &[bool]) -> (f64, f64) {
    let (mut sq, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for ((p, q), _) in a.iter().zip(b).zip(mask).filter(|(_, m)| **m) {
        for k in 0..3 {
            let d = (p[k] - q[k]) as f64;
            sq += d * d;
            max = max.max(d.abs());
            n += 1;
        }
    }
    ((sq / n.max(1) as f64).sqrt(), max)
}

/// Noise: the mean absolute Laplacian of the luminance over the `mask` pixels away from the
/// border — isolated dots raise it, smooth shading keeps it low.
pub fn noise(a: &Image, size: u32, mask: &[bool]) -> f64 {
    let n = size as usize;
    let lum = |i: usize| (0.2126 * a[i][0] + 0.7152 * a[i][1] + 0.0722 * a[i][2]) as f64;
    let (mut sum, mut count) = (0.0f64, 0usize);
    for y in 1..n - 1 {
        for x in 1..n - 1 {
            let i = y * n + x;
            if mask[i] {
                sum += (4.0 * lum(i) - lum(i - 1) - lum(i + 1) - lum(i - n) - lum(i + n)).abs();
                count += 1;
            }
        }
    }
    sum / count.max(1) as f64
}

/// Flicker: the share of the `mask` pixels whose luminance changes by more than 0.1 between
/// two frames.
pub fn flicker(a: &Image, b: &Image, mask: &[bool]) -> f64 {
    let lum = |p: &[f32; 3]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let (mut changed, mut count) = (0usize, 0usize);
    for ((p, q), _) in a.iter().zip(b).zip(mask).filter(|(_, m)| **m) {
        changed += ((lum(p) - lum(q)).abs() > 0.1) as usize;
        count += 1;
    }
    changed as f64 / count.max(1) as f64
}

/// The mean linear luminance of an image over every pixel: over black, the hair's coverage
/// times its brightness (what a level of detail must keep).
pub fn mean_luminance(a: &Image) -> f64 {
    let linear = |c: f32| if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    let lum = |p: &[f32; 3]| 0.2126 * linear(p[0]) + 0.7152 * linear(p[1]) + 0.0722 * linear(p[2]);
    a.iter().map(|p| lum(p) as f64).sum::<f64>() / a.len().max(1) as f64
}
