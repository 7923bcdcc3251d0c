//! Writing a texture asset back out for other tools: OpenEXR or raw little-endian f32.
//!
//! Raw layout: `[slice][row][col]` f32 values of one channel, or `[slice][row][col][channel]`
//! when no channel is picked; slices are the depth slices of a 3D texture (for horizon maps:
//! directions, so the file is D×H×W, direction-major), the layers of an array, or one slice.
//! EXR: one layer per slice (named `slice0000`, … when there are several), each holding the
//! picked channel or all channels as 32-bit float, named as in the manifest.

use std::path::Path;

use hikage_bundle::{Bundle, TextureData};

use crate::error::BakeError;

/// Output file type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportFormat {
    /// Multi-layer OpenEXR, f32 samples.
    Exr,
    /// Little-endian f32, no header.
    Raw,
}

/// What was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportSummary {
    /// Slices written.
    pub slices: u32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Channel names written.
    pub channels: Vec<String>,
    /// Bytes written.
    pub bytes: u64,
}

/// Finds a channel by manifest name (case-insensitive), by letter (`r g b a`), or by index.
pub fn resolve_channel(names: &[String], wanted: &str) -> Option<usize> {
    let lower = wanted.to_ascii_lowercase();
    names
        .iter()
        .position(|n| n.to_ascii_lowercase() == lower)
        .or_else(|| ["r", "g", "b", "a"].iter().position(|l| *l == lower).filter(|&i| i < names.len()))
        .or_else(|| lower.parse::<usize>().ok().filter(|&i| i < names.len()))
}

/// Exports level 0 of texture asset `id` of `bundle` to `out`, written through a temporary
/// file so a failure never leaves a partial output.
pub fn export_texture(
    bundle: &Bundle,
    id: &str,
    channel: Option<&str>,
    format: ExportFormat,
    out: &Path,
) -> Result<ExportSummary, BakeError> {
    let tex = bundle.read_texture(id)?;
    let asset = bundle.asset(id)?;
    let values = physical_values(asset, &tex);
    let names = &tex.desc.channels;
    let picked: Vec<usize> = match channel {
        Some(c) => vec![resolve_channel(names, c).ok_or_else(|| BakeError::Setting {
            place: None,
            path: bundle.dir().join(hikage_bundle::MANIFEST_FILE),
            job: id.to_string(),
            message: format!("no channel {c:?}; the asset has {}", names.join(", ")),
        })?],
        None => (0..names.len()).collect(),
    };
    let (w, h, _) = tex.desc.level_extent(0);
    let slices = tex.desc.slices();
    let bytes = match format {
        ExportFormat::Raw => raw_bytes(&tex, &values, &picked),
        ExportFormat::Exr => exr_bytes(&tex, &values, &picked, out)?,
    };
    super::write_via_temp(out, &bytes)?;
    Ok(ExportSummary {
        slices,
        width: w,
        height: h,
        channels: picked.iter().map(|&c| names[c].clone()).collect(),
        bytes: bytes.len() as u64,
    })
}

/// Level 0 in physical units, `[slice][row][col][channel]`: stored values, except 8-bit horizon
/// maps, which are decoded to `tan β` and world distance.
fn physical_values(asset: &hikage_bundle::Asset, tex: &TextureData) -> Vec<f32> {
    let mut values = tex.to_f32(0);
    if let hikage_bundle::Settings::Horizon(h) = &asset.settings {
        for pair in values.chunks_exact_mut(2) {
            let (s, d) = h.decode(tex.desc.format, pair[0], pair[1]);
            pair[0] = s;
            pair[1] = d;
        }
    }
    values
}

fn raw_bytes(tex: &TextureData, all: &[f32], picked: &[usize]) -> Vec<u8> {
    let n = tex.desc.format.channels();
    let mut out = Vec::with_capacity(all.len() / n * picked.len() * 4);
    for texel in all.chunks_exact(n) {
        for &c in picked {
            out.extend_from_slice(&texel[c].to_le_bytes());
        }
    }
    out
}

#[cfg(not(feature = "exr"))]
fn exr_bytes(_: &TextureData, _: &[f32], _: &[usize], out: &Path) -> Result<Vec<u8>, BakeError> {
    Err(BakeError::input(
        out,
        None,
        "this build of hikage-bake writes no OpenEXR: enable its `exr` feature, or export --raw",
    ))
}

#[cfg(feature = "exr")]
fn exr_bytes(tex: &TextureData, all: &[f32], picked: &[usize], out: &Path) -> Result<Vec<u8>, BakeError> {
    use exr::prelude::{
        AnyChannel, AnyChannels, Encoding, FlatSamples, Image, ImageAttributes, IntegerBounds, Layer, LayerAttributes,
        SmallVec, Text, WritableImage,
    };
    let (w, h, _) = tex.desc.level_extent(0);
    let slices = tex.desc.slices() as usize;
    let n = tex.desc.format.channels();
    let per_slice = w as usize * h as usize;
    let mut layers = Vec::with_capacity(slices);
    for s in 0..slices {
        let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        for &c in picked {
            let values: Vec<f32> = (0..per_slice).map(|i| all[(s * per_slice + i) * n + c]).collect();
            channels.push(AnyChannel::new(Text::from(tex.desc.channels[c].as_str()), FlatSamples::F32(values)));
        }
        let name = if slices > 1 {
            LayerAttributes::named(format!("slice{s:04}").as_str())
        } else {
            LayerAttributes::default()
        };
        layers.push(Layer::new((w as usize, h as usize), name, Encoding::FAST_LOSSLESS, AnyChannels::sort(channels)));
    }
    let image =
        Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((w as usize, h as usize))), layers);
    let mut cursor = std::io::Cursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut cursor)
        .map_err(|e| BakeError::input(out, None, format!("cannot encode OpenEXR: {e}")))?;
    Ok(cursor.into_inner())
}
