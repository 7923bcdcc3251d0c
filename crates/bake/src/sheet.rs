//! A contact sheet of a bundle for review: one HTML page with a small PNG per asset, rendered
//! on the CPU (CI has no GPU) — heights shaded, AO, each horizon map as the lit mask of a low
//! sun from four azimuths, relief depth for four directions, strands and meshes from the side,
//! curvature as colour — each labelled with its id, size, format, bytes and budget. Given the
//! previous bundle, the assets `hikage_bundle::diff` finds changed show old, new and their
//! difference side by side.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hikage_bundle::diff::{Status, Tolerances};
use hikage_bundle::{Asset, AssetKind, Bundle, Settings, TextureData};

use crate::BakeError;

/// Largest side of a rendered panel, pixels.
const SIDE: usize = 192;

/// Sun elevation of the horizon masks, degrees: low, where horizon maps matter.
pub const MASK_SUN_DEGREES: f32 = 5.0;

/// What [`write_sheet`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SheetReport {
    /// The page, `index.html` in the output directory.
    pub page: PathBuf,
    /// PNG files written.
    pub images: usize,
    /// Bytes of the page and its images.
    pub bytes: u64,
    /// Assets shown old beside new (changed since `old`).
    pub changed: usize,
}

/// A grey or colour picture.
struct Picture {
    width: usize,
    height: usize,
    rgb: Vec<[u8; 3]>,
}

impl Picture {
    fn new(width: usize, height: usize) -> Picture {
        Picture { width, height, rgb: vec![[0; 3]; width * height] }
    }

    /// `value(x, y)` in 0–1 as grey, `w`×`h` samples scaled to fit [`SIDE`].
    fn grey(w: usize, h: usize, value: impl Fn(usize, usize) -> f32) -> Picture {
        Picture::colour(w, h, |x, y| {
            let g = (value(x, y).clamp(0.0, 1.0) * 255.0).round() as u8;
            [g, g, g]
        })
    }

    /// `colour(x, y)` of `w`×`h` samples, nearest-sampled to fit [`SIDE`].
    fn colour(w: usize, h: usize, colour: impl Fn(usize, usize) -> [u8; 3]) -> Picture {
        let scale = (SIDE as f32 / w.max(h).max(1) as f32).min(4.0);
        let (pw, ph) = (((w as f32 * scale) as usize).max(1), ((h as f32 * scale) as usize).max(1));
        let mut p = Picture::new(pw, ph);
        for y in 0..ph {
            for x in 0..pw {
                let (sx, sy) = ((x * w / pw).min(w - 1), (y * h / ph).min(h - 1));
                p.rgb[y * pw + x] = colour(sx, sy);
            }
        }
        p
    }

    /// Pictures side by side, a gap between.
    fn row(parts: &[Picture]) -> Picture {
        let gap = 4;
        let width = parts.iter().map(|p| p.width).sum::<usize>() + gap * parts.len().saturating_sub(1);
        let height = parts.iter().map(|p| p.height).max().unwrap_or(1);
        let mut out = Picture::new(width.max(1), height);
        out.rgb.fill([40, 40, 40]);
        let mut x0 = 0;
        for p in parts {
            for y in 0..p.height {
                let at = y * out.width + x0;
                out.rgb[at..at + p.width].copy_from_slice(&p.rgb[y * p.width..(y + 1) * p.width]);
            }
            x0 += p.width + gap;
        }
        out
    }

    /// Where `self` and `other` differ, 4× amplified, in red on black (sizes must agree).
    fn difference(&self, other: &Picture) -> Option<Picture> {
        if (self.width, self.height) != (other.width, other.height) {
            return None;
        }
        let mut out = Picture::new(self.width, self.height);
        for (o, (a, b)) in out.rgb.iter_mut().zip(self.rgb.iter().zip(&other.rgb)) {
            let d = (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
            *o = [d.saturating_mul(4), 0, 0];
        }
        Some(out)
    }

    fn png(&self, path: &Path) -> Result<u64, BakeError> {
        let bytes: Vec<u8> = self.rgb.iter().flatten().copied().collect();
        let grey = self.rgb.iter().all(|p| p[0] == p[1] && p[1] == p[2]);
        let (data, colour) = if grey {
            (self.rgb.iter().map(|p| p[0]).collect(), image::ExtendedColorType::L8)
        } else {
            (bytes, image::ExtendedColorType::Rgb8)
        };
        let mut out = Vec::new();
        let encoder = image::codecs::png::PngEncoder::new_with_quality(
            &mut out,
            image::codecs::png::CompressionType::Best,
            image::codecs::png::FilterType::Adaptive,
        );
        image::ImageEncoder::write_image(encoder, &data, self.width as u32, self.height as u32, colour)
            .map_err(|e| BakeError::io(path, std::io::Error::other(e)))?;
        std::fs::write(path, &out).map_err(|e| BakeError::io(path, e))?;
        Ok(out.len() as u64)
    }
}

/// The picture of asset `asset` in `bundle`, with what it shows; `None` for a kind with nothing
/// to show.
fn render(bundle: &Bundle, asset: &Asset) -> Result<Option<(Picture, String)>, BakeError> {
    if asset.kind.is_mesh() {
        let mesh = bundle.read_mesh(&asset.id)?;
        return Ok(mesh_picture(asset.kind, &mesh));
    }
    let t = bundle.read_texture(&asset.id)?;
    let (w, h) = (t.desc.width as usize, t.desc.height as usize);
    let slices = (t.desc.depth.max(1) * t.desc.layers.max(1)) as usize;
    Ok(Some(match &asset.settings {
        Settings::Heightfield(s) => {
            let v = t.channel_f32(0, 0);
            let world = |x: usize, y: usize| s.height_offset + s.height_scale * v[y.min(h - 1) * w + x.min(w - 1)];
            let (sx, sy) = s.texel_size;
            let shade = |x: usize, y: usize| {
                let du = (world(x + 1, y) - world(x.saturating_sub(1), y)) / (2.0 * sx);
                let dv = (world(x, y + 1) - world(x, y.saturating_sub(1))) / (2.0 * sy);
                // Lit from the upper left, 45° up.
                let n = [-du, -dv, 1.0];
                let l = [-0.5f32, -0.5, std::f32::consts::FRAC_1_SQRT_2];
                let len = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
                0.1 + 0.9 * ((n[0] * l[0] + n[1] * l[1] + n[2] * l[2]) / len).max(0.0)
            };
            (Picture::grey(w, h, shade), "heights, shaded from the upper left".into())
        }
        Settings::Horizon(s) => {
            let v = t.to_f32(0);
            let tan_sun = MASK_SUN_DEGREES.to_radians().tan();
            let masks: Vec<Picture> = (0..4)
                .map(|q| {
                    let k = (q * slices / 4) % slices.max(1);
                    Picture::grey(w, h, |x, y| {
                        let i = ((k * h + y) * w + x) * 2;
                        let (tan_beta, _) = s.decode(t.desc.format, v[i], v[i + 1]);
                        if tan_sun > tan_beta { 1.0 } else { 0.15 }
                    })
                })
                .collect();
            let what = format!("lit mask of a {MASK_SUN_DEGREES}° sun from azimuths 0°, 90°, 180°, 270°");
            (Picture::row(&masks), what)
        }
        Settings::AmbientOcclusion(_) => {
            let v = t.channel_f32(0, 0);
            (Picture::grey(w, h, |x, y| 1.0 - v[y * w + x]), "sky visibility (1 − AO)".into())
        }
        Settings::Relief(_) => {
            let v = t.channel_f32(0, 0);
            let layers: Vec<Picture> = (0..4)
                .map(|q| {
                    let k = ((2 * q + 1) * slices / 8).min(slices - 1);
                    Picture::grey(w, h, |x, y| 1.0 - v[(k * h + y) * w + x])
                })
                .collect();
            (Picture::row(&layers), "depth of four directions (dark: deep)".into())
        }
        _ => {
            let v = channel_range(&t);
            (Picture::grey(w, h, |x, y| v[y * w + x]), "channel 0 of slice 0, its range stretched".into())
        }
    }))
}

/// Channel 0 of `t`'s first slice stretched to 0–1.
fn channel_range(t: &TextureData) -> Vec<f32> {
    let n = (t.desc.width * t.desc.height) as usize;
    let v: Vec<f32> = t.channel_f32(0, 0).into_iter().take(n).collect();
    let (lo, hi) = v.iter().filter(|x| x.is_finite()).fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    v.iter().map(|x| (x - lo) / span).collect()
}

/// A mesh seen along the axis it is thinnest on: strands and meshes as point density, curvature meshes coloured by mean curvature (blue negative, red positive).
fn mesh_picture(kind: AssetKind, mesh: &hikage_bundle::MeshData) -> Option<(Picture, String)> {
    let p = mesh.read_f32("position")?;
    let points: Vec<[f32; 3]> = p.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    if points.is_empty() {
        return None;
    }
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for q in &points {
        for a in 0..3 {
            lo[a] = lo[a].min(q[a]);
            hi[a] = hi[a].max(q[a]);
        }
    }
    // Seen along the axis it is thinnest on: the other two, in order, across and up.
    let thin = (0..3).min_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b]))).unwrap_or(2);
    let (u, v) = match thin {
        0 => (2, 1),
        1 => (0, 2),
        _ => (0, 1),
    };
    let span = (hi[u] - lo[u]).max(hi[v] - lo[v]).max(f32::MIN_POSITIVE);
    let (w, h) = (SIDE, SIDE);
    let centre = |a: usize| 0.5 * (lo[a] + hi[a]);
    let pixel = |q: &[f32; 3]| {
        let x = (((q[u] - centre(u)) / span + 0.5) * (w - 2) as f32) as usize;
        let y = (((centre(v) - q[v]) / span + 0.5) * (h - 2) as f32) as usize;
        (x.min(w - 2), y.min(h - 2))
    };
    let mut picture = Picture::new(w, h);
    if let (AssetKind::Curvature, Some(k)) = (kind, mesh.read_f32("curvature")) {
        let mean: Vec<f32> = k.chunks_exact(2).map(|c| 0.5 * (c[0] + c[1])).collect();
        let scale = mean.iter().fold(0f32, |m, v| m.max(v.abs())).max(f32::MIN_POSITIVE);
        for (q, m) in points.iter().zip(&mean) {
            let t = m / scale;
            let (x, y) = pixel(q);
            let c = |v: f32| (v.clamp(0.0, 1.0) * 255.0) as u8;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                picture.rgb[(y + dy) * w + x + dx] = [c(0.5 + t), c(0.5 - t.abs() * 0.5), c(0.5 - t)];
            }
        }
        return Some((picture, "mean curvature, seen across its thinnest axis (red +, blue −)".into()));
    }
    let mut count = vec![0u32; w * h];
    for q in &points {
        let (x, y) = pixel(q);
        count[y * w + x] += 1;
    }
    let most = *count.iter().max().unwrap_or(&1) as f32;
    for (o, c) in picture.rgb.iter_mut().zip(&count) {
        let g = ((*c as f32).ln_1p() / most.ln_1p() * 255.0) as u8;
        *o = [g, g, g];
    }
    Some((picture, "point density, seen across its thinnest axis".into()))
}

/// The budget that holds `id`: its own, its job's, or the bundle's, as text.
fn budget_of(bundle: &Bundle, id: &str) -> String {
    let Some(b) = &bundle.manifest().budget else { return "none".into() };
    let mib = |v: Option<u64>| v.map(|v| format!("{:.1} MiB", v as f64 / 1048576.0));
    let show = |disk: Option<u64>, gpu: Option<u64>, of: &str| {
        let parts: Vec<String> = [mib(disk).map(|d| format!("disk {d}")), mib(gpu).map(|g| format!("GPU {g}"))]
            .into_iter()
            .flatten()
            .collect();
        (!parts.is_empty()).then(|| format!("{} ({of})", parts.join(", ")))
    };
    let job = id.split('.').next().unwrap_or(id);
    b.assets
        .get(id)
        .and_then(|l| show(l.disk, l.gpu, "asset"))
        .or_else(|| b.jobs.get(job).and_then(|l| show(l.disk, l.gpu, "job")))
        .or_else(|| show(b.disk, b.gpu, "bundle"))
        .unwrap_or_else(|| "none".into())
}

/// Characters of text put into the page, escaped for HTML.
fn html(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Writes the contact sheet of `bundle` into `out` (created): `index.html` and one PNG per
/// asset (`<id>.png`, and `<id>.old.png`, `<id>.diff.png` for assets changed since `old`).
///
/// ```no_run
/// use hikage_bundle::Bundle;
/// let bundle = Bundle::open("bundle".as_ref())?;
/// let report = hikage_bake::sheet::write_sheet(&bundle, None, "sheet".as_ref())?;
/// println!("{}: {} images, {} bytes", report.page.display(), report.images, report.bytes);
/// # Ok::<(), hikage_bake::BakeError>(())
/// ```
pub fn write_sheet(bundle: &Bundle, old: Option<&Bundle>, out: &Path) -> Result<SheetReport, BakeError> {
    std::fs::create_dir_all(out).map_err(|e| BakeError::io(out, e))?;
    let changes = match old {
        Some(o) => hikage_bundle::diff::diff(o, bundle, &Tolerances::default())?,
        None => Vec::new(),
    };
    let summary = hikage_bundle::inspect::summarize(bundle.manifest());
    let assets = &bundle.manifest().assets;
    // Every asset's pictures, on every core.
    let rendered: Vec<Result<Option<(Picture, String)>, BakeError>> = {
        use rayon::prelude::*;
        assets.par_iter().map(|a| render(bundle, a)).collect()
    };
    let mut page = String::new();
    let title = html(&bundle.dir().display().to_string());
    let _ = write!(
        page,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>hikage: {title}</title>\n<style>\
         body{{font:14px sans-serif;background:#1e1e1e;color:#ddd;margin:1em}}\
         .card{{display:inline-block;vertical-align:top;margin:6px;padding:8px;background:#2a2a2a;border-radius:4px}}\
         .changed{{outline:2px solid #e07030}} img{{image-rendering:pixelated;display:block;margin:4px 0}}\
         small{{color:#999}} h1{{font-size:18px}}</style></head><body>\n<h1>{title}: {} assets, {:.1} MiB on disk, \
         {:.1} MiB in GPU memory</h1>\n",
        summary.assets.len(),
        summary.disk_bytes as f64 / 1048576.0,
        summary.gpu_bytes as f64 / 1048576.0
    );
    let (mut images, mut bytes, mut changed) = (0usize, 0u64, 0usize);
    for ((asset, info), picture) in assets.iter().zip(&summary.assets).zip(rendered) {
        let Some((picture, what)) = picture? else { continue };
        let file = format!("{}.png", asset.id);
        bytes += picture.png(&out.join(&file))?;
        images += 1;
        let change = changes.iter().find(|c| c.id == asset.id).map(|c| c.status);
        let mut extra = String::new();
        if let (Some(Status::Changed), Some(o)) = (change, old) {
            let before = o.manifest().asset(&asset.id).map(|a| render(o, a)).transpose()?.flatten();
            if let Some((before, _)) = before {
                let old_file = format!("{}.old.png", asset.id);
                bytes += before.png(&out.join(&old_file))?;
                images += 1;
                let _ = write!(extra, "<small>old</small><img src=\"{}\" alt=\"old\">", html(&old_file));
                if let Some(d) = before.difference(&picture) {
                    let diff_file = format!("{}.diff.png", asset.id);
                    bytes += d.png(&out.join(&diff_file))?;
                    images += 1;
                    let _ = write!(
                        extra,
                        "<small>difference (×4)</small><img src=\"{}\" alt=\"difference\">",
                        html(&diff_file)
                    );
                }
                changed += 1;
            }
        }
        let dims = info.dimensions.iter().map(u64::to_string).collect::<Vec<_>>().join("×");
        let status = match change {
            Some(Status::Changed) => " — changed",
            Some(Status::Added) => " — added",
            _ => "",
        };
        let _ = writeln!(
            page,
            "<div class=\"card{}\"><b>{}</b>{status}<br><small>{} · {} {} · {:.2} MiB on disk, {:.2} MiB GPU · budget {}</small>\
             <br><small>{}</small>{}<small>{}</small><img src=\"{}\" alt=\"{}\"></div>",
            if change == Some(Status::Changed) { " changed" } else { "" },
            html(&asset.id),
            html(&info.kind),
            html(&info.format),
            html(&dims),
            info.byte_length as f64 / 1048576.0,
            info.gpu_bytes as f64 / 1048576.0,
            html(&budget_of(bundle, &asset.id)),
            html(&what),
            extra,
            if extra.is_empty() { "" } else { "new" },
            html(&file),
            html(&asset.id),
        );
    }
    let removed: Vec<&str> = changes.iter().filter(|c| c.status == Status::Removed).map(|c| c.id.as_str()).collect();
    if !removed.is_empty() {
        let _ = writeln!(page, "<p>Removed since the old bundle: {}</p>", html(&removed.join(", ")));
    }
    page.push_str("</body></html>\n");
    let path = out.join("index.html");
    std::fs::write(&path, &page).map_err(|e| BakeError::io(&path, e))?;
    bytes += page.len() as u64;
    Ok(SheetReport { page: path, images, bytes, changed })
}
