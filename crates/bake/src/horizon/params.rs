//! The parameters of a horizon bake, apart from the heightfield's own world units.

use hikage_bundle::EdgeMode;

use super::encode::HorizonFormat;

/// Parameters of a horizon bake.
#[derive(Clone, Debug, PartialEq)]
pub struct HorizonParams {
    /// Number of azimuths `D` (1–256); direction `k` has `φ = 2πk/D`.
    pub directions: u32,
    /// Edge behaviour.
    pub edge: EdgeMode,
    /// Largest horizon distance in world units (`None`: see [`EdgeMode`]).
    pub max_distance: Option<f32>,
    /// Texels along each ray traced exactly before the line sweep takes over.
    pub near_field: u32,
    /// Storage format.
    pub format: HorizonFormat,
}

impl Default for HorizonParams {
    fn default() -> Self {
        HorizonParams {
            directions: 32,
            edge: EdgeMode::Wrap,
            max_distance: None,
            near_field: DEFAULT_NEAR_FIELD,
            format: HorizonFormat::Rg16Float,
        }
    }
}

/// Default near field: enough for the accuracy gates on rough terrain (docs/horizon.md, the accuracy against the brute force).
pub const DEFAULT_NEAR_FIELD: u32 = 16;

impl HorizonParams {
    /// Checks ranges; the message says what is accepted.
    pub fn check(&self) -> Result<(), String> {
        if !(1..=256).contains(&self.directions) {
            return Err(format!("directions must be 1 to 256, found {}", self.directions));
        }
        if let Some(d) = self.max_distance
            && !(d.is_finite() && d > 0.0)
        {
            return Err(format!("max_distance must be finite and above 0, found {d}"));
        }
        if self.near_field > 64 {
            return Err(format!("near_field must be 0 to 64 texels, found {}", self.near_field));
        }
        Ok(())
    }
}
