//! The job kinds a pipeline can name, and the one interface the runner bakes them through.
//!
//! Every kind is a settings struct (the fields `pipeline.ron` writes inside `Horizon(…)`) that
//! implements [`Baker`]. A kind that reads a heightfield owns a [`HeightSource`] (the input and
//! its world units, declared once in [`source`]) beside its own settings. [`Job`] is only the registry `pipeline.ron` needs: serde picks the
//! variant by name and [`Job::baker`] hands out the trait object. The runner, the hashing,
//! `validate PIPELINE` and the CLI never match on the kind, and the bundle derives an asset's
//! kind from its settings.
//!
//! Adding a kind therefore touches one new module here (its struct and `impl Baker`) and the
//! registry: one variant of [`Job`] and one arm of [`Job::baker`]. If its assets need a new
//! kind of settings in the manifest, that is a variant of [`hikage_bundle::Settings`] too.

pub mod curvature;
pub mod heightfield;
pub mod horizon;
pub mod relief;
pub mod source;
pub mod strands;

use std::path::{Path, PathBuf};

use hikage_bundle::{PayloadData, Settings};
use serde::Deserialize;

use crate::error::BakeError;
use crate::limits::InputLimits;

pub use curvature::CurvatureJob;
pub use heightfield::{HeightFormat, HeightfieldJob, HeightfieldOptions};
pub use horizon::{HorizonJob, HorizonOptions};
pub use relief::{ReliefJob, ReliefOptions, ReliefPreset};
pub use source::HeightSource;
pub use strands::StrandsJob;

/// One job of a pipeline. The variant names the baker; [`Job::baker`] is the only place that
/// lists them.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub enum Job {
    /// Import a heightfield image as a `heightfield` asset.
    Heightfield(HeightfieldJob),
    /// Bake horizon and distance maps (and optionally ambient occlusion) from a heightfield.
    Horizon(HorizonJob),
    /// Per-vertex principal curvatures of an OBJ or glTF mesh with UVs.
    Curvature(CurvatureJob),
    /// Bake relief-mapping depth maps and a max-mip pyramid from a heightfield.
    Relief(ReliefJob),
    /// Bake hair strip meshes (shading and opacity sets) from `.hair` or OBJ polylines.
    Strands(StrandsJob),
}

impl Job {
    /// The job's baker.
    pub fn baker(&self) -> &dyn Baker {
        match self {
            Job::Heightfield(j) => j,
            Job::Horizon(j) => j,
            Job::Curvature(j) => j,
            Job::Relief(j) => j,
            Job::Strands(j) => j,
        }
    }

    /// How the job's payloads are compressed.
    pub fn compression(&self) -> crate::Compression {
        match self {
            Job::Heightfield(j) => j.options.compression,
            Job::Horizon(j) => j.options.compression,
            Job::Curvature(j) => j.compression,
            Job::Relief(j) => j.options.compression,
            Job::Strands(j) => j.options.compression,
        }
    }
}

/// What the runner needs from a job kind.
///
/// Implementations read their inputs relative to [`JobContext::base_dir`], report progress
/// through [`JobContext::progress`], never print, and give the same bytes for the same inputs
/// whatever the rayon pool's size.
pub trait Baker: Sync {
    /// The job's id: its asset's id, or the prefix of its assets' ids.
    fn id(&self) -> &str;

    /// The kind's name, as `pipeline.ron` writes the variant, in lower case. Part of the input
    /// hash.
    fn kind(&self) -> &'static str;

    /// Version of the kind's algorithm; bumping it re-bakes every asset the kind made. Part of
    /// the input hash.
    fn algorithm_version(&self) -> u32;

    /// Every input file, resolved against `base_dir`: their bytes are part of the input hash, and
    /// a build script re-runs when one changes.
    fn inputs(&self, base_dir: &Path) -> Vec<PathBuf>;

    /// Ids of the assets the job makes.
    fn outputs(&self) -> Vec<String>;

    /// The settings in a canonical text form for the input hash (ids and paths left out, so
    /// renaming a job or moving its input does not re-bake it).
    fn canonical_settings(&self) -> String;

    /// Checks the settings without reading any input; the message says what is accepted.
    fn check(&self) -> Result<(), String>;

    /// Opens and decodes every input without baking (the `validate PIPELINE` pre-check).
    fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError>;

    /// Bakes the job's assets, in the order of [`outputs`](Baker::outputs) or any other.
    fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError>;

    /// The parts the job is baked as, each a job of its own for hashing, sharding, caching and
    /// writing; `None` when the job is baked whole. A tiled horizon job is one part per tile, so
    /// that shards share its tiles and each tile is written as soon as it is baked. It may read
    /// its inputs' headers (and an input once through, to hash it); it bakes nothing.
    fn parts(&self, _ctx: &JobContext) -> Result<Option<Vec<Box<dyn Baker>>>, BakeError> {
        Ok(None)
    }

    /// Where a part that is one tile of a map lies ([`TileArea`]); `None` for a job baked whole.
    fn tile_area(&self) -> Option<TileArea> {
        None
    }
}

/// Where one tile of a tiled job lies: its map, its level of detail and its texels in that
/// level (column, row, width, height), for saying what a bake rebaked.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileArea {
    /// The tiled job's id.
    pub map: String,
    /// Level of detail (0: the map as baked; `k`: reduced by `2^k`).
    pub level: u32,
    /// The tile's texels at its level: first column and row, width and height.
    pub rect: (u32, u32, u32, u32),
}

/// A job as the runner bakes it: a pipeline's job, or a part of one ([`Baker::parts`]).
pub enum Unit<'a> {
    /// A job baked whole.
    Job(&'a dyn Baker),
    /// A part of a job.
    Part(Box<dyn Baker>),
}

impl JobContext<'_> {
    /// A setting error of job `job`, naming where the job was written (at the field the
    /// message names first, when the source has it).
    pub fn setting(&self, job: &str, message: impl Into<String>) -> BakeError {
        let message = message.into();
        let place = self.place.and_then(|f| f.place_of(&message));
        BakeError::Setting { path: self.source.to_path_buf(), place, job: job.to_string(), message }
    }
}

impl Unit<'_> {
    /// The unit's baker.
    pub fn baker(&self) -> &dyn Baker {
        match self {
            Unit::Job(j) => *j,
            Unit::Part(p) => p.as_ref(),
        }
    }
}

/// The units `job` is baked as: its parts, or itself.
pub fn units<'a>(job: &'a dyn Baker, ctx: &JobContext) -> Result<Vec<Unit<'a>>, BakeError> {
    Ok(match job.parts(ctx)? {
        Some(parts) => parts.into_iter().map(Unit::Part).collect(),
        None => vec![Unit::Job(job)],
    })
}

/// Checks a job's id, the ids of the assets it makes, and its settings.
pub fn check(baker: &dyn Baker) -> Result<(), String> {
    hikage_bundle::check_asset_id(baker.id())?;
    for id in baker.outputs() {
        hikage_bundle::check_asset_id(&id).map_err(|m| format!("asset {m}"))?;
    }
    baker.check()
}

/// What a job needs from its surroundings while it runs.
pub struct JobContext<'a> {
    /// Where the job was written: the pipeline file, or `<command line>` for a one-shot
    /// command; setting errors name it.
    pub source: &'a Path,
    /// Where the job is written in the source, when known.
    pub place: Option<&'a crate::pipeline::Fields>,
    /// Directory that input paths are relative to.
    pub base_dir: &'a Path,
    /// Limits applied to inputs before they are decoded.
    pub limits: &'a InputLimits,
    /// Reports progress as (done, total) units of work.
    pub progress: &'a (dyn Fn(u64, u64) + Sync),
}

/// One asset produced by a job, ready to be written. Its kind follows from its settings
/// ([`Settings::kind`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BakedAsset {
    /// Asset id.
    pub id: String,
    /// The settings recorded in the manifest.
    pub settings: Settings,
    /// The payload.
    pub payload: PayloadData,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kind name hashed with a job is the variant name `pipeline.ron` writes, so the two
    /// can never drift apart; and a heightfield-reading job's source fields read flat, with its
    /// own settings' defaults where left out and a typo refused at its place.
    #[test]
    fn each_kind_reads_under_its_name_with_its_source_flat() {
        let path = std::path::Path::new("p.ron");
        for variant in ["Heightfield", "Horizon", "Curvature", "Relief", "Strands"] {
            let text = format!("(output: \"b\", jobs: [{variant}(id: \"a\", input: \"x.png\")])");
            let pipeline = crate::Pipeline::parse(&text, path).unwrap();
            assert_eq!(pipeline.jobs[0].baker().kind(), variant.to_lowercase(), "{text}");
        }
        let text = "(output: \"b\", jobs: [Horizon(id: \"t\", directions: 8, input: \"t.r16\", \
                    texel_size: (2, 3), raw_size: (4, 2), ao: true)])";
        let Job::Horizon(job) = &crate::Pipeline::parse(text, path).unwrap().jobs[0] else { panic!("a horizon job") };
        assert_eq!(job.source.input, PathBuf::from("t.r16"));
        assert_eq!((job.source.texel_size, job.source.raw_size), ((2.0, 3.0), Some((4, 2))));
        assert_eq!((job.options.directions, job.options.ao), (8, true));
        assert_eq!(job.options.near_field, HorizonOptions::default().near_field);
        let typo = "(output: \"b\", jobs: [\n  Horizon(id: \"t\", input: \"t.png\",\n  direction: 8)])";
        match crate::Pipeline::parse(typo, path).unwrap_err() {
            BakeError::Pipeline { line, message, .. } => {
                assert!(line == 3 && message.contains("direction"), "{message}")
            }
            e => panic!("{e}"),
        }
        let missing = "(output: \"b\", jobs: [Relief(id: \"r\", theta: 4)])";
        let e = crate::Pipeline::parse(missing, path).unwrap_err().to_string();
        assert!(e.contains("input"), "{e}");
    }
}
