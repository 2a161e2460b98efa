//! Monte Carlo comparison of the identification strategies.
//!
//! The poses are selected once on the nominal model (observability-optimal, as `legwise
//! select`): `count` per leg for divide and conquer, `count` shared for the traditional
//! strategy, and `legs × count` shared for the traditional strategy at an equal number of poses
//! (the fair comparison: divide and conquer measures `legs × count` poses in all). Each trial
//! then draws a real mechanism (the model's simulation block: its `real` values or its seeded
//! perturbation) and the measurement noise, simulates every pose set with those draws, and
//! identifies with the three strategies ([`Arm`]). Per trial and strategy it keeps each
//! identified parameter's error (estimate − real), its predicted standard deviation (from the
//! fit's covariance) and the RMS position error over a coarse accuracy map (the model commands,
//! the real mechanism moves: [`crate::evaluate::accuracy::reached_poses_from`], the real
//! mechanism's forward kinematics prepared once per trial and each map warm-started from the
//! previous one's joints).
//!
//! With an `instrument` block the study compares the two identifications through the
//! instrument instead ([`INSTRUMENT_ARMS`]): each trial also draws the real instrument frame
//! and target offsets, simulates what the instrument reports, and identifies jointly and in two
//! stages; the study parameters include the identified shared ones.
//!
//! Trials run in parallel (rayon). Trial `i` draws from its own generator, seeded from the
//! study seed and `i` (a ChaCha stream per trial), and the summary reduces the trials in trial
//! order: the results are bit-identical for a seed whatever the number of threads.

use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use super::alarms::Alarms;
pub use super::arm::{Arm, ARMS, INSTRUMENT_ARMS};
use super::stats::{self, Estimate};
pub use super::verdict::{millimetres, verdict_sentence};
use crate::error::{Error, Result};
use crate::evaluate::accuracy::{
    commanded_each, map_grid, position_error, reached_poses_from, result_parameters,
};
use crate::evaluate::observed_frame::observed_frame_error;
use crate::identify::estimate::{FitOptions, StrategyResult};
use crate::kinematics::inverse::Joints;
use crate::kinematics::platform::ForwardKinematics;
use crate::kinematics::KernelRows;
use crate::measure::forward_simulate::forward_pose_sets;
use crate::measure::observe_simulate::simulated_poses;
use crate::measure::simulate::{real_parameters, simulate_at, PoseSets, SimulationOptions};
use crate::measure::{MeasurementSet, Measurements};
use crate::model::params::Unit;
use crate::model::Mechanism;
use crate::pipeline::{identify_one, measured};
use crate::progress::Work;
use crate::report::RealValues;
use crate::selection::candidates::candidate_pool;
use crate::selection::design::{divide_and_conquer, traditional};
use crate::selection::forward_design::select_forward;
use crate::solver::SolverKind;

mod trial;

/// What a study runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MonteCarloOptions {
    /// Number of trials.
    pub trials: usize,
    /// Study seed (each trial's generator derives from it and the trial index).
    pub seed: u64,
    /// The least-squares solver of every fit.
    pub solver: SolverKind,
    /// Multiplies every simulated noise standard deviation (and the declared noise the fits
    /// test their residuals against).
    pub noise_scale: f64,
    /// Poses per leg (default: the model's `selection.poses_per_leg`).
    pub poses_per_leg: Option<usize>,
    /// Candidate grid spacing of the pose selection, metres (default: the model's).
    pub grid: Option<f64>,
    /// Grid spacing of the accuracy map, metres.
    pub map_grid: f64,
    /// Fraction of the workspace region the accuracy map covers.
    pub map_scale: f64,
}

/// Default grid spacing of the study's accuracy map (metres): coarse, a few hundred points.
pub const DEFAULT_MAP_GRID: f64 = 0.05;

impl MonteCarloOptions {
    /// The defaults for `trials` trials from `seed`: Levenberg–Marquardt, the declared noise,
    /// the model's pose counts and grid, a 5 cm map over 0.95 of the region.
    pub fn new(trials: usize, seed: u64) -> Self {
        Self {
            trials,
            seed,
            solver: SolverKind::LevenbergMarquardt,
            noise_scale: 1.0,
            poses_per_leg: None,
            grid: None,
            map_grid: DEFAULT_MAP_GRID,
            map_scale: 0.95,
        }
    }
}

/// One identified parameter of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyParameter {
    /// Name as in the model file.
    pub name: String,
    /// Its SI unit.
    pub unit: Unit,
    /// Where it is.
    pub of: ParameterOf,
}

/// Where a study parameter is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParameterOf {
    /// A leg's: the leg's index and the index among its parameters.
    Leg {
        /// Index of the leg.
        leg: usize,
        /// Index among the leg's parameters.
        column: usize,
    },
    /// The instrument's: the index among its shared parameters.
    Instrument(usize),
}

/// A prepared study: the mechanism (its declared noise as in the model file; the fits expect it
/// times the noise scale, [`Study::fit_options`]), the selected poses and the map.
#[derive(Debug, Clone)]
pub struct Study {
    mechanism: Mechanism,
    options: MonteCarloOptions,
    /// The arms compared: [`ARMS`], or [`INSTRUMENT_ARMS`] for a model with an instrument.
    arms: Vec<Arm>,
    /// Divide and conquer's per-leg poses, then the shared poses of both traditional arms
    /// (first the small set, then the equal-poses set; none through an instrument, whose arms
    /// both identify from the per-leg poses).
    pose_sets: PoseSets,
    /// Number of shared poses of the traditional arm (the rest are the equal-poses arm's).
    shared_count: usize,
    map: Vec<[f64; 6]>,
    parameters: Vec<StudyParameter>,
    /// The real parameters when every trial draws the same ones (a simulation block that
    /// declares them all), with the nominal model's RMS position error over the map against
    /// them: computed once for all trials.
    fixed_real: Option<(Vec<Vec<f64>>, f64)>,
    /// The nominal model's joints at every map point (point after point, leg after leg): the
    /// warm starts of every trial's maps.
    nominal_joints: Vec<Option<Joints>>,
}

/// One arm's values in one trial.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ArmTrial {
    /// Estimate − real, per study parameter.
    pub errors: Vec<f64>,
    /// The fit's predicted standard deviation, per study parameter (NaN without redundancy).
    pub predicted_std: Vec<f64>,
    /// RMS position error over the accuracy map, metres.
    #[serde(rename = "map_rms_m")]
    pub map_rms: f64,
    /// The fit's checks of bad data, on data that have none: how often they fire.
    pub alarms: Alarms,
}

/// The values of one successful trial.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialValues {
    /// RMS position error over the map with the nominal model commanding, metres.
    pub nominal_map_rms: f64,
    /// The trial's real value of every study parameter (its draw; SI units).
    pub real: Vec<f64>,
    /// Per arm, in the study's order ([`Study::arms`]).
    pub arms: Vec<ArmTrial>,
}

/// One trial: its seed and its values, or why it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct Trial {
    /// Index of the trial.
    pub index: usize,
    /// The seed of its simulation (derived from the study seed and the index).
    pub seed: u64,
    /// The values, or the reason the trial failed (a simulation or fit error, or a solver that
    /// did not converge).
    pub outcome: std::result::Result<TrialValues, String>,
}

/// One arm's summary.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmSummary {
    /// The arm.
    pub arm: Arm,
    /// Poses measured in all.
    pub poses: usize,
    /// Per study parameter.
    pub parameters: Vec<ParameterSummary>,
    /// Mean over the trials of the RMS position error over the map, metres.
    pub map_rms: Estimate,
    /// The checks of bad data over every trial (counts summed).
    pub alarms: Alarms,
    /// The fraction of the leg fits tested for outliers that flagged a row (Wilson interval).
    pub flagged: Estimate,
    /// The fraction of the noise tests that rejected the declared noise (Wilson interval).
    pub rejected: Estimate,
    /// The fraction of the fits held to a tolerance whose predicted σ exceeded it (Wilson
    /// interval).
    pub above_tolerance: Estimate,
}

/// One parameter's error statistics under one arm.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterSummary {
    /// Mean error (bias).
    pub mean: Estimate,
    /// Standard deviation of the error (the observed spread).
    pub std: Estimate,
    /// Root mean square error.
    pub rms: Estimate,
    /// Mean over the trials of the predicted standard deviation (NaN if a fit had none).
    pub predicted_std: Estimate,
}

/// A paired comparison of two arms on the map's RMS position error.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The first arm.
    pub first: Arm,
    /// The second arm.
    pub second: Arm,
    /// Mean over the trials of (first − second) RMS position error, metres.
    pub difference: Estimate,
    /// What the interval says, one sentence.
    pub sentence: String,
}

/// The study's result.
#[derive(Debug, Clone, PartialEq)]
pub struct MonteCarlo {
    /// The options it ran with.
    pub options: MonteCarloOptions,
    /// Mechanism name.
    pub mechanism: String,
    /// The study parameters, in model order.
    pub parameters: Vec<StudyParameter>,
    /// Points of the accuracy map.
    pub map_points: usize,
    /// Seen through the forward kinematics: the frame the map errors are taken in (the
    /// instrument's first target, aligned over what its observations cannot see); `None` for
    /// the platform's position in the base frame.
    pub map_frame: Option<String>,
    /// Every trial, in index order.
    pub trials: Vec<Trial>,
    /// Trials whose values enter the summary.
    pub succeeded: usize,
    /// Mean RMS position error over the map of the nominal model, metres.
    pub nominal_map_rms: Estimate,
    /// Per arm, in the study's order.
    pub arms: Vec<ArmSummary>,
    /// The first arm against each other one (D&C against each traditional arm, or joint
    /// against two-stage).
    pub comparisons: Vec<Comparison>,
    /// The verdict: the last comparison (at an equal number of poses, or joint against
    /// two-stage).
    pub verdict: String,
}

/// The seed of trial `index`: the first word of the ChaCha stream `index` of the study seed.
pub fn trial_seed(seed: u64, index: usize) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index as u64);
    rng.next_u64()
}

impl Study {
    /// How every fit of the study treats its rows: plain least squares expecting the declared
    /// noise times the study's noise scale (as simulated).
    pub fn fit_options(&self) -> FitOptions {
        FitOptions {
            noise_scale: self.options.noise_scale,
            ..FitOptions::default()
        }
    }

    /// Selects the poses and builds the map grid.
    ///
    /// # Errors
    /// No simulation block; the pose selection's errors (too few candidates, an unidentifiable
    /// design); an invalid map grid or scale.
    pub fn prepare(mechanism: &Mechanism, options: MonteCarloOptions) -> Result<Self> {
        Self::prepare_at(mechanism, options, None)
    }

    /// [`Self::prepare`], a forward model measured at the commanded poses `commanded` (every
    /// trial's touches on its own real surface) instead of selected ones: a firmware's probe
    /// points, a design of one's own.
    ///
    /// # Errors
    /// As [`Self::prepare`]; commanded poses for a model not seen through the forward
    /// kinematics, or none.
    pub fn prepare_at(
        mechanism: &Mechanism,
        options: MonteCarloOptions,
        commanded: Option<&[[f64; 6]]>,
    ) -> Result<Self> {
        crate::measure::simulate::setup(mechanism)?;
        if let Some(poses) = commanded {
            if mechanism.forward_instrument().is_none() || poses.is_empty() {
                return Err(Error::Invalid(format!(
                    "{}: commanded poses (--poses FILE) are for a model seen through the forward \
                     kinematics (`instrument.kinematics: forward`), at least one",
                    mechanism.model_path.display()
                )));
            }
        }
        if mechanism.instrument.is_some() && options.solver != SolverKind::LevenbergMarquardt {
            return Err(Error::Invalid(format!(
                "{}: through an instrument the legs and the instrument are identified by \
                 Levenberg-Marquardt (choose --solver lm)",
                mechanism.model_path.display()
            )));
        }
        let map = map_grid(mechanism, options.map_grid, options.map_scale)?;
        let mechanism = mechanism.clone();
        let count = options
            .poses_per_leg
            .unwrap_or(mechanism.selection.poses_per_leg);
        let criterion = mechanism.selection.criterion;
        let through = mechanism.instrument.is_some();
        let forward = mechanism.forward_instrument().is_some();
        let mut per_leg = vec![Vec::new(); mechanism.legs.len()];
        let (arms, shared_count, shared_poses) = if forward {
            // Forward rows couple every leg: the joint fit alone, at the commanded poses
            // selected for it (each trial's touches on its own real surface).
            let commanded = match commanded {
                Some(poses) => poses.to_vec(),
                None => select_forward(&mechanism, options.grid, count, criterion)?.commanded(),
            };
            (vec![Arm::Joint], 0, commanded)
        } else {
            let pool = candidate_pool(&mechanism, options.grid)?;
            let legs = divide_and_conquer(&mechanism, &pool, count, criterion)?;
            let total: usize = legs.iter().map(|l| l.poses.len()).sum();
            for design in legs {
                per_leg[design.leg] = design.poses;
            }
            if through {
                (INSTRUMENT_ARMS.to_vec(), 0, Vec::new())
            } else {
                let shared = traditional(&mechanism, &pool, count, criterion)?;
                let equal = traditional(&mechanism, &pool, total, criterion)?;
                let shared_count = shared.poses.len();
                let mut shared_poses = shared.poses;
                shared_poses.extend(equal.poses);
                (ARMS.to_vec(), shared_count, shared_poses)
            }
        };
        let mut parameters: Vec<StudyParameter> = mechanism
            .instrument
            .iter()
            .flat_map(|instrument| {
                instrument.identified().into_iter().map(|k| StudyParameter {
                    name: instrument.parameters[k].name.clone(),
                    unit: instrument.parameters[k].unit,
                    of: ParameterOf::Instrument(k),
                })
            })
            .collect();
        parameters.extend(mechanism.identified_legs().into_iter().flat_map(|leg| {
            let model = &mechanism.legs[leg];
            model
                .identified()
                .into_iter()
                .map(move |column| StudyParameter {
                    name: model.params[column].name.clone(),
                    unit: model.params[column].unit,
                    of: ParameterOf::Leg { leg, column },
                })
        }));
        let nominal = mechanism.nominal_parameters();
        let kinematics = ForwardKinematics::new(&mechanism, &nominal);
        let mut joints = Vec::new();
        reached_poses_from(&mechanism, &nominal, &kinematics, &map, &mut joints);
        let mut study = Self {
            mechanism,
            options,
            arms,
            pose_sets: PoseSets {
                per_leg,
                shared: shared_poses,
            },
            shared_count,
            map,
            parameters,
            fixed_real: None,
            nominal_joints: joints,
        };
        study.fixed_real = study.fixed_real_parameters();
        Ok(study)
    }

    /// The real parameters and the nominal map's RMS error, if the real parameters do not
    /// depend on the trial (the same for two different trial seeds: declared, not drawn).
    fn fixed_real_parameters(&self) -> Option<(Vec<Vec<f64>>, f64)> {
        if self.map_frame().is_some() {
            // Its map depends on the trial's real instrument too: computed in every trial.
            return None;
        }
        let simulation = self.mechanism.simulation.as_ref()?;
        let [first, second] = [0, 1].map(|i| {
            real_parameters(
                &self.mechanism,
                simulation,
                trial_seed(self.options.seed, i),
            )
        });
        if first != second {
            return None;
        }
        let kinematics = ForwardKinematics::new(&self.mechanism, &first);
        // Not fixed yet: computed.
        let rms = self.nominal_map_rms((&first, None), &kinematics).ok()?;
        Some((first, rms))
    }

    /// Seen through the forward kinematics, the frame the map errors are taken in.
    fn map_frame(&self) -> Option<String> {
        let instrument = self.mechanism.forward_instrument()?;
        Some(format!(
            "target `{}` in the frame the observations define (the instrument frame, aligned \
             over the frame motions its reported coordinates cannot see)",
            instrument.targets[0].name
        ))
    }

    /// The mechanism the study identifies (its declared noise unscaled: [`Study::fit_options`]
    /// carry the scale).
    pub fn mechanism(&self) -> &Mechanism {
        &self.mechanism
    }

    /// The arms the study compares, in report order.
    pub fn arms(&self) -> &[Arm] {
        &self.arms
    }

    /// Poses each arm measures, in the order of [`Self::arms`].
    pub fn poses(&self) -> Vec<usize> {
        let dc = self.pose_sets.per_leg.iter().map(Vec::len).sum();
        if self.mechanism.forward_instrument().is_some() {
            // The forward rows (every leg's reading at each), the joint fit's.
            return vec![self.pose_sets.shared.len(); self.arms.len()];
        }
        if self.mechanism.instrument.is_some() {
            return vec![dc; self.arms.len()];
        }
        let equal = self.pose_sets.shared.len() - self.shared_count;
        vec![dc, self.shared_count, equal]
    }

    /// Runs every trial in parallel (a progress bar on a terminal) and summarises them.
    pub fn run(&self) -> MonteCarlo {
        let work = Work {
            label: "monte carlo",
            total: self.options.trials,
            items: "trials",
            passes: 1,
        };
        let trials = work.map(|index| self.trial(index));
        self.summarise(trials)
    }

    /// The summary of `trials` (reduced in the given order; failed trials left out).
    pub fn summarise(&self, trials: Vec<Trial>) -> MonteCarlo {
        let values: Vec<&TrialValues> = trials
            .iter()
            .filter_map(|t| t.outcome.as_ref().ok())
            .collect();
        let nominal: Vec<f64> = values.iter().map(|v| v.nominal_map_rms).collect();
        let map_of = |a: usize| -> Vec<f64> { values.iter().map(|v| v.arms[a].map_rms).collect() };
        let poses = self.poses();
        let arms: Vec<ArmSummary> = self
            .arms
            .iter()
            .enumerate()
            .map(|(a, &arm)| {
                let alarms = values
                    .iter()
                    .fold(Alarms::default(), |sum, v| sum + v.arms[a].alarms);
                ArmSummary {
                    arm,
                    poses: poses[a],
                    alarms,
                    flagged: stats::proportion_interval(alarms.flagged, alarms.outlier_tests),
                    rejected: stats::proportion_interval(alarms.rejected, alarms.noise_tests),
                    above_tolerance: stats::proportion_interval(
                        alarms.above_tolerance,
                        alarms.tolerance_tests,
                    ),
                    parameters: (0..self.parameters.len())
                        .map(|p| {
                            let errors: Vec<f64> =
                                values.iter().map(|v| v.arms[a].errors[p]).collect();
                            let predicted: Vec<f64> =
                                values.iter().map(|v| v.arms[a].predicted_std[p]).collect();
                            ParameterSummary {
                                mean: stats::mean_interval(&errors),
                                std: stats::std_interval(&errors),
                                rms: stats::rms_interval(&errors),
                                predicted_std: stats::mean_interval(&predicted),
                            }
                        })
                        .collect(),
                    map_rms: stats::mean_interval(&map_of(a)),
                }
            })
            .collect();
        let through = self.mechanism.instrument.is_some();
        let comparisons: Vec<Comparison> = (1..self.arms.len())
            .map(|b| {
                let (first, second) = (self.arms[0], self.arms[b]);
                let difference = stats::paired_difference(&map_of(0), &map_of(b));
                let equal_poses = poses[b] == poses[0] && !through;
                Comparison {
                    first,
                    second,
                    sentence: verdict_sentence(first, second, equal_poses, &difference),
                    difference,
                }
            })
            .collect();
        let verdict =
            comparisons.last().map_or_else(
                || {
                    format!(
                    "one strategy ({}): nothing to compare; read its parameters' std/σ and its \
                     map error above",
                    self.arms.iter().map(|a| a.name()).collect::<Vec<_>>().join(", ")
                )
                },
                |c| c.sentence.clone(),
            );
        MonteCarlo {
            options: self.options,
            mechanism: self.mechanism.name.clone(),
            parameters: self.parameters.clone(),
            map_points: self.map.len(),
            map_frame: self.map_frame(),
            succeeded: values.len(),
            nominal_map_rms: stats::mean_interval(&nominal),
            arms,
            comparisons,
            verdict,
            trials,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_trial_gets_its_own_seed_and_the_same_one_each_time() {
        let seeds: std::collections::BTreeSet<u64> = (0..1000).map(|i| trial_seed(7, i)).collect();
        assert_eq!(seeds.len(), 1000);
        assert_eq!(trial_seed(7, 12), trial_seed(7, 12));
        assert_ne!(trial_seed(7, 12), trial_seed(8, 12));
    }
}
