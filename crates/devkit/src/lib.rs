//! hikage-devkit: what tests, benchmarks, fuzz targets and `make_data` share, kept out of the
//! libraries a build script or a game links (`publish = false`).
//!
//! - [`synth`]: the procedural generators behind the sample data in `data/` and the inputs of
//!   tests and benchmarks (tileable bump maps, rough terrain, the relief families, hair, meshes).
//! - [`brute_force`]: the independent reference the horizon baker is measured against.
//! - [`fuzzing`]: one entry point per reader of untrusted input, for `fuzz/` and the test that
//!   replays its regressions.
//! - [`tile_tables`]: manifests of maps baked in tiles at sizes no test bakes.
//! - [`alembic`]: a small Alembic writer, for what no tool here writes (Unreal's groom
//!   attributes, indexed values) and for a groom large enough to measure.
//!
//! `cargo run --release -p hikage-devkit --example make_data` rebuilds `data/` byte for byte.

pub mod alembic;
pub mod brute_force;
pub mod fuzzing;
pub mod synth;
pub mod tile_tables;
