//! The factor-set choice checked on simulated experiments of any model (`legwise sets --trials
//! N`): each trial simulates the model's experiment with its own noise draws (the model's
//! `simulation` block: its real values, its poses), fits every set of the model
//! ([`model_sets`]), and judges each determined set by the truth: the RMS over a map of the
//! workspace of the position error the real mechanism makes when the fitted set's model
//! commands it (in the frame the observations define for a model seen through the forward
//! kinematics), and each factor's error over its σ. The set the rows alone recommend
//! ([`recommended`]) is then compared with the best in hindsight.
//!
//! Trials run in parallel (rayon); trial `i` draws from the seed [`trial_seed`]`(seed, i)`, so a
//! seed gives the same figures whatever the number of threads.

use rayon::prelude::*;

use super::montecarlo::trial_seed;
use super::set_outcomes::{choice_summary, ChoiceSummary, SetOutcome};
use crate::error::{Error, Result};
use crate::evaluate::accuracy::{map_grid, position_error, reached_poses};
use crate::evaluate::observed_frame::observed_frame_error;
use crate::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::simulate::SimulationOptions;
use crate::model::with_values::with_values;
use crate::model::Mechanism;
use crate::pipeline::{simulate, PoseSource, SimulationSettings};
use crate::report::RealValues;

/// Spacing of the map the true error is taken over, m.
pub const MAP_GRID: f64 = 0.05;

/// Fraction of the workspace region the map covers.
pub const MAP_SCALE: f64 = 0.95;

/// One trial: its seed and every set's outcome, or why it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct SetTrial {
    /// Its index.
    pub index: usize,
    /// Its seed.
    pub seed: u64,
    /// Every set of the model (its own first), or the reason the trial failed.
    pub outcome: std::result::Result<Vec<SetOutcome>, String>,
}

/// The study's result.
#[derive(Debug, Clone, PartialEq)]
pub struct SetStudyResult {
    /// Study seed.
    pub seed: u64,
    /// Points of the map the true errors are taken over.
    pub map_points: usize,
    /// Every trial, in index order.
    pub trials: Vec<SetTrial>,
}

impl SetStudyResult {
    /// How the recommendation did over the trials that succeeded (`None` if none did).
    pub fn choice(&self) -> Option<ChoiceSummary> {
        let trials: Vec<&[SetOutcome]> = self
            .trials
            .iter()
            .filter_map(|t| t.outcome.as_ref().ok())
            .map(Vec::as_slice)
            .collect();
        choice_summary(&trials)
    }
}

/// Runs `trials` simulated experiments of `mechanism` from `seed`.
///
/// # Errors
/// No simulation block, an empty map; a trial's own failure is its outcome.
pub fn set_study(mechanism: &Mechanism, trials: usize, seed: u64) -> Result<SetStudyResult> {
    crate::measure::simulate::setup(mechanism)?;
    if trials == 0 {
        return Err(Error::Invalid("a study of the sets needs trials".into()));
    }
    let map = map_grid(mechanism, MAP_GRID, MAP_SCALE)?;
    let trials = (0..trials)
        .into_par_iter()
        .map(|index| {
            let seed = trial_seed(seed, index);
            SetTrial {
                index,
                seed,
                outcome: trial(mechanism, seed, &map).map_err(|e| e.to_string()),
            }
        })
        .collect();
    Ok(SetStudyResult {
        seed,
        map_points: map.len(),
        trials,
    })
}

/// One trial: the experiment simulated from `seed`, every set fitted and judged over `map`.
fn trial(mechanism: &Mechanism, seed: u64, map: &[[f64; 6]]) -> Result<Vec<SetOutcome>> {
    let settings = SimulationSettings {
        options: SimulationOptions {
            seed: Some(seed),
            ..Default::default()
        },
        poses: PoseSource::Selected,
        grid: None,
    };
    let simulated = simulate(mechanism, &settings)?;
    let real = &simulated.real;
    let truth = real_by_name(mechanism, real);
    let kinematics = ForwardKinematics::new(mechanism, &real.legs);
    model_sets(mechanism)
        .iter()
        .map(|set| {
            let fit = fit_factor_set(mechanism, &simulated.measurements, set)?;
            SetOutcome::of(
                &fit,
                |fit| true_error(mechanism, fit, (&kinematics, real), map),
                |name| truth.iter().find(|(n, _)| n == name).map(|(_, v)| *v),
            )
        })
        .collect()
}

/// Every parameter's real value by name (the legs', then the instrument's).
fn real_by_name(mechanism: &Mechanism, real: &RealValues) -> Vec<(String, f64)> {
    let legs = mechanism
        .legs
        .iter()
        .zip(&real.legs)
        .flat_map(|(leg, values)| {
            leg.params
                .iter()
                .zip(values)
                .map(|(p, v)| (p.name.clone(), *v))
        });
    let shared = mechanism
        .instrument
        .iter()
        .zip(&real.instrument)
        .flat_map(|(i, values)| {
            i.parameters
                .iter()
                .zip(values)
                .map(|(p, v)| (p.name.clone(), *v))
        });
    legs.chain(shared).collect()
}

/// The RMS position error over `map` of the real mechanism (`kinematics`, `real`) commanded by
/// the model at the set's estimates; for a model seen through the forward kinematics, in the
/// frame its observations define.
fn true_error(
    mechanism: &Mechanism,
    fit: &FactorSetFit,
    (kinematics, real): (&ForwardKinematics<'_>, &RealValues),
    map: &[[f64; 6]],
) -> Result<f64> {
    let values: Vec<(String, f64)> = fit
        .factors
        .iter()
        .map(|f| (f.name.clone(), f.estimate))
        .collect();
    let fitted = with_values(mechanism, &values)?;
    let reached = reached_poses(mechanism, &fitted.nominal_parameters(), kinematics, map);
    let unreached = || {
        Error::Invalid(format!(
            "set `{}`: the real mechanism reaches none of the {} map points",
            fit.name,
            map.len()
        ))
    };
    if let (Some(instrument), Some(real_shared)) =
        (fitted.forward_instrument(), real.instrument.as_deref())
    {
        let commanding = instrument.nominal();
        return observed_frame_error(instrument, (&commanding, real_shared), map, &reached)
            .map(|e| e.position_error.rms)
            .ok_or_else(unreached);
    }
    let errors: Vec<f64> = map
        .iter()
        .zip(&reached)
        .filter_map(|(target, reached)| reached.map(|r| position_error(&r, target)))
        .collect();
    if errors.is_empty() {
        return Err(unreached());
    }
    Ok((errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt())
}
