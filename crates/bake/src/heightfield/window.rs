//! Heightfield files read a window at a time: what a tiled bake reads, so that its memory is
//! bounded by the window and not by the map.
//!
//! Raw `.r16`/`.r32` and SRTM `.hgt` grids are read row by row from the window's columns;
//! TIFF strips and tiles are decoded one chunk at a time, only those the window touches. PNG
//! and OpenEXR have no random access: their image is decoded whole and the window cut from it.
//! A window may reach past the map's edges (a tile's halo on a torus): its texels are then read
//! around the torus. The samples are exactly those [`super::load_samples`] gives for the same
//! texels, voids filled with the same value (the lowest valid sample of the whole file, which
//! [`HeightSource::void_fill`] finds by reading the file once a chunk at a time).

use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::tiff::TiffFile;
use super::{LoadOptions, Samples, hgt, load_samples, raw, tiff};
use crate::error::BakeError;

/// A heightfield file opened for reading windows.
pub struct HeightSource {
    path: PathBuf,
    width: u32,
    height: u32,
    format: Format,
}

enum Format {
    /// Rows of fixed-size samples with no header: `.r16`/`.r32` (little-endian), `.hgt`
    /// (big-endian i16, voids).
    Rows {
        bytes: u64,
        hgt: bool,
    },
    Tiff(Box<TiffFile>),
    /// A format without random access, decoded whole.
    Whole(Samples),
}

impl HeightSource {
    /// Opens `path` and reads its header (PNG and EXR: the whole image).
    pub fn open(path: &Path, options: &LoadOptions) -> Result<HeightSource, BakeError> {
        let (width, height, format) = if hgt::is_hgt(path) {
            let side = hgt::side(path, options)?;
            (side, side, Format::Rows { bytes: 2, hgt: true })
        } else if let Some(bytes) = raw::bytes_per_sample(path) {
            let (w, h) = raw::dimensions(path, options, bytes)?;
            (w, h, Format::Rows { bytes, hgt: false })
        } else if is_tiff(path)? {
            let file = tiff::open(path, options)?;
            (file.width, file.height, Format::Tiff(Box::new(file)))
        } else {
            let samples = load_samples(path, options)?;
            (samples.width, samples.height, Format::Whole(samples))
        };
        Ok(HeightSource { path: path.to_path_buf(), width, height, format })
    }

    /// The map's width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Whether samples are integers normalised to [0, 1], and the channel they come from.
    pub fn channel(&self) -> (bool, String) {
        match &self.format {
            Format::Whole(s) => (s.normalized, s.channel.clone()),
            Format::Rows { hgt: true, .. } => (false, "elevation".into()),
            _ => (false, "height".into()),
        }
    }

    /// The value the file's voids take: its lowest valid sample, read a chunk at a time.
    /// `None` when the format marks no voids (or they were already filled on decoding).
    pub fn void_fill(&mut self) -> Result<Option<f32>, BakeError> {
        let Some(no_data) = self.no_data() else { return Ok(None) };
        let mut lowest = f32::INFINITY;
        self.for_each_block((0, self.height), (0, self.width), &|_| true, &mut |block| {
            lowest = block.values.iter().copied().filter(|&v| v != no_data && v.is_finite()).fold(lowest, f32::min);
        })?;
        if !lowest.is_finite() {
            let count = self.width as u64 * self.height as u64;
            return Err(BakeError::input(
                &self.path,
                None,
                format!("every one of the {count} samples is no-data ({no_data})"),
            ));
        }
        Ok(Some(lowest))
    }

    fn no_data(&self) -> Option<f32> {
        match &self.format {
            Format::Rows { hgt: true, .. } => Some(f32::from(hgt::VOID)),
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
        let mut out = vec![f32::NAN; w as usize * h as usize];
        let no_data = self.no_data();
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
                        for bc in 0..bw {
                            let c = c0 + bc;
                            if c < col_span.0 || c >= col_span.1 {
                                continue;
                            }
                            let v = values[(br * bw + bc) as usize];
                            let v = match (no_data, fill) {
                                (Some(nd), Some(f)) if v == nd => f,
                                _ => v,
                            };
                            for &wx in &at_col[(c - col_span.0) as usize] {
                                out[wy as usize * w as usize + wx as usize] = v;
                            }
                        }
                    }
                }
            },
        )?;
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            let (u, v) = (cols[i % w as usize], rows[i / w as usize]);
            return Err(BakeError::input(
                &self.path,
                Some(format!("pixel ({u}, {v})")),
                format!("expected a finite height, found {}", out[i]),
            ));
        }
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
                let mut file = std::fs::File::open(path).map_err(|e| BakeError::io(path, e))?;
                let mut buf = vec![0u8; (cols.1 - cols.0) as usize * *bytes as usize];
                for r in (rows.0..rows.1).filter(|&r| wanted(r)) {
                    let at = (r as u64 * self.width as u64 + cols.0 as u64) * *bytes;
                    file.seek(SeekFrom::Start(at)).map_err(|e| BakeError::io(path, e))?;
                    file.read_exact(&mut buf).map_err(|e| BakeError::io(path, e))?;
                    let values = if *hgt { hgt::decode(&buf) } else { raw::decode(&buf, *bytes) };
                    f(Block { origin: (r, cols.0), size: (cols.1 - cols.0, 1), values: &values });
                }
            }
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

/// Whether `path` starts with a TIFF signature.
fn is_tiff(path: &Path) -> Result<bool, BakeError> {
    let mut magic = [0u8; 4];
    let mut f = std::fs::File::open(path).map_err(|e| BakeError::io(path, e))?;
    let n = f.read(&mut magic).map_err(|e| BakeError::io(path, e))?;
    Ok(n == 4 && tiff::is_tiff(&magic))
}
