//! The simulated experiment of a run: the model's real mechanism (its simulation block)
//! measured at observability-optimal selected poses or at random ones, with the declared
//! noise times the noise scale; through the instrument when the model has one.

use super::settings::{PoseSource, SimulationSettings};
use crate::error::Result;
use crate::measure::forward_simulate::forward_pose_sets;
use crate::measure::observe_simulate::{observed_from, simulated_poses};
use crate::measure::simulate::{self as simulator, setup, simulate_at};
use crate::measure::simulate::{SimulatedExperiment, SimulationOptions};
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::report::RealValues;
use crate::selection::design::ExperimentDesign;
use crate::selection::forward_design::select_forward;

/// A simulated experiment.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// The measurements (through the instrument for a model with one).
    pub measurements: Measurements,
    /// The real parameters the measurements were simulated with.
    pub real: RealValues,
    /// Where the measurements come from, in words: poses, counts, seed and noise scale.
    pub source: String,
}

/// Simulates the model's experiment as `settings` say.
///
/// # Errors
/// No `simulation` block (or no `instrument` block where one is needed), no reachable pose,
/// or a pose selection that fails (naming what).
pub fn simulate(mechanism: &Mechanism, settings: &SimulationSettings) -> Result<Simulated> {
    let options = settings.options;
    let simulation = setup(mechanism)?;
    let seed = options.seed.unwrap_or(simulation.seed);
    let noise = format!("seed {seed}, noise scale {}", options.noise_scale);
    let simulated = simulated_poses(mechanism);
    let forward = mechanism.forward_instrument();
    let (experiment, source) = match (forward, settings.poses) {
        (Some(instrument), poses) => {
            // Commanded poses selected for the joint problem's observability, or random.
            let (commanded, chosen) = match poses {
                PoseSource::Random => (None, "at random poses".to_string()),
                PoseSource::Selected => {
                    let count = options
                        .poses_per_leg
                        .unwrap_or(mechanism.selection.poses_per_leg);
                    let criterion = mechanism.selection.criterion;
                    let design = select_forward(&simulated, settings.grid, count, criterion)?;
                    let text = format!(
                        "at selected poses ({criterion:?}-optimal from {} distinct candidate \
                         rows, grid {} m)",
                        design.candidates, design.spacing
                    );
                    (Some(design.commanded()), text)
                }
            };
            let sets = forward_pose_sets(&simulated, instrument, options, commanded.as_deref())?;
            let experiment = simulate_at(&simulated, &sets, options)?;
            let touch = if instrument.targets.iter().any(|t| t.touch.is_some()) {
                ", each moved to its touch"
            } else {
                ""
            };
            let measured = instrument.poses.as_ref().map_or(0, |p| p.simulate);
            let poses = match measured {
                0 => String::new(),
                n => format!(
                    ", then {n} rows at {} poses with their platform pose measured (inverse \
                     kinematics)",
                    match commanded {
                        Some(_) => "selected",
                        None => "random",
                    }
                ),
            };
            let text = format!(
                "simulated {chosen}{touch}: {} rows of every leg's reading (forward \
                 kinematics){poses}, {noise}",
                sets.shared.len() - measured
            );
            (experiment, text)
        }
        (None, poses) => match poses {
            PoseSource::Random => {
                let count = options.poses_per_leg.unwrap_or(simulation.poses_per_leg);
                let experiment = simulator::simulate(&simulated, options)?;
                let text = format!(
                    "simulated at random poses: {count} per leg and {count} shared, {noise}"
                );
                (experiment, text)
            }
            PoseSource::Selected => {
                let count = options
                    .poses_per_leg
                    .unwrap_or(mechanism.selection.poses_per_leg);
                let criterion = mechanism.selection.criterion;
                let design =
                    ExperimentDesign::select(&simulated, settings.grid, count, criterion, true)?;
                let experiment = simulate_at(&simulated, &design.pose_sets(), options)?;
                let text = format!(
                "simulated at selected poses ({criterion:?}-optimal from {} feasible candidates, grid {} m): {count} per leg and {count} shared, {noise}",
                design.candidates, design.spacing
            );
                (experiment, text)
            }
        },
    };
    let (real, measurements) = measured(mechanism, experiment, options)?;
    Ok(Simulated {
        measurements,
        real,
        source,
    })
}

/// The real values of `experiment` (simulated with `options` on [`simulated_poses`] of
/// `mechanism`) and what the model measures of it: the poses themselves, or the instrument's
/// view of them.
///
/// # Errors
/// No simulation block.
pub(crate) fn measured(
    mechanism: &Mechanism,
    experiment: SimulatedExperiment,
    options: SimulationOptions,
) -> Result<(RealValues, Measurements)> {
    if mechanism.instrument.is_none() {
        let real = RealValues {
            legs: experiment.real,
            instrument: None,
        };
        return Ok((real, Measurements::Readings(experiment.measurements)));
    }
    let observed = observed_from(mechanism, experiment, options)?;
    let real = RealValues {
        legs: observed.real,
        instrument: Some(observed.real_shared),
    };
    Ok((real, Measurements::Targets(observed.observations)))
}
