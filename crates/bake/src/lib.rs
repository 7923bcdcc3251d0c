//! hikage-bake: turns source assets into bundle payloads.
//!
//! - [`heightfield`] imports heightfields — PNG (8/16-bit), OpenEXR (f16/f32), TIFF/GeoTIFF,
//!   SRTM `.hgt` and raw `.r16`/`.r32` — with their world units (texel size, height scale and
//!   offset; see `docs/conventions.md`), whole or a window at a time. PNG, OpenEXR and TIFF are
//!   the `png`, `exr` and `tiff` features (on by default).
//! - [`pipeline`] parses `pipeline.ron`: the output bundle and a list of jobs.
//! - [`run`] runs a pipeline incrementally: a job whose input hash (input bytes, canonical
//!   settings, baker algorithm version) matches the existing asset is skipped, and the bundle
//!   is replaced atomically. [`build::BuildScript`] is what a `build.rs` calls: it bakes into
//!   `OUT_DIR` and tells cargo where the bundle is and what to watch.
//! - [`jobs`] holds the job kinds (`Heightfield`, `Horizon`, `Curvature`, `Relief`, `Strands`)
//!   behind one [`Baker`] interface; [`horizon`], [`relief`], [`strands`] and [`curvature`] are
//!   the algorithms they call, usable on their own.
//! - [`export`] writes assets back out: textures as EXR or raw little-endian f32, meshes as
//!   binary glTF, a bundle as a contact sheet for review ([`export::sheet`]).
//! - [`shard`] splits a pipeline over machines (`--shard K/N`) and merges the parts; [`cache`]
//!   shares baked payloads between checkouts and machines by input hash; [`report`] says what a
//!   run baked and why.
//! - [`compression`] chooses each payload's zstd level; [`mesh`] reads OBJ and glTF meshes;
//!   [`bc4`] encodes relief maps as BC4.
//!
//! The library never prints (except the `cargo::` lines a build script asks for, in
//! [`build`]); progress goes to an [`run::Observer`].
//!
//! ```no_run
//! // build.rs
//! hikage_bake::build::BuildScript::new("assets/pipeline.ron").bake();
//! ```

pub mod bc4;
pub mod build;
pub mod cache;
pub mod compression;
pub mod curvature;
mod error;
pub mod export;
mod hash;
pub mod heightfield;
pub mod horizon;
pub mod jobs;
mod limits;
pub mod mesh;
pub mod pipeline;
pub mod relief;
pub mod report;
pub mod run;
pub mod shard;
pub mod strands;

pub use compression::Compression;
pub use error::BakeError;
pub use heightfield::{Heightfield, LoadOptions};
pub use jobs::{Baker, Job, TileArea};
pub use limits::InputLimits;
pub use pipeline::Pipeline;
pub use report::{Reason, Rebaked};
pub use run::{Observer, RunOptions, RunReport, run_pipeline};
