//! The `Strands` job: a `.hair` file or OBJ polylines → hair strip meshes (seed 004).

use std::path::{Path, PathBuf};

use hikage_bundle::{Settings, StrandsSettings};
use serde::{Deserialize, Deserializer, Serialize};

use super::source::deserialize_flat;
use super::{BakedAsset, Baker, JobContext};
use crate::error::BakeError;
use crate::strands::strips::{self, StripSets};
use crate::strands::{self, Strands, auto, ribbons};

/// Version of the strands job; part of the input hash.
pub const ALGORITHM_VERSION: u32 = 2;

/// A strands bake. Asset ids: `<id>.strips`, and `<id>.ribbons` with `ribbons`.
///
/// Widths (full, world units) and opacities are those of a strand with the source's default
/// thickness and transparency; each strand's own values scale them. Absent: the shading set is
/// the source's defaults, the opacity set the shading set times the paper's ratios (width
/// × 1.40/0.16, opacity × 0.0165/0.366), unless `auto` chooses it.
///
/// With the `clap` feature it is also the `hikage strands` command line (the id comes from
/// `--id` or the input's file stem).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct StrandsJob {
    /// Prefix of the asset ids.
    #[cfg_attr(feature = "clap", arg(skip))]
    pub id: String,
    /// Cem Yuksel `.hair` file (by its signature) or Wavefront OBJ with `l` polylines.
    pub input: PathBuf,
    /// The job's own settings.
    #[cfg_attr(feature = "clap", command(flatten))]
    pub options: StrandsOptions,
}

/// The `Strands` job's own settings; every default is [`StrandsOptions::default`]'s.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct StrandsOptions {
    /// Shading set width (default: the input's default thickness).
    #[cfg_attr(feature = "clap", arg(long))]
    pub shading_width: Option<f32>,
    /// Shading set opacity (default: 1 − the input's default transparency).
    #[cfg_attr(feature = "clap", arg(long))]
    pub shading_alpha: Option<f32>,
    /// Opacity set width (default: shading width × 1.40/0.16, the paper's ratio).
    #[cfg_attr(feature = "clap", arg(long))]
    pub opacity_width: Option<f32>,
    /// Opacity set opacity (default: shading opacity × 0.0165/0.366).
    #[cfg_attr(feature = "clap", arg(long))]
    pub opacity_alpha: Option<f32>,
    /// Choose the opacity set for an opacity map of N² texels: the width (with width × opacity
    /// kept) whose light-space shadow is nearest the shading set's at 8× the resolution.
    #[cfg_attr(feature = "clap", arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "256"))]
    pub auto: Option<u32>,
    /// Share of the width lost at the tip, 0–1.
    #[cfg_attr(feature = "clap", arg(long, default_value_t = StrandsOptions::default().taper))]
    pub taper: f32,
    /// Also bake a fixed-orientation ribbon mesh (minimum-twist frames).
    #[cfg_attr(feature = "clap", arg(long))]
    pub ribbons: bool,
}

impl<'de> Deserialize<'de> for StrandsJob {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (id, input, options) = deserialize_flat(d, "Strands")?;
        Ok(StrandsJob { id, input, options })
    }
}

impl StrandsJob {
    /// A job with every setting at its default.
    pub fn new(id: &str, input: PathBuf) -> StrandsJob {
        StrandsJob { id: id.into(), input, options: StrandsOptions::default() }
    }

    /// Id of the strip mesh.
    pub fn strips_id(&self) -> String {
        format!("{}.strips", self.id)
    }

    /// Id of the ribbon mesh.
    pub fn ribbons_id(&self) -> String {
        format!("{}.ribbons", self.id)
    }

    /// The sets the job asks for on this source.
    pub fn sets(&self, s: &Strands) -> StripSets {
        let source = StripSets::from_source(s);
        let shading = (
            self.options.shading_width.unwrap_or(source.shading.0),
            self.options.shading_alpha.unwrap_or(source.shading.1),
        );
        let opacity = (
            self.options.opacity_width.unwrap_or(shading.0 * strips::PAPER_WIDTH_RATIO),
            self.options.opacity_alpha.unwrap_or(shading.1 * strips::PAPER_ALPHA_RATIO),
        );
        StripSets { shading, opacity, taper: self.options.taper }
    }
}

impl Baker for StrandsJob {
    fn id(&self) -> &str {
        &self.id
    }

    fn kind(&self) -> &'static str {
        "strands"
    }

    fn algorithm_version(&self) -> u32 {
        ALGORITHM_VERSION
    }

    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        vec![base_dir.join(&self.input)]
    }

    fn outputs(&self) -> Vec<String> {
        let mut out = vec![self.strips_id()];
        if self.options.ribbons {
            out.push(self.ribbons_id());
        }
        out
    }

    fn canonical_settings(&self) -> String {
        format!(
            "shading=({:?},{:?});opacity=({:?},{:?});auto={:?};taper={:?};ribbons={}",
            self.options.shading_width,
            self.options.shading_alpha,
            self.options.opacity_width,
            self.options.opacity_alpha,
            self.options.auto,
            self.options.taper,
            self.options.ribbons
        )
    }

    fn check(&self) -> Result<(), String> {
        for (name, w) in [("shading_width", self.options.shading_width), ("opacity_width", self.options.opacity_width)]
        {
            if let Some(w) = w
                && !(w.is_finite() && w > 0.0)
            {
                return Err(format!("{name} must be finite and above 0, found {w}"));
            }
        }
        for (name, a) in [("shading_alpha", self.options.shading_alpha), ("opacity_alpha", self.options.opacity_alpha)]
        {
            if let Some(a) = a
                && !(a > 0.0 && a <= 1.0)
            {
                return Err(format!("{name} must be in (0, 1], found {a}"));
            }
        }
        if !(0.0..=1.0).contains(&self.options.taper) {
            return Err(format!("taper must be in [0, 1], found {}", self.options.taper));
        }
        if let Some(r) = self.options.auto {
            if !(16..=8192).contains(&r) {
                return Err(format!("auto resolution must be 16–8192, found {r}"));
            }
            if self.options.opacity_width.is_some() || self.options.opacity_alpha.is_some() {
                return Err("auto chooses the opacity set: give either auto or opacity_width/opacity_alpha".into());
            }
        }
        Ok(())
    }

    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        strands::load(&ctx.base_dir.join(&self.input)).map(|_| ())
    }

    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        (ctx.progress)(0, 2);
        let s = strands::load(&ctx.base_dir.join(&self.input))?;
        let mut sets = self.sets(&s);
        if let Some(resolution) = self.options.auto {
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
            auto_resolution: self.options.auto,
            bounds_min: lo,
            bounds_max: hi,
        };
        let mut out = vec![BakedAsset {
            id: self.strips_id(),
            settings: Settings::Strands(settings.clone()),
            payload: mesh.into(),
        }];
        if self.options.ribbons {
            out.push(BakedAsset {
                id: self.ribbons_id(),
                settings: Settings::Generic,
                payload: ribbons::build(&s, &sets).into(),
            });
        }
        (ctx.progress)(2, 2);
        Ok(out)
    }
}
