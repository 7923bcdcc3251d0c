//! End-to-end tests: the `hikage` binary on real files, then the runtime on what it baked.

mod util;

mod bad_input;
mod bake;
mod build_reuse;
mod build_script;
mod cache;
mod concurrency;
mod corpus;
mod data;
mod diff;
mod gpu;
mod gpu_bc;
mod gpu_fit;
mod gpu_hair;
mod gpu_horizon;
mod gpu_relief;
mod gpu_skin;
mod gpu_stream;
mod gpu_sun_field;
mod hostile;
mod raised;
mod shard;
mod sheet;
mod tiles;
