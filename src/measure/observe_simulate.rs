//! Seeded simulation of an experiment measured through the instrument: the legs' readings as
//! [`super::simulate`] makes them (the same real leg parameters and true poses for the same
//! seed), then the instrument's report of its targets at each true pose with the real frame and
//! offsets, plus Gaussian noise on every target coordinate (the model's noise of the coordinate
//! of the same name: `x`, `y`, `yaw`).
//!
//! The real shared parameters are `simulation.real` by name, else (identified ones) a seeded
//! perturbation with the instrument's own sizes, else nominal.

use std::borrow::Cow;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::observations::{instrument_of, DistanceRow, Observations, ObservedRow};
use super::simulate::{gaussian, setup, simulate, SimulatedExperiment, SimulationOptions};
use super::targets::{observe, target_position};
use super::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::instrument::Instrument;
use crate::model::mechanism::Simulation;
use crate::model::Mechanism;
use rand::Rng;

/// A simulated experiment measured through the instrument.
#[derive(Debug, Clone)]
pub struct ObservedExperiment {
    /// Real parameter values per leg (all parameters, in model order).
    pub real: Vec<Vec<f64>>,
    /// Real shared parameters (all of them, in the instrument's order).
    pub real_shared: Vec<f64>,
    /// The true platform poses with the noisy readings (the same rows, in the same order).
    pub poses: MeasurementSet,
    /// What the instrument reports, with the noisy readings.
    pub observations: Observations,
}

/// The real shared parameters: `simulation.real`, else a seeded perturbation of identified
/// ones, else nominal.
pub fn real_shared(instrument: &Instrument, simulation: &Simulation, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0051_a7ed_f7a3);
    instrument
        .parameters
        .iter()
        .map(|p| match simulation.real.get(&p.name) {
            Some(&value) => value,
            None if p.identified => p.nominal + p.perturbation * gaussian(&mut rng),
            None => p.nominal,
        })
        .collect()
}

/// `mechanism` with its simulation's noise on the pose coordinates removed: simulating it gives
/// the true poses (and the noisy readings) that [`observed_from`] turns into target
/// measurements.
pub fn without_pose_noise(mechanism: &Mechanism) -> Mechanism {
    mechanism.edited(|parts| {
        if let Some(s) = parts.simulation.as_mut() {
            s.pose_noise = [0.0; 6];
        }
    })
}

/// The mechanism whose simulation gives the poses `mechanism` measures: through an instrument
/// [`without_pose_noise`] (the poses are exact; the instrument's noise comes on the targets'
/// coordinates), else `mechanism` itself.
pub fn simulated_poses(mechanism: &Mechanism) -> Cow<'_, Mechanism> {
    match mechanism.instrument {
        Some(_) => Cow::Owned(without_pose_noise(mechanism)),
        None => Cow::Borrowed(mechanism),
    }
}

/// Simulates the model's experiment through its instrument at random poses.
///
/// # Errors
/// No simulation or instrument block, or no reachable pose (as [`simulate`]).
pub fn simulate_observed(
    mechanism: &Mechanism,
    options: SimulationOptions,
) -> Result<ObservedExperiment> {
    instrument_of(mechanism)?;
    let experiment = simulate(&without_pose_noise(mechanism), options)?;
    observed_from(mechanism, experiment, options)
}

/// The instrument's report of a simulated experiment `experiment` whose poses are the true
/// ones (simulated by [`without_pose_noise`] of `mechanism`, with the same `options`).
///
/// # Errors
/// No simulation or instrument block.
pub fn observed_from(
    mechanism: &Mechanism,
    experiment: SimulatedExperiment,
    options: SimulationOptions,
) -> Result<ObservedExperiment> {
    let instrument = instrument_of(mechanism)?;
    let simulation = setup(mechanism)?;
    let seed = options.seed.unwrap_or(simulation.seed);
    let shared = real_shared(instrument, simulation, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x7a26_e75e_ed00);
    let sigma: Vec<f64> = instrument
        .targets
        .iter()
        .flat_map(|t| t.pose_indices())
        .map(|&c| options.noise_scale * simulation.pose_noise[c])
        .collect();
    let forward = instrument.forward;
    // A forward experiment's last rows are those of a measured pose (`instrument.poses`):
    // their pose measured with its own noise (its own random stream), no target coordinates.
    let total = experiment.measurements.poses().len();
    let measured = instrument.poses.as_ref().filter(|_| forward);
    let seen_rows = total - measured.map_or(0, |p| p.simulate.min(total));
    let mut pose_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0b5e_7ed0_9053);
    let rows: Vec<ObservedRow> = experiment
        .measurements
        .rows()
        .enumerate()
        .map(|(i, (pose, readings))| {
            let (observed, measured_pose) = match (i < seen_rows, measured) {
                (false, Some(poses)) => {
                    let noisy = std::array::from_fn(|c| {
                        let sigma = options.noise_scale * poses.noise[c];
                        pose.pose[c] + sigma * gaussian(&mut pose_rng)
                    });
                    (Vec::new(), Some(noisy))
                }
                _ => {
                    let observed = observe(instrument, &shared, &pose.pose)
                        .iter()
                        .zip(&sigma)
                        .map(|(v, s)| v + s * gaussian(&mut rng))
                        .collect();
                    (observed, None)
                }
            };
            ObservedRow {
                line: pose.line,
                leg: pose.leg,
                observed,
                readings: readings.to_vec(),
                id: forward.then(|| format!("t{}", i + 1)),
                pose: measured_pose,
            }
        })
        .collect();
    let poses: Vec<[f64; 6]> = experiment
        .measurements
        .poses()
        .iter()
        .take(seen_rows)
        .map(|p| p.pose)
        .collect();
    let distances = simulated_distances(mechanism, &shared, &poses, options, &mut rng)?;
    Ok(ObservedExperiment {
        real: experiment.real,
        real_shared: shared,
        poses: experiment.measurements,
        observations: Observations {
            source: None,
            rows,
            distances,
        },
    })
}

/// The model's simulated distances (`instrument.distances.simulate` of them, noise times the
/// scale): between distinct random pairs of rows, the real distance between the target's
/// positions at their true poses `poses`, plus Gaussian noise.
///
/// # Errors
/// More distances asked for than there are distinct pairs of rows (they were silently fewer).
fn simulated_distances(
    mechanism: &Mechanism,
    shared: &[f64],
    poses: &[[f64; 6]],
    options: SimulationOptions,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<DistanceRow>> {
    let instrument = instrument_of(mechanism)?;
    let Some(distances) = &instrument.distances else {
        return Ok(Vec::new());
    };
    let mut pairs: Vec<[usize; 2]> = Vec::new();
    // The pairs drawn, for a membership test that stays fast for many distances.
    let mut drawn = std::collections::HashSet::new();
    let possible = poses.len() * poses.len().saturating_sub(1) / 2;
    if distances.simulate > possible {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "instrument.distances.simulate".into(),
            message: format!(
                "{} distances between distinct pairs of {} simulated rows, which have {possible} \
                 pairs: ask for at most {possible}, or simulate more rows",
                distances.simulate,
                poses.len()
            ),
        });
    }
    while pairs.len() < distances.simulate {
        let pair = [
            rng.random_range(0..poses.len()),
            rng.random_range(0..poses.len()),
        ];
        let sorted = [pair[0].min(pair[1]), pair[0].max(pair[1])];
        if sorted[0] != sorted[1] && drawn.insert(sorted) {
            pairs.push(sorted);
        }
    }
    Ok(pairs
        .into_iter()
        .map(|rows| {
            let [a, b] =
                rows.map(|r| target_position(instrument, shared, distances.target, &poses[r]));
            let length = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
            DistanceRow {
                line: None,
                rows,
                value: length + options.noise_scale * distances.noise * gaussian(rng),
            }
        })
        .collect())
}
