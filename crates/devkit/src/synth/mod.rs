//! Procedural heightfields: the committed generators behind the sample data in `data/` and the
//! inputs of tests and benchmarks. Every generator is deterministic (integer hashing, no
//! global state) and returns samples in [0, 1], row-major.

mod character;
mod hair;
mod heightfields;
mod meshes;
mod noise;

pub use character::{Character, character, pose};
pub use hair::{carried, combed, curly, hair};
pub use heightfields::{bricks, cylinder_bumps, dune_ripples, fbm_relief, reptile_cells, spikes_and_walls, terrain};
pub use meshes::{cylinder_obj, torus_glb, uv_sphere_obj};
pub use noise::{fbm, hash01, value_noise};
