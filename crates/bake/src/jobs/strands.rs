//! The `Strands` job: a `.hair` file or OBJ polylines → hair strip meshes (seed 004).

use std::path::{Path, PathBuf};

use hikage_bundle::{AssetKind, Settings, StrandsSettings};
use serde::{Deserialize, Serialize};

use super::{BakedAsset, BakedPayload, JobContext};
use crate::error::BakeError;
use crate::strands::cyhair::{self, HairLimits};
use crate::strands::strips::{self, StripSets};
use crate::strands::{Strands, auto, obj, ribbons};

/// Version of the strands job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 1;

/// Settings of a strands bake. Asset ids: `<id>.strips`, and `<id>.ribbons` with `ribbons`.
///
/// Widths (full, world units) and opacities are those of a strand with the source's default
/// thickness and transparency; each strand's own values scale them. Absent: the shading set is
/// the source's defaults, the opacity set the shading set times the paper's ratios (width
/// × 1.40/0.16, opacity × 0.0165/0.366), unless `auto` chooses it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrandsJob {
    /// Prefix of the asset ids.
    pub id: String,
    /// Cem Yuksel `.hair` (by its signature) or Wavefront OBJ polylines.
    pub input: PathBuf,
    /// Shading set width.
    #[serde(default)]
    pub shading_width: Option<f32>,
    /// Shading set opacity.
    #[serde(default)]
    pub shading_alpha: Option<f32>,
    /// Opacity set width.
    #[serde(default)]
    pub opacity_width: Option<f32>,
    /// Opacity set opacity.
    #[serde(default)]
    pub opacity_alpha: Option<f32>,
    /// Choose the opacity set for an opacity map of this many texels a side (no holes in the
    /// hair's light-space silhouette, the shading set's optical depth).
    #[serde(default)]
    pub auto: Option<u32>,
    /// Share of the width lost at the tip (0–1).
    #[serde(default)]
    pub taper: f32,
    /// Also bake a fixed-orientation ribbon mesh (minimum-twist frames).
    #[serde(default)]
    pub ribbons: bool,
}

impl StrandsJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> StrandsJob {
        StrandsJob {
            id: id.into(),
            input,
            shading_width: None,
            shading_alpha: None,
            opacity_width: None,
            opacity_alpha: None,
            auto: None,
            taper: 0.0,
            ribbons: false,
        }
    }

    /// Id of the strip mesh.
    pub fn strips_id(&self) -> String {
        format!("{}.strips", self.id)
    }

    /// Id of the ribbon mesh.
    pub fn ribbons_id(&self) -> String {
        format!("{}.ribbons", self.id)
    }

    pub(crate) fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.strips_id()];
        if self.ribbons {
            out.push(self.ribbons_id());
        }
        out
    }

    pub(crate) fn canonical_settings(&self) -> String {
        format!(
            "shading=({:?},{:?});opacity=({:?},{:?});auto={:?};taper={:?};ribbons={}",
            self.shading_width,
            self.shading_alpha,
            self.opacity_width,
            self.opacity_alpha,
            self.auto,
            self.taper,
            self.ribbons
        )
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        for (name, w) in [("shading_width", self.shading_width), ("opacity_width", self.opacity_width)] {
            if let Some(w) = w {
                if !(w.is_finite() && w > 0.0) {
                    return Err(format!("{name} must be finite and above 0, found {w}"));
                }
            }
        }
        for (name, a) in [("shading_alpha", self.shading_alpha), ("opacity_alpha", self.opacity_alpha)] {
            if let Some(a) = a {
                if !(a > 0.0 && a <= 1.0) {
                    return Err(format!("{name} must be in (0, 1], found {a}"));
                }
            }
        }
        if !(0.0..=1.0).contains(&self.taper) {
            return Err(format!("taper must be in [0, 1], found {}", self.taper));
        }
        if let Some(r) = self.auto {
            if !(16..=8192).contains(&r) {
                return Err(format!("auto resolution must be 16–8192, found {r}"));
            }
            if self.opacity_width.is_some() || self.opacity_alpha.is_some() {
                return Err("auto chooses the opacity set: give either auto or opacity_width/opacity_alpha".into());
            }
        }
        Ok(())
    }

    pub(crate) fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        load(&ctx.base_dir.join(&self.input)).map(|_| ())
    }

    /// The sets the job asks for on this source.
    pub fn sets(&self, s: &Strands) -> StripSets {
        let source = StripSets::from_source(s);
        let shading = (self.shading_width.unwrap_or(source.shading.0), self.shading_alpha.unwrap_or(source.shading.1));
        let opacity = (
            self.opacity_width.unwrap_or(shading.0 * strips::PAPER_WIDTH_RATIO),
            self.opacity_alpha.unwrap_or(shading.1 * strips::PAPER_ALPHA_RATIO),
        );
        StripSets { shading, opacity, taper: self.taper }
    }

    pub(crate) fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 2);
        let s = load(&ctx.base_dir.join(&self.input))?;
        let mut sets = self.sets(&s);
        if let Some(resolution) = self.auto {
            sets = auto::choose(&s, &sets, resolution).0;
        }
        (ctx.progress)(1, 2);
        let (mesh, lo, hi) = strips::build(&s, &sets);
        let settings = StrandsSettings {
            strands: s.segments.len() as u32,
            points: s.points.len() as u32,
            shading: sets.shading,
            opacity: sets.opacity,
            taper: sets.taper,
            auto_resolution: self.auto,
            bounds_min: lo,
            bounds_max: hi,
        };
        let mut out = vec![BakedAsset {
            id: self.strips_id(),
            kind: AssetKind::Strands,
            settings: Settings::Strands(settings.clone()),
            payload: BakedPayload::Mesh(mesh),
        }];
        if self.ribbons {
            out.push(BakedAsset {
                id: self.ribbons_id(),
                kind: AssetKind::Mesh,
                settings: Settings::Generic,
                payload: BakedPayload::Mesh(ribbons::build(&s, &sets)),
            });
        }
        (ctx.progress)(2, 2);
        Ok(out)
    }
}

/// Reads strands: a `.hair` file when it starts with `HAIR`/`hair`, OBJ polylines otherwise.
pub fn load(path: &Path) -> Result<Strands, BakeError> {
    let limits = HairLimits::default();
    // The largest file the limits allow: header, segments, and every per-point array.
    let max_bytes = 128 + 2 * limits.max_strands + 32 * limits.max_points;
    let len = std::fs::metadata(path).map_err(|e| BakeError::io(path, e))?.len();
    if len > max_bytes {
        return Err(BakeError::Limit {
            path: path.into(),
            what: "strand file size".into(),
            value: len,
            limit: max_bytes,
        });
    }
    let bytes = std::fs::read(path).map_err(|e| BakeError::io(path, e))?;
    if bytes.starts_with(b"HAIR") || bytes.starts_with(b"hair") {
        return cyhair::decode(&bytes, &limits).map_err(|e| match e.over_limit {
            Some((value, limit)) => {
                BakeError::Limit { path: path.into(), what: format!("{} in the header", e.message), value, limit }
            }
            None => BakeError::input(path, Some(e.place), e.message),
        });
    }
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        BakeError::input(path, Some(format!("byte {}", e.valid_up_to())), "expected a .hair signature or OBJ text")
    })?;
    obj::parse(text, limits.max_points).map_err(|(place, message)| BakeError::input(path, Some(place), message))
}
