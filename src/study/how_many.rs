//! How many measured rows a model needs: the predicted σ of its target's position over the
//! workspace as a function of the number of selected rows, each point the same run as
//! `legwise identify --poses-per-leg N` (the rows `legwise select` picks, the model's simulated
//! experiment, the default fit, the covariance carried to the target over the workspace), so
//! that a user sees where more rows stop helping.

use serde::Serialize;

use crate::error::{Error, Result};
use crate::identify::factor_set::{fit_factor_set, model_sets};
use nalgebra::DMatrix;

use crate::evaluate::accuracy::result_parameters;
use crate::evaluate::predicted_pose::predicted_pose_sigma;
use crate::identify::result::{PredictedPosition, StrategyResult};
use crate::measure::simulate::SimulationOptions;
use crate::model::mechanism::SelectionCriterion;
use crate::model::mechanism::Simulation;
use crate::model::Mechanism;
use crate::pipeline::{run, simulate, Settings, SimulationSettings};

/// One count's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CountPoint {
    /// Rows selected.
    pub count: usize,
    /// The predicted σ over the workspace as `legwise identify` reports it (with enough rows a
    /// sandwich of the residuals: it varies with the experiment's noise), or why there is none
    /// (too few rows to determine the unknowns, more rows than the candidate grid holds).
    pub predicted: std::result::Result<PredictedPosition, String>,
    /// The design's: the same rows' predicted σ from the declared noise alone (the model's own
    /// set fitted by [`crate::identify::factor_set::fit_factor_set`]), smooth in the count.
    pub design: Option<PredictedPosition>,
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
/// when `None`); a model without a simulation block is simulated at its nominal values with
/// its declared noise (seed 1).
///
/// # Errors
/// A model whose instrument measures the platform's pose (its predicted σ over the workspace is
/// a forward fit's, or one from measured poses without an instrument).
pub fn predicted_by_count(
    mechanism: &Mechanism,
    counts: &[usize],
    seed: Option<u64>,
) -> Result<Vec<CountPoint>> {
    if mechanism.instrument.is_some() && mechanism.forward_instrument().is_none() {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "instrument.kinematics".into(),
            message: "the predicted σ over the workspace is a forward fit's or one from measured \
                      poses: expected a model seen through the forward kinematics \
                      (`instrument.kinematics: forward`) or without an instrument, found an \
                      instrument that measures the platform's pose"
                .into(),
        });
    }
    // Without a simulation block (an imported printer) the experiment is the nominal model's
    // with the declared noise: the σ a design predicts at the model's values.
    let with_simulation;
    let mechanism = match mechanism.simulation {
        Some(_) => mechanism,
        None => {
            let noise = mechanism.noise.unwrap_or_default();
            with_simulation = mechanism.edited(|parts| {
                parts.simulation = Some(Simulation {
                    real: Default::default(),
                    perturbation: None,
                    pose_noise: noise.pose,
                    reading_noise: noise.reading,
                    poses_per_leg: parts.selection.poses_per_leg,
                    seed: 1,
                });
            });
            &with_simulation
        }
    };
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
            let report = run(mechanism, &settings).map_err(|e| e.to_string());
            let design = report.as_ref().ok().and_then(|report| {
                let own = model_sets(mechanism).into_iter().next()?;
                fit_factor_set(mechanism, &report.measurements, &own)
                    .ok()?
                    .predicted
            });
            let predicted = report.and_then(|report| {
                report
                    .results
                    .iter()
                    .find_map(|r| match &r.instrument {
                        Some(instrument) => instrument.predicted_position.clone(),
                        None => measured_pose_prediction(mechanism, r),
                    })
                    .ok_or_else(|| {
                        "no predicted σ: the rows do not determine every unknown".to_string()
                    })
            });
            CountPoint {
                count,
                predicted,
                design,
            }
        })
        .collect())
}

/// The design's predicted σ over the workspace of `count` rows selected by `criterion` on a
/// candidate grid of spacing `grid` (the model's when `None`): the model's own set fitted on
/// those rows simulated at the nominal model without noise, its σ from the declared noise alone
/// (what `legwise select`'s rows promise; how-many's design column at the model's values).
/// `None` without a declared noise, or when the rows do not determine the set.
pub fn design_sigma(
    mechanism: &Mechanism,
    count: usize,
    criterion: SelectionCriterion,
    grid: Option<f64>,
) -> Option<PredictedPosition> {
    let noise = mechanism.noise?;
    let nominal = mechanism.edited(|parts| {
        parts.selection.criterion = criterion;
        parts.simulation = Some(Simulation {
            real: Default::default(),
            perturbation: None,
            pose_noise: noise.pose,
            reading_noise: noise.reading,
            poses_per_leg: count,
            seed: 1,
        });
    });
    let settings = SimulationSettings {
        options: SimulationOptions {
            noise_scale: 0.0,
            poses_per_leg: Some(count),
            ..SimulationOptions::default()
        },
        grid,
        ..SimulationSettings::default()
    };
    let simulated = simulate(&nominal, &settings).ok()?;
    let own = model_sets(&nominal).into_iter().next()?;
    fit_factor_set(&nominal, &simulated.measurements, &own)
        .ok()?
        .predicted
}

/// A fit from measured poses carried to the end effector's position over the workspace: its
/// legs' covariances (each leg fitted on its own: the blocks of one covariance) at its
/// estimates ([`predicted_pose_sigma`]).
fn measured_pose_prediction(
    mechanism: &Mechanism,
    result: &StrategyResult,
) -> Option<PredictedPosition> {
    let blocks: Vec<&DMatrix<f64>> = mechanism
        .identified_legs()
        .iter()
        .map(|&l| {
            let name = &mechanism.legs[l].name;
            result
                .legs
                .iter()
                .find(|e| &e.leg == name)?
                .covariance
                .as_ref()
        })
        .collect::<Option<_>>()?;
    let n: usize = blocks.iter().map(|b| b.nrows()).sum();
    let mut covariance = DMatrix::zeros(n, n);
    let mut at = 0;
    for block in blocks {
        let k = block.nrows();
        covariance.view_mut((at, at), (k, k)).copy_from(block);
        at += k;
    }
    predicted_pose_sigma(
        mechanism,
        &result_parameters(mechanism, result),
        &covariance,
    )
}
