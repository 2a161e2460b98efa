//! How many measured rows a model needs: the predicted σ of its target's position over the
//! workspace as a function of the number of selected rows, each point the same run as
//! `legwise identify --poses-per-leg N` (the rows `legwise select` picks, the model's simulated
//! experiment, the default fit, the covariance carried to the target over the workspace), so
//! that a user sees where more rows stop helping.

use serde::Serialize;

use crate::error::{Error, Result};
use crate::identify::result::PredictedPosition;
use crate::measure::simulate::SimulationOptions;
use crate::model::Mechanism;
use crate::pipeline::{run, Settings, SimulationSettings};

/// One count's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CountPoint {
    /// Rows selected.
    pub count: usize,
    /// The predicted σ over the workspace, or why there is none (too few rows to determine the
    /// unknowns, more rows than the candidate grid holds).
    pub predicted: std::result::Result<PredictedPosition, String>,
}

/// The default counts around the model's own `n`: n/4, n/2, 3n/4, n, 3n/2, 2n (at least 2,
/// without repeats).
pub fn default_counts(n: usize) -> Vec<usize> {
    let mut counts: Vec<usize> = [n / 4, n / 2, 3 * n / 4, n, 3 * n / 2, 2 * n]
        .into_iter()
        .map(|c| c.max(2))
        .collect();
    counts.dedup();
    counts
}

/// The predicted σ at each of `counts` selected rows, simulated from `seed` (the model's seed
/// when `None`).
///
/// # Errors
/// The model is not seen through the forward kinematics (its predicted σ over the workspace is
/// a forward fit's), or has no simulation block.
pub fn predicted_by_count(
    mechanism: &Mechanism,
    counts: &[usize],
    seed: Option<u64>,
) -> Result<Vec<CountPoint>> {
    if mechanism.forward_instrument().is_none() {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "instrument.kinematics".into(),
            message: "the predicted σ over the workspace is a forward fit's: expected a model \
                      seen through the forward kinematics (`instrument.kinematics: forward`), \
                      found none"
                .into(),
        });
    }
    crate::measure::simulate::setup(mechanism)?;
    Ok(counts
        .iter()
        .map(|&count| {
            let settings = Settings {
                simulation: SimulationSettings {
                    options: SimulationOptions {
                        seed,
                        poses_per_leg: Some(count),
                        ..SimulationOptions::default()
                    },
                    ..SimulationSettings::default()
                },
                ..Settings::default()
            };
            let predicted = run(mechanism, &settings)
                .map_err(|e| e.to_string())
                .and_then(|report| {
                    report
                        .results
                        .iter()
                        .find_map(|r| r.instrument.as_ref()?.predicted_position.clone())
                        .ok_or_else(|| {
                            "no predicted σ: the rows do not determine every unknown".to_string()
                        })
                });
            CountPoint { count, predicted }
        })
        .collect())
}
