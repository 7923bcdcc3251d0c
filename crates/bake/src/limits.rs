//! Limits applied to input files before anything is decoded or allocated for them.

use serde::{Deserialize, Serialize};

/// The `limits:` section of `pipeline.ron`. Part of every job's input hash, so a tightened limit
/// is applied to inputs baked before it (the result never depends on the cache).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputLimits {
    /// Largest image width or height, 1 to [`InputLimits::MAX_DIMENSION`].
    #[serde(default = "default_max_dimension")]
    pub max_dimension: u32,
}

fn default_max_dimension() -> u32 {
    16_384
}

impl InputLimits {
    /// The largest `max_dimension` a pipeline may set: 65536² samples of f32 are 16 GiB, and
    /// the readers size their buffers from it.
    pub const MAX_DIMENSION: u32 = 65_536;
}

impl Default for InputLimits {
    fn default() -> Self {
        InputLimits { max_dimension: default_max_dimension() }
    }
}
