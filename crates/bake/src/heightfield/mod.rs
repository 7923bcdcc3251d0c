//! Heightfields: import from PNG, OpenEXR, TIFF/GeoTIFF, SRTM `.hgt` and raw `.r16`/`.r32`, and
//! their world units (`docs/conventions.md`).
//!
//! A heightfield is a grid of samples, row-major with row 0 first (`u` = column, `v` = row).
//! Integer images are normalised to [0, 1] (8-bit by 255, 16-bit by 65535); float images,
//! elevation grids (TIFF, `.hgt`, metres) and raw heightmaps are taken as they are. World height is `height_offset + height_scale × sample`, and a texel spans
//! `texel_size = (sx, sy)` world units along `u` and `v`.
//!
//! Channel rule: a grayscale PNG gives its luma (alpha, if any, is ignored). A colour PNG is an
//! error unless a channel (`R`, `G`, `B`) is named. An EXR gives the named channel, else `Y`,
//! else `R`, else its only channel; with several channels and none of those, it is an error
//! listing them. Only the first layer of a multi-layer EXR is read.

#[cfg(feature = "exr")]
mod exr;
mod file;
mod hgt;
#[cfg(feature = "png")]
mod png;
mod raw;
#[cfg(feature = "tiff")]
mod tiff;

use std::path::Path;

use hikage_bundle::{Supercompression, TextureData, TextureDesc, TextureDimension, TextureFormat};

use crate::error::BakeError;

pub use file::HeightFile;

/// Options for loading a heightfield image.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Channel to take (`R`, `G`, `B`, `A`, `Y` or any EXR channel name); `None` applies the
    /// module's channel rule.
    pub channel: Option<String>,
    /// Largest width or height accepted; checked from the file header before decoding.
    pub max_dimension: u32,
    /// Width and height of a raw `.r16`/`.r32` heightmap (it has no header); `None` takes a
    /// square map's side from the file's length.
    pub raw_size: Option<(u32, u32)>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions { channel: None, max_dimension: 16_384, raw_size: None }
    }
}

/// A heightfield in memory with its world units.
#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    /// Samples along `u`.
    pub width: u32,
    /// Samples along `v`.
    pub height: u32,
    /// Row-major samples (row 0 first); normalised to [0, 1] when `normalized`.
    pub samples: Vec<f32>,
    /// World units per texel along `u` and `v`.
    pub texel_size: (f32, f32),
    /// World height = `height_offset + height_scale × sample`.
    pub height_scale: f32,
    /// See `height_scale`.
    pub height_offset: f32,
    /// True when the samples came from integers normalised to [0, 1].
    pub normalized: bool,
    /// The channel the samples came from.
    pub source_channel: String,
}

impl Heightfield {
    /// A heightfield from raw samples with unit texels, scale 1 and offset 0.
    pub fn from_samples(width: u32, height: u32, samples: Vec<f32>) -> Heightfield {
        assert_eq!(samples.len(), width as usize * height as usize, "sample count must be width × height");
        Heightfield {
            width,
            height,
            samples,
            texel_size: (1.0, 1.0),
            height_scale: 1.0,
            height_offset: 0.0,
            normalized: false,
            source_channel: "generated".into(),
        }
    }

    /// The sample at column `x`, row `y`.
    pub fn sample(&self, x: u32, y: u32) -> f32 {
        self.samples[y as usize * self.width as usize + x as usize]
    }

    /// World height at column `x`, row `y`.
    pub fn world_height(&self, x: u32, y: u32) -> f32 {
        hikage_bundle::world_height(self.height_offset, self.height_scale, self.sample(x, y))
    }

    /// The samples as a one-level 2D texture in `format` (R32Float or R16Float), channel
    /// `height`.
    pub fn to_texture(&self, format: TextureFormat) -> Result<TextureData, hikage_bundle::BundleError> {
        let desc = TextureDesc {
            format,
            dimension: TextureDimension::D2,
            width: self.width,
            height: self.height,
            depth: 1,
            layers: 1,
            levels: 1,
            supercompression: Supercompression::None,
            channels: vec!["height".into()],
        };
        TextureData::from_f32(desc, &self.samples)
    }
}

/// Samples read from an image, before world units are attached.
#[derive(Clone, Debug, PartialEq)]
pub struct Samples {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Row-major values.
    pub values: Vec<f32>,
    /// True when integers were normalised to [0, 1].
    pub normalized: bool,
    /// The channel taken.
    pub channel: String,
}

/// Loads the whole map from any supported file (see [`HeightFile::open`] for how the format
/// is chosen): a read of the window that is the whole map, voids filled, every sample checked
/// to be finite.
pub fn load_samples(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    HeightFile::open(path, options)?.read_all()
}

/// `samples` when they are exactly `width × height` and all finite; otherwise an error naming
/// the file and the first sample that is not.
pub(crate) fn checked(path: &Path, samples: Samples) -> Result<Samples, BakeError> {
    let expected = samples.width as usize * samples.height as usize;
    if samples.values.len() != expected {
        return Err(BakeError::input(
            path,
            None,
            format!(
                "expected {}×{} = {expected} samples, decoded {}",
                samples.width,
                samples.height,
                samples.values.len()
            ),
        ));
    }
    if let Some(i) = samples.values.iter().position(|v| !v.is_finite()) {
        let (x, y) = (i % samples.width as usize, i / samples.width as usize);
        return Err(BakeError::input(
            path,
            Some(format!("pixel ({x}, {y}) channel {}", samples.channel)),
            format!("expected a finite height, found {}", samples.values[i]),
        ));
    }
    Ok(samples)
}

/// Whether `v` is a void of a grid whose no-data value is `no_data` (GDAL's `nan` matches
/// every NaN).
pub(crate) fn is_void(v: f32, no_data: f32) -> bool {
    v == no_data || (no_data.is_nan() && v.is_nan())
}

/// The no-data rule of every elevation format: samples equal to `no_data` take the lowest
/// other sample, so a void never casts a shadow it has no terrain for. A grid of voids only is
/// an error naming the file.
pub(crate) fn fill_voids(path: &Path, mut values: Vec<f32>, no_data: f32) -> Result<Vec<f32>, BakeError> {
    let lowest = lowest_valid(values.iter().copied(), no_data, f32::INFINITY);
    if !lowest.is_finite() {
        return Err(all_void(path, values.len() as u64, no_data));
    }
    values.iter_mut().filter(|v| is_void(**v, no_data)).for_each(|v| *v = lowest);
    Ok(values)
}

/// The lowest finite sample of `values` that is not a void, starting from `lowest`.
pub(crate) fn lowest_valid(values: impl Iterator<Item = f32>, no_data: f32, lowest: f32) -> f32 {
    values.filter(|&v| !is_void(v, no_data) && v.is_finite()).fold(lowest, f32::min)
}

/// The error for a grid with no valid sample.
pub(crate) fn all_void(path: &Path, count: u64, no_data: f32) -> BakeError {
    BakeError::input(path, None, format!("every one of the {count} samples is no-data ({no_data})"))
}

/// The side of a square grid of `bytes`-byte samples filling `len` bytes, if it is one.
pub(crate) fn square_side(len: u64, bytes: u64) -> Option<u64> {
    let side = (len / bytes).isqrt();
    (side >= 1 && side * side * bytes == len).then_some(side)
}

/// Refuses zero or over-limit dimensions; called with the header's size before decoding.
pub(crate) fn check_dimensions(path: &Path, width: u64, height: u64, max: u32) -> Result<(), BakeError> {
    if width == 0 || height == 0 {
        return Err(BakeError::input(
            path,
            Some("header".into()),
            format!("expected a non-empty image, found {width}×{height}"),
        ));
    }
    let largest = width.max(height);
    if largest > max as u64 {
        return Err(BakeError::Limit {
            path: path.to_path_buf(),
            what: format!("image dimension ({width}×{height})"),
            value: largest,
            limit: max as u64,
        });
    }
    Ok(())
}
