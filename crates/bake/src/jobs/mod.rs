//! The bakers a pipeline job can name, behind one interface the runner uses.

pub mod curvature;
pub mod heightfield;
pub mod horizon;
pub mod relief;
pub mod strands;

use std::path::{Path, PathBuf};

use hikage_bundle::{AssetKind, MeshData, Settings, TextureData};

use crate::error::BakeError;
use crate::pipeline::{InputLimits, Job};

/// What a job needs from its surroundings while it runs.
pub struct JobContext<'a> {
    /// Directory that input paths are relative to.
    pub base_dir: &'a Path,
    /// Input limits.
    pub limits: &'a InputLimits,
    /// Reports progress as (done, total) units of work.
    pub progress: &'a (dyn Fn(u64, u64) + Sync),
}

/// A payload produced by a job.
#[derive(Clone, Debug, PartialEq)]
pub enum BakedPayload {
    /// A texture.
    Texture(TextureData),
    /// A mesh.
    Mesh(MeshData),
}

/// One asset produced by a job, ready to be written.
#[derive(Clone, Debug, PartialEq)]
pub struct BakedAsset {
    /// Asset id.
    pub id: String,
    /// Asset kind.
    pub kind: AssetKind,
    /// The settings recorded in the manifest.
    pub settings: Settings,
    /// The payload.
    pub payload: BakedPayload,
}

impl Job {
    /// The job's id (its first asset's id).
    pub fn id(&self) -> &str {
        match self {
            Job::Heightfield(j) => &j.id,
            Job::Horizon(j) => &j.id,
            Job::Relief(j) => &j.id,
            Job::Strands(j) => &j.id,
            Job::Curvature(j) => &j.id,
        }
    }

    /// The baker's name as written in the pipeline.
    pub fn kind(&self) -> &'static str {
        match self {
            Job::Heightfield(_) => "heightfield",
            Job::Horizon(_) => "horizon",
            Job::Relief(_) => "relief",
            Job::Strands(_) => "strands",
            Job::Curvature(_) => "curvature",
        }
    }

    /// Version of the baker's algorithm; bumping it re-bakes every asset it made.
    pub fn algorithm_version(&self) -> u32 {
        match self {
            Job::Heightfield(_) => heightfield::ALGORITHM_VERSION,
            Job::Horizon(_) => horizon::ALGORITHM_VERSION,
            Job::Relief(_) => relief::ALGORITHM_VERSION,
            Job::Strands(_) => strands::ALGORITHM_VERSION,
            Job::Curvature(_) => curvature::ALGORITHM_VERSION,
        }
    }

    /// Input files, resolved against `base_dir`.
    pub fn inputs(&self, base_dir: &Path) -> Vec<PathBuf> {
        match self {
            Job::Heightfield(j) => vec![base_dir.join(&j.input)],
            Job::Horizon(j) => vec![base_dir.join(&j.input)],
            Job::Relief(j) => vec![base_dir.join(&j.input)],
            Job::Strands(j) => vec![base_dir.join(&j.input)],
            Job::Curvature(j) => {
                let input = base_dir.join(&j.input);
                let buffers = crate::mesh::gltf::external_files(&input);
                std::iter::once(input).chain(buffers).collect()
            }
        }
    }

    /// Ids of the assets the job makes.
    pub fn outputs(&self) -> Vec<String> {
        match self {
            Job::Heightfield(j) => vec![j.id.clone()],
            Job::Horizon(j) => j.outputs(),
            Job::Relief(j) => j.outputs(),
            Job::Strands(j) => j.outputs(),
            Job::Curvature(j) => vec![j.id.clone()],
        }
    }

    /// Settings in a canonical text form for the input hash (ids and paths excluded).
    pub fn canonical_settings(&self) -> String {
        match self {
            Job::Heightfield(j) => j.canonical_settings(),
            Job::Horizon(j) => j.canonical_settings(),
            Job::Relief(j) => j.canonical_settings(),
            Job::Strands(j) => j.canonical_settings(),
            Job::Curvature(j) => j.canonical_settings(),
        }
    }

    /// Checks the settings without reading any input.
    pub fn check(&self) -> Result<(), String> {
        if !hikage_bundle::is_valid_asset_id(self.id()) {
            return Err(format!(
                "id {:?} is not valid: expected 1–128 of A–Z a–z 0–9 _ - . not starting with .",
                self.id()
            ));
        }
        match self {
            Job::Heightfield(j) => j.check(),
            Job::Horizon(j) => j.check(),
            Job::Relief(j) => j.check(),
            Job::Strands(j) => j.check(),
            Job::Curvature(_) => Ok(()),
        }
    }

    /// Opens and decodes every input without baking (the `validate PIPELINE` pre-check).
    pub fn check_inputs(&self, ctx: &JobContext) -> Result<(), BakeError> {
        match self {
            Job::Heightfield(j) => j.load(ctx).map(|_| ()),
            Job::Horizon(j) => j.check_inputs(ctx),
            Job::Relief(j) => j.check_inputs(ctx),
            Job::Strands(j) => j.check_inputs(ctx),
            Job::Curvature(j) => j.compute(ctx).map(|_| ()),
        }
    }

    /// Bakes the job's assets.
    pub fn bake(&self, ctx: &JobContext) -> Result<Vec<BakedAsset>, BakeError> {
        match self {
            Job::Heightfield(j) => j.bake(ctx),
            Job::Horizon(j) => j.bake(ctx),
            Job::Relief(j) => j.bake(ctx),
            Job::Strands(j) => j.bake(ctx),
            Job::Curvature(j) => j.bake(ctx),
        }
    }

    /// The input hash of this job. The input limits are part of it, so a tightened limit is
    /// applied to inputs that were baked before (the result never depends on the cache).
    pub fn input_hash(&self, base_dir: &Path, limits: &InputLimits) -> Result<String, BakeError> {
        let inputs = self.inputs(base_dir);
        let refs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        let settings = format!("{};max_dimension={}", self.canonical_settings(), limits.max_dimension);
        crate::hash::input_hash(self.kind(), self.algorithm_version(), &settings, &refs)
    }
}
