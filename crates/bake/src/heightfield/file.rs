//! A heightfield file opened for reading: the one place that tells formats apart, and reads
//! the whole map or a window of it.
//!
//! A whole read is the read of the window that is the whole map, so every reader shares one
//! path and one set of checks. Raw `.r16`/`.r32` and SRTM `.hgt` grids are read row by row
//! from the window's columns; TIFF strips and tiles are decoded one chunk at a time, only
//! those the window touches. PNG and OpenEXR have no random access: their image is decoded
//! whole and the window cut from it. A window may reach past the map's edges (a tile's halo on
//! a torus): its texels are then read around the torus. Voids take one value for the whole
//! file (its lowest valid sample, which [`HeightFile::void_fill`] finds by reading the file
//! once a chunk at a time), so a window holds exactly the samples the whole map has there.

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

#[cfg(feature = "tiff")]
use super::tiff::{self, TiffFile};
use super::{LoadOptions, Samples, all_void, checked, fill_voids, hgt, is_void, lowest_valid, raw};
use crate::error::BakeError;

/// A heightfield file opened for reading windows.
pub struct HeightFile {
    path: PathBuf,
    width: u32,
    height: u32,
    format: Format,
}

enum Format {
    /// Rows of fixed-size samples with no header: `.r16`/`.r32` (little-endian), `.hgt`
    /// (big-endian i16, voids).
    Rows { bytes: u64, hgt: bool },
    #[cfg(feature = "tiff")]
    Tiff(Box<TiffFile>),
    /// A format without random access, decoded whole (and checked) when opened.
    Whole(Samples),
}

impl HeightFile {
    /// Opens `path` and reads its header (PNG and EXR: the whole image). SRTM tiles and raw
    /// heightmaps are known by their extension (`.hgt`, `.r16`, `.r32`: those formats have no
    /// signature), PNG, OpenEXR and TIFF by their first bytes. Anything but a regular file is
    /// refused before it is read.
    pub fn open(path: &Path, options: &LoadOptions) -> Result<HeightFile, BakeError> {
        hikage_bundle::files::regular_metadata(path).map_err(|e| BakeError::io(path, e))?;
        let (width, height, format) = if hgt::is_hgt(path) {
            let side = hgt::side(path, options)?;
            (side, side, Format::Rows { bytes: 2, hgt: true })
        } else if let Some(bytes) = raw::bytes_per_sample(path) {
            let (w, h) = raw::dimensions(path, options, bytes)?;
            (w, h, Format::Rows { bytes, hgt: false })
        } else {
            let (magic, n) = read_magic(path)?;
            if n < 4 {
                return Err(BakeError::input(
                    path,
                    None,
                    format!("expected a PNG, OpenEXR or TIFF image, found a {n}-byte file"),
                ));
            }
            if is_tiff(&magic) {
                open_tiff(path, options)?
            } else if magic.starts_with(&[0x89, b'P', b'N', b'G']) {
                whole(path, load_png(path, options)?)?
            } else if magic.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
                whole(path, load_exr(path, options)?)?
            } else {
                return Err(BakeError::input(
                    path,
                    Some("byte 0".into()),
                    "expected a PNG, OpenEXR or TIFF signature (or a file named *.hgt, *.r16 or *.r32); other formats \
                     are not read",
                ));
            }
        };
        Ok(HeightFile { path: path.to_path_buf(), width, height, format })
    }

    /// The map's width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// A maker of more readers of the same file when one costs nothing (raw and `.hgt` rows,
    /// read by seeking), so that windows can be read on several threads; `None` for formats
    /// that hold decoder state or a decoded image.
    pub fn readers(&self) -> Option<impl Fn() -> HeightFile + Sync + '_> {
        let Format::Rows { bytes, hgt } = self.format else { return None };
        Some(move || HeightFile {
            path: self.path.clone(),
            width: self.width,
            height: self.height,
            format: Format::Rows { bytes, hgt },
        })
    }

    /// Whether samples are integers normalised to [0, 1], and the channel they come from.
    pub fn channel(&self) -> (bool, String) {
        match &self.format {
            Format::Whole(s) => (s.normalized, s.channel.clone()),
            Format::Rows { hgt: true, .. } => (false, "elevation".into()),
            _ => (false, "height".into()),
        }
    }

    /// The whole map, voids filled, every sample finite.
    pub fn read_all(mut self) -> Result<Samples, BakeError> {
        let (normalized, channel) = self.channel();
        let (width, height) = self.size();
        let values = match self.format {
            Format::Whole(samples) => return Ok(samples),
            _ => {
                let values = self.read_raw((0, 0), (width, height))?;
                match self.no_data() {
                    Some(no_data) => fill_voids(&self.path, values, no_data)?,
                    None => values,
                }
            }
        };
        checked(&self.path, Samples { width, height, values, normalized, channel })
    }

    /// Visits every sample that is not a void, a block at a time, with its column and row:
    /// finite, and whatever `check` asks of it (the message names the pixel). Reads little
    /// more than one chunk of the file at a time, so a grid is checked in little memory.
    pub fn scan(&mut self, check: &dyn Fn(f32) -> Result<(), String>) -> Result<(), BakeError> {
        let no_data = self.no_data();
        let mut first_bad: Option<(u32, u32, String)> = None;
        let mut any_valid = false;
        let (w, h) = self.size();
        self.for_each_block((0, h), (0, w), &|_| true, &mut |Block { origin: (r0, c0), size: (bw, _), values }| {
            if first_bad.is_some() {
                return;
            }
            for (i, &v) in values.iter().enumerate() {
                if no_data.is_some_and(|nd| is_void(v, nd)) {
                    continue;
                }
                any_valid = true;
                let problem =
                    if v.is_finite() { check(v).err() } else { Some(format!("expected a finite height, found {v}")) };
                if let Some(message) = problem {
                    first_bad = Some((c0 + i as u32 % bw, r0 + i as u32 / bw, message));
                    return;
                }
            }
        })?;
        if let Some((x, y, message)) = first_bad {
            return Err(BakeError::input(&self.path, Some(format!("pixel ({x}, {y})")), message));
        }
        match no_data {
            Some(nd) if !any_valid => Err(all_void(&self.path, w as u64 * h as u64, nd)),
            _ => Ok(()),
        }
    }

    /// The value the file's voids take: its lowest valid sample, read a chunk at a time.
    /// `None` when the format marks no voids (or they were already filled on decoding).
    pub fn void_fill(&mut self) -> Result<Option<f32>, BakeError> {
        let Some(no_data) = self.no_data() else { return Ok(None) };
        let mut lowest = f32::INFINITY;
        self.for_each_block((0, self.height), (0, self.width), &|_| true, &mut |block| {
            lowest = lowest_valid(block.values.iter().copied(), no_data, lowest);
        })?;
        if !lowest.is_finite() {
            return Err(all_void(&self.path, self.width as u64 * self.height as u64, no_data));
        }
        Ok(Some(lowest))
    }

    fn no_data(&self) -> Option<f32> {
        match &self.format {
            Format::Rows { hgt: true, .. } => Some(f32::from(hgt::VOID)),
            #[cfg(feature = "tiff")]
            Format::Tiff(f) => f.no_data,
            _ => None,
        }
    }

    /// The `w`×`h` samples from map column `x`, row `y` (either may be negative, and the
    /// window may pass the map's far edges: it is read around the torus), voids replaced by
    /// `fill` (see [`void_fill`](Self::void_fill)). Every sample is checked to be finite.
    pub fn read_window(
        &mut self,
        (x, y): (i64, i64),
        (w, h): (u32, u32),
        fill: Option<f32>,
    ) -> Result<Vec<f32>, BakeError> {
        let mut out = self.read_raw((x, y), (w, h))?;
        if let (Some(nd), Some(f)) = (self.no_data(), fill) {
            out.iter_mut().filter(|v| is_void(**v, nd)).for_each(|v| *v = f);
        }
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            let wrap = |v: i64, n: u32| v.rem_euclid(n as i64);
            let (u, v) =
                (wrap(x + (i % w as usize) as i64, self.width), wrap(y + (i / w as usize) as i64, self.height));
            return Err(BakeError::input(
                &self.path,
                Some(format!("pixel ({u}, {v})")),
                format!("expected a finite height, found {}", out[i]),
            ));
        }
        Ok(out)
    }

    /// The window's samples as stored (voids not filled, nothing checked); a sample no block
    /// gave is NaN.
    fn read_raw(&mut self, (x, y): (i64, i64), (w, h): (u32, u32)) -> Result<Vec<f32>, BakeError> {
        let wrap = |v: i64, n: u32| v.rem_euclid(n as i64) as u32;
        let cols: Vec<u32> = (0..w as i64).map(|i| wrap(x + i, self.width)).collect();
        let rows: Vec<u32> = (0..h as i64).map(|i| wrap(y + i, self.height)).collect();
        let span = |v: &[u32]| (v.iter().copied().min().unwrap_or(0), v.iter().copied().max().map_or(0, |m| m + 1));
        let (row_span, col_span) = (span(&rows), span(&cols));
        let mut wanted = vec![false; self.height as usize];
        rows.iter().for_each(|&r| wanted[r as usize] = true);
        // Window columns by map column, so each block row is scattered in one pass.
        let mut at_col: Vec<Vec<u32>> = vec![Vec::new(); (col_span.1 - col_span.0) as usize];
        for (i, &c) in cols.iter().enumerate() {
            at_col[(c - col_span.0) as usize].push(i as u32);
        }
        let mut at_row: Vec<Vec<u32>> = vec![Vec::new(); (row_span.1 - row_span.0) as usize];
        for (i, &r) in rows.iter().enumerate() {
            at_row[(r - row_span.0) as usize].push(i as u32);
        }
        // Without wrapping, the window's columns are one run of the map's.
        let contiguous = cols.iter().enumerate().all(|(i, &c)| c == col_span.0 + i as u32);
        let mut out = vec![f32::NAN; w as usize * h as usize];
        self.for_each_block(
            row_span,
            col_span,
            &|r| wanted[r as usize],
            &mut |Block { origin: (r0, c0), size: (bw, bh), values }| {
                for br in 0..bh {
                    let r = r0 + br;
                    if r < row_span.0 || r >= row_span.1 {
                        continue;
                    }
                    for &wy in &at_row[(r - row_span.0) as usize] {
                        if contiguous {
                            // Window column i is map column col_span.0 + i: the block's part of
                            // the row is one run.
                            let (lo, hi) = (c0.max(col_span.0), (c0 + bw).min(col_span.1));
                            if lo < hi {
                                let dst = wy as usize * w as usize + (lo - col_span.0) as usize;
                                let src = (br * bw + lo - c0) as usize;
                                out[dst..dst + (hi - lo) as usize]
                                    .copy_from_slice(&values[src..src + (hi - lo) as usize]);
                            }
                            continue;
                        }
                        for bc in 0..bw {
                            let c = c0 + bc;
                            if c < col_span.0 || c >= col_span.1 {
                                continue;
                            }
                            let v = values[(br * bw + bc) as usize];
                            for &wx in &at_col[(c - col_span.0) as usize] {
                                out[wy as usize * w as usize + wx as usize] = v;
                            }
                        }
                    }
                }
            },
        )?;
        Ok(out)
    }

    /// Calls `f` with blocks of the map covering rows
    /// `rows` (those `wanted`) and columns `cols`, each as stored (no void filled).
    fn for_each_block(
        &mut self,
        rows: (u32, u32),
        cols: (u32, u32),
        wanted: &dyn Fn(u32) -> bool,
        f: &mut dyn FnMut(Block),
    ) -> Result<(), BakeError> {
        let path = self.path.as_path();
        match &mut self.format {
            Format::Rows { bytes, hgt } => {
                let mut file = hikage_bundle::files::open_regular(path).map_err(|e| BakeError::io(path, e))?;
                let mut buf = vec![0u8; (cols.1 - cols.0) as usize * *bytes as usize];
                for r in (rows.0..rows.1).filter(|&r| wanted(r)) {
                    let at = (r as u64 * self.width as u64 + cols.0 as u64) * *bytes;
                    file.seek(SeekFrom::Start(at)).map_err(|e| BakeError::io(path, e))?;
                    file.read_exact(&mut buf).map_err(|e| BakeError::io(path, e))?;
                    let values = if *hgt { hgt::decode(&buf) } else { raw::decode(&buf, *bytes) };
                    f(Block { origin: (r, cols.0), size: (cols.1 - cols.0, 1), values: &values });
                }
            }
            #[cfg(feature = "tiff")]
            Format::Tiff(file) => {
                let ((cw, ch), across) = file.chunk_grid();
                for cy in rows.0 / ch..rows.1.div_ceil(ch) {
                    if !(cy * ch..((cy + 1) * ch).min(self.height)).any(wanted) {
                        continue;
                    }
                    for cx in cols.0 / cw..cols.1.div_ceil(cw).min(across) {
                        let (bw, bh, values) = file.read_chunk(path, cy * across + cx)?;
                        f(Block { origin: (cy * ch, cx * cw), size: (bw, bh), values: &values });
                    }
                }
            }
            Format::Whole(s) => f(Block { origin: (0, 0), size: (s.width, s.height), values: &s.values }),
        }
        Ok(())
    }
}

/// Samples of the map as stored, row-major.
struct Block<'a> {
    /// Row and column of the first.
    origin: (u32, u32),
    /// Width and height.
    size: (u32, u32),
    values: &'a [f32],
}

/// Whether `magic` starts a TIFF file (either byte order; BigTIFF too).
fn is_tiff(magic: &[u8]) -> bool {
    [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"].iter().any(|m| magic.starts_with(*m))
}

/// The size and format of a decoded whole image, its samples checked.
fn whole(path: &Path, samples: Samples) -> Result<(u32, u32, Format), BakeError> {
    let samples = checked(path, samples)?;
    Ok((samples.width, samples.height, Format::Whole(samples)))
}

/// The error for a file whose format this build of hikage-bake does not read.
#[cfg_attr(
    all(feature = "png", feature = "exr", feature = "tiff"),
    expect(dead_code, reason = "used only by the builds that leave a format out")
)]
fn not_built(path: &Path, format: &str, feature: &str) -> BakeError {
    BakeError::input(
        path,
        Some("byte 0".into()),
        format!("a {format} file, but this build of hikage-bake reads no {format}: enable its `{feature}` feature"),
    )
}

#[cfg(feature = "tiff")]
fn open_tiff(path: &Path, options: &LoadOptions) -> Result<(u32, u32, Format), BakeError> {
    let file = tiff::open(path, options)?;
    Ok((file.width, file.height, Format::Tiff(Box::new(file))))
}

#[cfg(not(feature = "tiff"))]
fn open_tiff(path: &Path, _: &LoadOptions) -> Result<(u32, u32, Format), BakeError> {
    Err(not_built(path, "TIFF", "tiff"))
}

#[cfg(feature = "png")]
fn load_png(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    super::png::load(path, options)
}

#[cfg(not(feature = "png"))]
fn load_png(path: &Path, _: &LoadOptions) -> Result<Samples, BakeError> {
    Err(not_built(path, "PNG", "png"))
}

#[cfg(feature = "exr")]
fn load_exr(path: &Path, options: &LoadOptions) -> Result<Samples, BakeError> {
    super::exr::load(path, options)
}

#[cfg(not(feature = "exr"))]
fn load_exr(path: &Path, _: &LoadOptions) -> Result<Samples, BakeError> {
    Err(not_built(path, "OpenEXR", "exr"))
}

/// The first eight bytes of `path` and how many there were.
fn read_magic(path: &Path) -> Result<([u8; 8], usize), BakeError> {
    let mut magic = [0u8; 8];
    let mut f = hikage_bundle::files::open_regular(path).map_err(|e| BakeError::io(path, e))?;
    let mut n = 0;
    while n < magic.len() {
        match f.read(&mut magic[n..]).map_err(|e| BakeError::io(path, e))? {
            0 => break,
            k => n += k,
        }
    }
    Ok((magic, n))
}
