//! A contact sheet of a bundle for review: one HTML page with a small PNG per asset, rendered
//! on the CPU (CI has no GPU) — heights shaded, AO, each horizon map as the lit mask of a low
//! sun from four azimuths, relief depth for four directions, strands and meshes from the side,
//! curvature as colour — each labelled with its id, size, format, bytes and budget. Given the
//! previous bundle, the assets `hikage_bundle::diff` finds changed show old, new and their
//! difference side by side.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use hikage_bundle::diff::{Status, Tolerances};
use hikage_bundle::{Asset, AssetKind, Bundle, Payload, Settings, TextureData};

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
/// to show. `panels` 4 shows a horizon or relief map from four directions, 1 from the first.
/// An error names the asset as well as the file (a shared payload's file is named after
/// another asset).
fn render(bundle: &Bundle, asset: &Asset, panels: usize) -> Result<Option<(Picture, String)>, BakeError> {
    let named = |e: hikage_bundle::BundleError| {
        BakeError::input(bundle.payload_path(asset), Some(format!("asset `{}`", asset.id)), e.to_string())
    };
    if asset.kind.is_mesh() {
        let mesh = bundle.read_mesh(&asset.id).map_err(named)?;
        return Ok(mesh_picture(asset.kind, &mesh));
    }
    let t = bundle.read_texture(&asset.id).map_err(named)?;
    let (w, h) = (t.desc.width as usize, t.desc.height as usize);
    let slices = (t.desc.depth.max(1) * t.desc.layers.max(1)) as usize;
    Ok(Some(match &asset.settings {
        Settings::Heightfield(s) => {
            let v = t.channel_f32(0, 0);
            let world = |x: usize, y: usize| s.world_height(v[y.min(h - 1) * w + x.min(w - 1)]);
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
            let masks: Vec<Picture> = (0..panels)
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
            let layers: Vec<Picture> = (0..panels)
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

/// Largest side of a tiled map's level-0 mosaic, pixels; level `k`'s is this over `2^k` (at
/// least [`MOSAIC_MIN`]).
const MOSAIC: usize = 512;

/// Smallest side of a level's mosaic, pixels.
const MOSAIC_MIN: usize = 64;

/// A picture's place on the page: a plain asset's, or the mosaic of one part of a tiled map at
/// one level (`<part>.L<k>`).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Card {
    Asset(usize),
    Map { part: String, level: u32 },
}

impl Card {
    /// The picture's file in role directory `role` (`new`, `old`, `diff`): plain assets under
    /// `asset/`, mosaics under `map/`, so no asset's name can meet another picture's.
    fn file(&self, assets: &[Asset], role: &str) -> String {
        match self {
            Card::Asset(i) => format!("{role}/asset/{}.png", assets[*i].id),
            Card::Map { part, level } => format!("{role}/map/{part}.L{level}.png"),
        }
    }
}

/// The card of each asset: its own, or its tiled map's mosaic for its part and level.
fn card_of(asset: &Asset, index: usize) -> Card {
    match asset.settings.tile() {
        Some(p) => {
            let part = hikage_bundle::tiles::tile_part(&asset.id, p).unwrap_or(&asset.id).to_string();
            Card::Map { part, level: p.level }
        }
        None => Card::Asset(index),
    }
}

/// The mosaic of the tiles `tiles` (indices into `bundle`'s assets, one part of one level):
/// each tile's picture (its first panel) scaled into its place in the level's map, the whole at
/// most [`MOSAIC`] over `2^level` a side. Tiles are rendered on every core, each as small as its
/// place, so a map of thousands of tiles never holds their full pictures at once.
fn mosaic(bundle: &Bundle, tiles: &[usize], level: u32) -> Result<Option<(Picture, String)>, BakeError> {
    use rayon::prelude::*;
    let assets = &bundle.manifest().assets;
    let map = tiles.iter().filter_map(|&i| assets[i].settings.tile()).map(|p| p.map_size).next().unwrap_or((1, 1));
    let side = (MOSAIC >> level.min(16)).max(MOSAIC_MIN) as f32;
    let scale = side / map.0.max(map.1).max(1) as f32;
    let (w, h) = (((map.0 as f32 * scale).ceil() as usize).max(1), ((map.1 as f32 * scale).ceil() as usize).max(1));
    let placed: Vec<Option<(usize, usize, Picture, String)>> = tiles
        .par_iter()
        .map(|&i| -> Result<_, BakeError> {
            let a = &assets[i];
            let (Some(p), Payload::Texture(t)) = (a.settings.tile(), &a.payload) else { return Ok(None) };
            let Some((picture, what)) = render(bundle, a, 1)? else { return Ok(None) };
            let (x0, y0) = ((p.origin.0 as f32 * scale) as usize, (p.origin.1 as f32 * scale) as usize);
            let x1 = (((p.origin.0 + t.width) as f32 * scale).ceil() as usize).clamp(x0 + 1, w.max(x0 + 1));
            let y1 = (((p.origin.1 + t.height) as f32 * scale).ceil() as usize).clamp(y0 + 1, h.max(y0 + 1));
            let (pw, ph) = (x1 - x0, y1 - y0);
            let mut small = Picture::new(pw, ph);
            for y in 0..ph {
                for x in 0..pw {
                    small.rgb[y * pw + x] =
                        picture.rgb[(y * picture.height / ph) * picture.width + x * picture.width / pw];
                }
            }
            Ok(Some((x0, y0, small, what)))
        })
        .collect::<Result<_, _>>()?;
    let mut out = Picture::new(w, h);
    out.rgb.fill([40, 40, 40]);
    let mut what = None;
    for (x0, y0, small, w_) in placed.into_iter().flatten() {
        for y in 0..small.height {
            for x in 0..small.width {
                if y0 + y < h && x0 + x < w {
                    out.rgb[(y0 + y) * w + x0 + x] = small.rgb[y * small.width + x];
                }
            }
        }
        what.get_or_insert(w_);
    }
    Ok(what.map(|what| (out, format!("{} tiles: {what}", tiles.len()))))
}

/// The picture of `card` in `bundle`: an asset's, or a mosaic of the tiles `tiles` lists for it.
fn picture_of(
    bundle: &Bundle,
    card: &Card,
    tiles: &std::collections::BTreeMap<Card, Vec<usize>>,
) -> Result<Option<(Picture, String)>, BakeError> {
    match card {
        Card::Asset(i) => render(bundle, &bundle.manifest().assets[*i], 4),
        Card::Map { level, .. } => mosaic(bundle, &tiles[card], *level),
    }
}

/// Every card of `bundle` in manifest order (a map's mosaic where its first tile is), and each
/// map card's tiles.
fn cards(bundle: &Bundle) -> (Vec<Card>, std::collections::BTreeMap<Card, Vec<usize>>) {
    let mut order = Vec::new();
    let mut tiles: std::collections::BTreeMap<Card, Vec<usize>> = Default::default();
    for (i, a) in bundle.manifest().assets.iter().enumerate() {
        let card = card_of(a, i);
        if let Card::Map { .. } = card {
            let list = tiles.entry(card.clone()).or_default();
            if list.is_empty() {
                order.push(card);
            }
            list.push(i);
        } else {
            order.push(card);
        }
    }
    (order, tiles)
}

/// Writes the contact sheet of `bundle` into `out` (created): `index.html` and one PNG per
/// plain asset (`new/asset/<id>.png`; for assets changed since `old`, `old/asset/<id>.png` and
/// `diff/asset/<id>.png`), and per tiled map, part and level one mosaic of its tiles
/// (`new/map/<part>.L<k>.png`, old and diff likewise when a tile changed).
///
/// ```no_run
/// use hikage_bundle::Bundle;
/// let bundle = Bundle::open("bundle".as_ref())?;
/// let report = hikage_bake::export::sheet::write_sheet(&bundle, None, "sheet".as_ref())?;
/// println!("{}: {} images, {} bytes", report.page.display(), report.images, report.bytes);
/// # Ok::<(), hikage_bake::BakeError>(())
/// ```
pub fn write_sheet(bundle: &Bundle, old: Option<&Bundle>, out: &Path) -> Result<SheetReport, BakeError> {
    for role in ["new", "old", "diff"] {
        for kind in ["asset", "map"] {
            let dir = out.join(role).join(kind);
            std::fs::create_dir_all(&dir).map_err(|e| BakeError::io(&dir, e))?;
        }
    }
    let changes = match old {
        Some(o) => hikage_bundle::diff::diff(o, bundle, &Tolerances::default())?,
        None => Vec::new(),
    };
    let status = |id: &str| changes.iter().find(|c| c.id == id).map(|c| c.status);
    let summary = hikage_bundle::inspect::summarize(bundle.manifest());
    let assets = &bundle.manifest().assets;
    let (order, tiles) = cards(bundle);
    let old_cards = old.map(cards);
    // Every plain asset's picture on every core; a mosaic renders its tiles on every core.
    let rendered: Vec<Result<Option<(Picture, String)>, BakeError>> = {
        use rayon::prelude::*;
        order.par_iter().map(|c| picture_of(bundle, c, &tiles)).collect()
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
    for (card, picture) in order.iter().zip(rendered) {
        let Some((picture, what)) = picture? else { continue };
        let file = card.file(assets, "new");
        bytes += picture.png(&out.join(&file))?;
        images += 1;
        // What the card stands for: its asset, or its tiles.
        let members: Vec<usize> = match card {
            Card::Asset(i) => vec![*i],
            Card::Map { .. } => tiles[card].clone(),
        };
        let statuses: Vec<Option<Status>> = members.iter().map(|&i| status(&assets[i].id)).collect();
        let change = if statuses.contains(&Some(Status::Changed)) {
            Some(Status::Changed)
        } else if statuses.iter().all(|s| *s == Some(Status::Added)) {
            Some(Status::Added)
        } else {
            None
        };
        let mut extra = String::new();
        if let (Some(Status::Changed), Some(o), Some((_, old_tiles))) = (change, old, &old_cards) {
            let before = match card {
                Card::Asset(i) => o.manifest().asset(&assets[*i].id).map(|a| render(o, a, 4)).transpose()?.flatten(),
                Card::Map { .. } if old_tiles.contains_key(card) => picture_of(o, card, old_tiles)?,
                Card::Map { .. } => None,
            };
            if let Some((before, _)) = before {
                let old_file = card.file(assets, "old");
                bytes += before.png(&out.join(&old_file))?;
                images += 1;
                let _ = write!(extra, "<small>old</small><img src=\"{}\" alt=\"old\">", html(&old_file));
                if let Some(d) = before.difference(&picture) {
                    let diff_file = card.file(assets, "diff");
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
        let label = match card {
            Card::Asset(i) => {
                let (asset, info) = (&assets[*i], &summary.assets[*i]);
                let dims = info.dimensions.iter().map(u64::to_string).collect::<Vec<_>>().join("×");
                format!(
                    "<b>{}</b>{}<br><small>{} · {} {} · {:.2} MiB on disk, {:.2} MiB GPU · budget {}</small>",
                    html(&asset.id),
                    status_text(change),
                    html(&info.kind),
                    html(&info.format),
                    html(&dims),
                    info.byte_length as f64 / 1048576.0,
                    info.gpu_bytes as f64 / 1048576.0,
                    html(&budget_of(bundle, &asset.id)),
                )
            }
            Card::Map { part, level } => {
                let disk: u64 = members.iter().map(|&i| summary.assets[i].byte_length).sum();
                let gpu: u64 = members.iter().map(|&i| summary.assets[i].gpu_bytes).sum();
                let first = &summary.assets[members[0]];
                format!(
                    "<b>{} level {level}</b>{}<br><small>{} · {} · {} tiles · {:.2} MiB on disk, {:.2} MiB GPU</small>",
                    html(part),
                    status_text(change),
                    html(&first.kind),
                    html(&first.format),
                    members.len(),
                    disk as f64 / 1048576.0,
                    gpu as f64 / 1048576.0,
                )
            }
        };
        let _ = writeln!(
            page,
            "<div class=\"card{}\">{label}<br><small>{}</small>{}<small>{}</small><img src=\"{}\" alt=\"{}\"></div>",
            if change == Some(Status::Changed) { " changed" } else { "" },
            html(&what),
            extra,
            if extra.is_empty() { "" } else { "new" },
            html(&file),
            html(&file),
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

/// A card's change, as its heading says it.
fn status_text(change: Option<Status>) -> &'static str {
    match change {
        Some(Status::Changed) => " — changed",
        Some(Status::Added) => " — added",
        _ => "",
    }
}
