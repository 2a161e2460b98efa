//! Seeded simulation of an identification experiment from the model's simulation block.
//!
//! "Real" parameters come from `simulation.real` or a seeded perturbation of the nominal
//! values; true readings are each leg's inverse kinematics with the real parameters at the true
//! pose; the measured pose and readings get Gaussian noise (`simulation.noise`, by default the
//! model's declared `noise` block, applied at validation). Divide and conquer gets
//! `poses_per_leg` poses per leg (labelled with the leg, only that leg's reading, independent
//! noise); the traditional strategy gets `poses_per_leg` shared poses with every reading. The
//! true poses are given ([`simulate_at`], e.g. selected poses) or random ([`simulate`]).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::{MeasuredPose, MeasurementSet};
use crate::error::{Error, Result};
use crate::kinematics::inverse::predict_reading;
use crate::kinematics::reading::ReadingPredictor;
use crate::model::mechanism::Simulation;
use crate::model::params::{ParamTarget, Parameter, Unit};
use crate::model::Mechanism;

/// Options that change a simulation without editing the model file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulationOptions {
    /// Replaces the model's seed.
    pub seed: Option<u64>,
    /// Multiplies every noise standard deviation (0 gives noise-free data).
    pub noise_scale: f64,
    /// Replaces the model's number of poses per leg.
    pub poses_per_leg: Option<usize>,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            seed: None,
            noise_scale: 1.0,
            poses_per_leg: None,
        }
    }
}

/// A simulated experiment: the real parameters and the measurements.
#[derive(Debug, Clone)]
pub struct SimulatedExperiment {
    /// Real parameter values per leg (all parameters, in model order).
    pub real: Vec<Vec<f64>>,
    /// The simulated measurements.
    pub measurements: MeasurementSet,
}

/// The model's simulation block, or an error naming the model file.
///
/// # Errors
/// [`Error::Model`] if the model has no `simulation` block.
pub fn setup(mechanism: &Mechanism) -> Result<&Simulation> {
    mechanism.simulation.as_ref().ok_or_else(|| Error::Model {
        path: mechanism.model_path.clone(),
        field: "simulation".into(),
        message: "missing: simulating needs a simulation block (or give --measurements)".into(),
    })
}

/// Real parameter values per leg: `simulation.real`, else a seeded perturbation of identified
/// parameters ([`perturbation_sigma`]), else nominal.
pub fn real_parameters(mechanism: &Mechanism, simulation: &Simulation, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x005e_ed0f_2ea1);
    mechanism
        .legs
        .iter()
        .map(|leg| {
            leg.params
                .iter()
                .map(|p| {
                    if let Some(&value) = simulation.real.get(&p.name) {
                        return value;
                    }
                    match perturbation_sigma(p, simulation) {
                        Some(sigma) => p.nominal + sigma * gaussian(&mut rng),
                        None => p.nominal,
                    }
                })
                .collect()
        })
        .collect()
}

/// The standard deviation of the simulation's perturbation of parameter `p` (by its kind:
/// gain, angle or length), when the simulation draws it: identified, not given a real value,
/// with a `perturbation` block. `None` for a parameter the simulation holds at a given value.
pub fn perturbation_sigma(p: &Parameter, simulation: &Simulation) -> Option<f64> {
    if simulation.real.contains_key(&p.name) || !p.identified {
        return None;
    }
    let (length, angle, gain) = simulation.perturbation?;
    Some(match (p.target, p.unit) {
        (ParamTarget::Gain, _) => gain,
        (_, Unit::Radian) => angle,
        _ => length,
    })
}

/// A standard normal draw.
pub(crate) fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    Normal::new(0.0, 1.0).map_or(0.0, |n| n.sample(rng))
}

/// True poses of an experiment: per leg (divide and conquer) and shared (traditional).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PoseSets {
    /// Per leg, the poses of its own identification set.
    pub per_leg: Vec<Vec<[f64; 6]>>,
    /// Poses shared by all legs.
    pub shared: Vec<[f64; 6]>,
}

/// Simulates the experiment of the model's simulation block at random poses spread over the
/// usable workspace, which every leg reaches on its home branch with both the nominal and the
/// real parameters.
///
/// # Errors
/// No simulation block, or no reachable pose found in the usable workspace.
pub fn simulate(mechanism: &Mechanism, options: SimulationOptions) -> Result<SimulatedExperiment> {
    let simulation = setup(mechanism)?;
    check_noise(mechanism, simulation, options.noise_scale)?;
    let seed = options.seed.unwrap_or(simulation.seed);
    let count = options.poses_per_leg.unwrap_or(simulation.poses_per_leg);
    let real = real_parameters(mechanism, simulation, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1));
    let mut draw = |n: usize| -> Result<Vec<[f64; 6]>> {
        (0..n)
            .map(|_| reachable_pose(mechanism, &real, &mut rng))
            .collect()
    };
    let sets = PoseSets {
        per_leg: (0..mechanism.legs.len())
            .map(|_| draw(count))
            .collect::<Result<_>>()?,
        shared: draw(count)?,
    };
    simulate_at(mechanism, &sets, options)
}

/// Simulates measurements at given true poses: true readings from each leg's inverse
/// kinematics with the real parameters, then Gaussian noise on the measured coordinates and on
/// the readings. Rows of a leg's set carry only that leg's reading; shared rows carry all.
///
/// # Errors
/// No simulation block, or a real leg cannot reach one of the poses (named).
pub fn simulate_at(
    mechanism: &Mechanism,
    sets: &PoseSets,
    options: SimulationOptions,
) -> Result<SimulatedExperiment> {
    let simulation = setup(mechanism)?;
    check_noise(mechanism, simulation, options.noise_scale)?;
    let seed = options.seed.unwrap_or(simulation.seed);
    let real = real_parameters(mechanism, simulation, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let legs = mechanism.legs.len();
    let groups = sets
        .per_leg
        .iter()
        .enumerate()
        .map(|(l, poses)| (Some(l), poses))
        .chain([(None, &sets.shared)]);
    let mut poses = MeasurementSet::new(None, legs);
    // Each real leg's geometry built once for every pose (the same readings, bit for bit).
    let predictors: Vec<ReadingPredictor<'_>> = mechanism
        .legs
        .iter()
        .zip(&real)
        .map(|(leg, real)| ReadingPredictor::new(leg, real))
        .collect();
    for (group, true_poses) in groups {
        for true_pose in true_poses {
            let readings = predictors.iter().map(|predictor| {
                predictor
                    .predict(true_pose, &mechanism.home_pose)
                    .map_err(|err| {
                        Error::Invalid(format!(
                            "simulation: with its real parameters, {err} (pose {})",
                            mechanism.pose_text(true_pose)
                        ))
                    })
            });
            let readings = readings.collect::<Result<Vec<f64>>>()?;
            if let Some(l) = readings.iter().position(|r| !r.is_finite()) {
                return Err(Error::Invalid(format!(
                    "simulation: with its real parameters, leg `{}`'s reading is not finite at \
                     pose {}: check the real values of its gain and offset (simulation.real)",
                    mechanism.legs[l].name,
                    mechanism.pose_text(true_pose)
                )));
            }
            let mut measured = *true_pose;
            for &c in &mechanism.measured {
                measured[c] += options.noise_scale * simulation.pose_noise[c] * gaussian(&mut rng);
            }
            let readings: Vec<Option<f64>> = (0..legs)
                .map(|l| {
                    let noise = options.noise_scale * simulation.reading_noise * gaussian(&mut rng);
                    group.is_none_or(|g| g == l).then(|| readings[l] + noise)
                })
                .collect();
            let pose = MeasuredPose {
                line: None,
                leg: group,
                pose: measured,
            };
            poses.push(pose, &readings);
        }
    }
    Ok(SimulatedExperiment {
        real,
        measurements: poses,
    })
}

/// Random poses drawn before a simulation gives up finding a reachable one.
const DRAWS: usize = 10_000;

/// Refuses a noise (declared σ times `scale`) that makes every simulated value meaningless:
/// a position or prismatic reading σ beyond the mechanism's size, an angle or revolute reading
/// σ beyond π rad. `--noise-scale 1e6` wrote poses scattered over 100 m without a word.
///
/// # Errors
/// [`Error::Invalid`] naming the coordinate, the σ and the scale.
pub fn check_noise(mechanism: &Mechanism, simulation: &Simulation, scale: f64) -> Result<()> {
    let size = crate::measure::checks::mechanism_size(mechanism);
    let bound = |metres: bool| if metres { size } else { std::f64::consts::PI };
    let revolute = mechanism.legs.iter().any(|l| l.actuated_is_revolute());
    let prismatic = mechanism.legs.iter().any(|l| !l.actuated_is_revolute());
    let coordinates = mechanism.measured.iter().map(|&c| {
        let name = crate::model::mechanism::COORDINATES[c];
        (format!("`{name}`"), simulation.pose_noise[c], c < 3)
    });
    let readings = [(true, prismatic), (false, revolute)]
        .into_iter()
        .filter(|(_, present)| *present)
        .map(|(metres, _)| ("the readings".to_string(), simulation.reading_noise, metres));
    for (what, declared, metres) in coordinates.chain(readings) {
        let sigma = scale * declared;
        if sigma > bound(metres) {
            let (unit, what_bound) = match metres {
                true => ("m", format!("the mechanism's size ({size:.3} m)")),
                false => ("rad", "π rad".to_string()),
            };
            return Err(Error::Invalid(format!(
                "simulation: the noise of {what} would be σ = {sigma:.3e} {unit} ({declared:e} \
                 {unit} declared, times the noise scale {}), more than {what_bound}: the \
                 simulated measurements would mean nothing; lower the noise scale \
                 (--noise-scale) or the model's noise",
                super::checks::compact(scale)
            )));
        }
    }
    Ok(())
}

/// Draws poses until every leg reaches one with nominal and real parameters.
pub(super) fn reachable_pose(
    mechanism: &Mechanism,
    real_parameters: &[Vec<f64>],
    rng: &mut ChaCha8Rng,
) -> Result<[f64; 6]> {
    let home = &mechanism.home_pose;
    let (mut drawn, mut nominal) = (0, 0);
    for _ in 0..DRAWS {
        let Some(pose) = mechanism.workspace.sample(home, rng) else {
            break;
        };
        drawn += 1;
        let reaches = |real: bool| {
            mechanism
                .legs
                .iter()
                .zip(real_parameters)
                .all(|(leg, phi)| match real {
                    true => predict_reading(leg, phi, &pose, home).is_ok(),
                    false => predict_reading(leg, &leg.nominal(), &pose, home).is_ok(),
                })
        };
        if reaches(false) {
            nominal += 1;
            if reaches(true) {
                return Ok(pose);
            }
        }
    }
    if nominal > 0 {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "simulation".into(),
            message: format!(
                "no pose of the usable workspace is reachable by the real legs on their home \
                 branch, though the nominal legs reach {nominal} of the {drawn} poses drawn: \
                 the real parameters (simulation.real, simulation.perturbation) are too far \
                 from the nominal ones (lengths in millimetres?)"
            ),
        });
    }
    Err(Error::Model {
        path: mechanism.model_path.clone(),
        field: "workspace".into(),
        message: "no pose of the usable workspace is reachable by every leg on its home branch"
            .into(),
    })
}
