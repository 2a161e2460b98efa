//! A study of a delta printer's calibration workflows on simulated printers: legwise's (its
//! selected touches, its default fit, the result exported through the firmware's parameters)
//! against the firmware's own (its probe points, its factor set), each judged by the print
//! error the real printer makes when the firmware commands it with the values the workflow
//! gives.
//!
//! **The printers.** Each one perturbs every parameter of an imported model (`legwise printer
//! import`) — every tower's position, rod, gain, carriage offset and effector joint — and the
//! bed's height and tilt, by Gaussian draws of the standard deviations of [`Spread`]: what a
//! built printer is off its drawings by, much of it beyond what the firmware can express (its
//! rods equal to each other in some firmwares, its gains 1, its bed level). Its probe touches
//! the real, tilted bed, with the model's declared noise on each height.
//!
//! **The print error.** The firmware, with the values a workflow gives, commands the carriage
//! readings of its own kinematics at every point of a map over the workspace (the model's
//! region, [`PrinterStudyOptions::map_grid`]); the real printer puts the nozzle where its
//! geometry takes it. The error is taken in the frame the probe defines (the real bed, after
//! the motions a probe cannot see: along the bed and about its normal, as
//! [`observed_frame_error`]), its RMS over the map is the printer's print error.
//!
//! Printers run in parallel (rayon); printer `i` draws from its own generator seeded from the
//! study seed and `i`, so a seed gives the same figures whatever the number of threads.

use std::collections::BTreeMap;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::evaluate::accuracy::{reached_poses_from, result_parameters};
use crate::evaluate::observed_frame::observed_frame_error;
use crate::identify::estimate::FitOptions;
use crate::identify::factor_set::fit_factor_set;
use crate::identify::result::Strategy;
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::forward_simulate::{forward_pose_sets, touched};
use crate::measure::observe_simulate::simulated_poses;
use crate::measure::simulate::{gaussian, simulate_at, SimulationOptions};
use crate::measure::Measurements;
use crate::model::mechanism::Simulation;
use crate::model::params::Unit;
use crate::model::with_values::with_values;
use crate::model::Mechanism;
use crate::pipeline::{identify_one, measured};
use crate::selection::forward_design::select_forward;
use crate::solver::SolverKind;
use crate::study::montecarlo::trial_seed;

use super::export::fit_delta;

mod bed;
mod choice;
mod firmware;
mod summary;

pub use crate::study::set_outcomes::{
    choice_summary, median, recommended, ChoiceSummary, SetOutcome, SetSummary,
};
pub use bed::{print_map, MAP_LAYERS};
pub use firmware::{
    firmware_quantities, klipper_calibration, FirmwareCalibration, KLIPPER_SCATTER,
};
pub use summary::PrinterStudySummary;

/// How far the simulated printers are from the imported model: Gaussian standard deviations by
/// kind of parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Lengths (tower positions, rods, carriage offsets, effector joints, the bed's height), m.
    pub length: f64,
    /// Angles (the bed's tilt), rad.
    pub angle: f64,
    /// Actuator gains (steps per millimetre), dimensionless.
    pub gain: f64,
}

impl Default for Spread {
    /// A printer built to about a third of a millimetre and a milliradian, its steps per
    /// millimetre to 0.1 %: 3e-4 m, 1e-3 rad, 1e-3.
    fn default() -> Self {
        Self {
            length: 3e-4,
            angle: 1e-3,
            gain: 1e-3,
        }
    }
}

/// What a study runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrinterStudyOptions {
    /// Number of simulated printers.
    pub printers: usize,
    /// Study seed.
    pub seed: u64,
    /// legwise's touches (default: the model's `selection.poses_per_leg`).
    pub touches: Option<usize>,
    /// How far the printers are from the model.
    pub spread: Spread,
    /// Grid spacing of the print-error map, m.
    pub map_grid: f64,
    /// Also fit every factor set of the model on legwise's touches, each judged by its print
    /// error, and the set the touches alone recommend ([`recommended`]).
    pub compare_sets: bool,
}

impl PrinterStudyOptions {
    /// `printers` printers from `seed`, the default spread, the model's touch count and a 1 cm
    /// map.
    pub fn new(printers: usize, seed: u64) -> Self {
        Self {
            printers,
            seed,
            touches: None,
            spread: Spread::default(),
            map_grid: 0.01,
            compare_sets: false,
        }
    }
}

/// One printer's print errors (RMS over the map in the frame the probe defines, m).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PrinterErrors {
    /// With the imported (nominal) values.
    pub nominal: f64,
    /// After the firmware's own calibration (a study against a firmware).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub firmware: Option<f64>,
    /// legwise's calibrated model itself commanding (what a firmware with its terms would do).
    pub legwise_model: f64,
    /// legwise's calibration exported through the firmware's parameters (a study against a
    /// firmware).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub legwise: Option<f64>,
    /// The export's loss: RMS over the bed of the nozzle's distance between the exported
    /// firmware values and legwise's calibrated model, m (a study against a firmware).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub export_loss: Option<f64>,
}

/// What one printer's two calibrations gave.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PrinterOutcome {
    /// The print errors.
    #[serde(rename = "print_error_m")]
    pub errors: PrinterErrors,
    /// The firmware's values after its own calibration (the model's quantities it fits, SI;
    /// empty without a firmware).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub firmware_values: BTreeMap<String, f64>,
    /// legwise's calibration exported as the firmware's values (the model's quantities, SI;
    /// empty without a firmware).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub legwise_values: BTreeMap<String, f64>,
    /// With [`PrinterStudyOptions::compare_sets`]: every set of the model on legwise's
    /// touches (the model's own first).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sets: Vec<SetOutcome>,
}

/// One printer: its seed and what its calibrations gave, or why it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct PrinterTrial {
    /// Its index.
    pub index: usize,
    /// Its seed.
    pub seed: u64,
    /// Its outcome, or the reason it failed (a touch out of reach, a fit that did not
    /// converge).
    pub outcome: std::result::Result<PrinterOutcome, String>,
}

/// A prepared study.
#[derive(Debug, Clone)]
pub struct PrinterStudy {
    mechanism: Mechanism,
    /// The firmware compared with, if any.
    firmware: Option<FirmwareCalibration>,
    options: PrinterStudyOptions,
    /// legwise's selected touches (commanded poses).
    selected: Vec<[f64; 6]>,
    /// The firmware's touches (commanded poses at its points).
    firmware_poses: Vec<[f64; 6]>,
    map: Vec<[f64; 6]>,
    bed_radius: f64,
}

/// The study's result.
#[derive(Debug, Clone, PartialEq)]
pub struct PrinterStudyResult {
    /// The options it ran with.
    pub options: PrinterStudyOptions,
    /// The firmware's calibration's name (`None`: legwise's fit and sets alone).
    pub firmware: Option<String>,
    /// The firmware's touches.
    pub firmware_touches: usize,
    /// legwise's touches.
    pub legwise_touches: usize,
    /// Points of the print-error map.
    pub map_points: usize,
    /// Every printer, in index order.
    pub printers: Vec<PrinterTrial>,
}

impl PrinterStudy {
    /// Selects legwise's touches, places the firmware's (if compared with one) and builds the
    /// map.
    ///
    /// # Errors
    /// Not a printer (no forward instrument); the selection's errors; a firmware point off the
    /// nominal bed; an empty map.
    pub fn prepare(
        mechanism: &Mechanism,
        firmware: Option<FirmwareCalibration>,
        options: PrinterStudyOptions,
    ) -> Result<Self> {
        let instrument = mechanism.forward_instrument().ok_or_else(|| Error::Model {
            path: mechanism.model_path.clone(),
            field: "instrument.kinematics".into(),
            message: "expected a printer seen through its probe (a forward model, \
                      `instrument.kinematics: forward`), found none"
                .into(),
        })?;
        if options.printers == 0 {
            return Err(Error::Invalid("a printer study needs printers".into()));
        }
        let count = options.touches.unwrap_or(mechanism.selection.poses_per_leg);
        let criterion = mechanism.selection.criterion;
        let selected = select_forward(mechanism, None, count, criterion)?.commanded();
        let nominal_shared = instrument.nominal();
        let points = firmware.iter().flat_map(|f| &f.points);
        let firmware_poses = points
            .map(|&[x, y]| {
                let mut pose = mechanism.home_pose;
                pose[0] = x;
                pose[1] = y;
                touched(mechanism, instrument, &nominal_shared, pose)
            })
            .collect::<Result<Vec<_>>>()?;
        let map = print_map(mechanism, options.map_grid)?;
        Ok(Self {
            mechanism: mechanism.clone(),
            firmware,
            options,
            selected,
            firmware_poses,
            map,
            bed_radius: bed::bed_radius(mechanism)?,
        })
    }

    /// Runs every printer (in parallel) and gathers them in index order.
    pub fn run(&self) -> PrinterStudyResult {
        let printers = (0..self.options.printers)
            .into_par_iter()
            .map(|index| PrinterTrial {
                index,
                seed: trial_seed(self.options.seed, index),
                outcome: self.printer(index).map_err(|e| e.to_string()),
            })
            .collect();
        PrinterStudyResult {
            options: self.options,
            firmware: self.firmware.as_ref().map(|f| f.name.clone()),
            firmware_touches: self.firmware_poses.len(),
            legwise_touches: self.selected.len(),
            map_points: self.map.len(),
            printers,
        }
    }

    /// Printer `index`: drawn from its seed, calibrated both ways, its print errors measured.
    ///
    /// # Errors
    /// A touch beyond the printer's reach, a fit that fails or does not converge, an export
    /// that does not converge.
    pub fn printer(&self, index: usize) -> Result<PrinterOutcome> {
        let seed = trial_seed(self.options.seed, index);
        let real = self.draw(seed);
        let (legs, shared) = real_values(&real)?;
        let kinematics = ForwardKinematics::new(&real, &legs);
        let error = |model: &Mechanism| self.print_error(model, &kinematics, &shared);

        let firmware = match &self.firmware {
            Some(calibration) => {
                let firmware_data = self.touches(&real, &self.firmware_poses, seed)?;
                let set = fit_factor_set(&self.mechanism, &firmware_data, &calibration.set)?;
                let values: Vec<(String, f64)> = set
                    .factors
                    .iter()
                    .map(|f| (f.name.clone(), f.estimate))
                    .collect();
                Some((with_values(&self.mechanism, &values)?, values))
            }
            None => None,
        };

        let data = self.touches(&real, &self.selected, seed ^ 0x7e11)?;
        let result = identify_one(
            &self.mechanism,
            &data,
            Strategy::Joint,
            SolverKind::LevenbergMarquardt,
            FitOptions::default(),
        )?;
        if let Some(run) = result.runs.iter().find(|r| !r.converged) {
            return Err(Error::Solver {
                context: "legwise's fit".into(),
                message: format!("did not converge: {}", run.stop_reason),
            });
        }
        let calibrated = with_parameters(
            &self.mechanism,
            &result_parameters(&self.mechanism, &result),
            result
                .instrument
                .as_ref()
                .map(|i| i.parameters.iter().map(|p| p.estimate).collect()),
        );
        let mut errors = PrinterErrors {
            nominal: error(&self.mechanism)?,
            firmware: None,
            legwise_model: error(&calibrated)?,
            legwise: None,
            export_loss: None,
        };
        let (mut firmware_values, mut legwise_values) = (BTreeMap::new(), BTreeMap::new());
        if let (Some(calibration), Some((firmware, values))) = (&self.firmware, firmware) {
            let export = fit_delta(&calibrated, self.bed_radius, calibration.terms)?;
            let exported_values = firmware_quantities(&self.mechanism, &export, calibration.terms)?;
            let exported = with_values(&self.mechanism, &exported_values)?;
            errors.firmware = Some(error(&firmware)?);
            errors.legwise = Some(error(&exported)?);
            errors.export_loss = Some(export.rms_loss);
            firmware_values = values.into_iter().collect();
            legwise_values = exported_values.into_iter().collect();
        }
        let sets = match self.options.compare_sets {
            true => self.set_outcomes(&data, (&kinematics, &shared), &real)?,
            false => Vec::new(),
        };
        Ok(PrinterOutcome {
            errors,
            firmware_values,
            legwise_values,
            sets,
        })
    }

    /// Printer `index`: the model with its simulation block's `real` values drawn (every leg
    /// parameter and the bed's height and tilt about the model's values).
    pub fn real_printer(&self, index: usize) -> Mechanism {
        self.draw(trial_seed(self.options.seed, index))
    }

    /// The map the print errors are taken over.
    pub fn map(&self) -> &[[f64; 6]] {
        &self.map
    }

    /// A printer drawn from `seed`.
    fn draw(&self, seed: u64) -> Mechanism {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let spread = self.options.spread;
        let sigma = |unit: Unit| match unit {
            Unit::Metre => spread.length,
            Unit::Radian => spread.angle,
            Unit::One => spread.gain,
        };
        let mut real = BTreeMap::new();
        for leg in &self.mechanism.legs {
            for p in &leg.params {
                let value = p.nominal + sigma(p.unit) * gaussian(&mut rng);
                real.insert(p.name.clone(), value);
            }
        }
        if let Some(instrument) = &self.mechanism.instrument {
            // The bed's height and tilt; where it lies along itself and its turn about its
            // normal a probe cannot see (and the map's frame aligns away).
            let components = instrument.frame_components();
            for (k, p) in instrument
                .parameters
                .iter()
                .enumerate()
                .take(components.len())
            {
                let moved = matches!(components[k], "z" | "roll" | "pitch");
                let value = p.nominal
                    + if moved {
                        sigma(p.unit) * gaussian(&mut rng)
                    } else {
                        0.0
                    };
                real.insert(p.name.clone(), value);
            }
        }
        let noise = self.mechanism.noise.unwrap_or_default();
        self.mechanism.edited(|parts| {
            parts.simulation = Some(Simulation {
                real,
                perturbation: None,
                pose_noise: noise.pose,
                reading_noise: noise.reading,
                poses_per_leg: 1,
                seed,
            });
        })
    }

    /// The touches of `real` (a drawn printer) at the commanded poses, with the declared noise.
    fn touches(&self, real: &Mechanism, commanded: &[[f64; 6]], seed: u64) -> Result<Measurements> {
        let instrument = real.forward_instrument().ok_or_else(|| {
            Error::Invalid("a printer study's model has a forward instrument".into())
        })?;
        let options = SimulationOptions {
            seed: Some(seed),
            noise_scale: 1.0,
            poses_per_leg: None,
        };
        let simulated = simulated_poses(real);
        let sets = forward_pose_sets(&simulated, instrument, options, Some(commanded))?;
        let experiment = simulate_at(&simulated, &sets, options)?;
        Ok(measured(real, experiment, options)?.1)
    }

    /// The print error of `model` commanding the real printer (`real`: its forward kinematics;
    /// `real_shared`: its bed frame and nozzle), RMS over the map in the frame the probe defines.
    fn print_error(
        &self,
        model: &Mechanism,
        real: &ForwardKinematics<'_>,
        real_shared: &[f64],
    ) -> Result<f64> {
        let commanding = model.nominal_parameters();
        let reached = reached_poses_from(model, &commanding, real, &self.map, &mut Vec::new());
        let instrument = model.forward_instrument().ok_or_else(|| {
            Error::Invalid("a printer study's model has a forward instrument".into())
        })?;
        let shared = instrument.nominal();
        observed_frame_error(instrument, (&shared, real_shared), &self.map, &reached)
            .map(|e| e.position_error.rms)
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "print error: the real printer reaches none of the {} map points",
                    self.map.len()
                ))
            })
    }
}

/// A drawn printer's leg parameters and instrument values (its simulation block's `real`).
fn real_values(real: &Mechanism) -> Result<(Vec<Vec<f64>>, Vec<f64>)> {
    let simulation = crate::measure::simulate::setup(real)?;
    let value = |name: &str, nominal: f64| simulation.real.get(name).copied().unwrap_or(nominal);
    let legs = real
        .legs
        .iter()
        .map(|leg| {
            leg.params
                .iter()
                .map(|p| value(&p.name, p.nominal))
                .collect()
        })
        .collect();
    let shared = real.instrument.as_ref().map_or_else(Vec::new, |i| {
        i.parameters
            .iter()
            .map(|p| value(&p.name, p.nominal))
            .collect()
    });
    Ok((legs, shared))
}

/// `mechanism` with its legs' parameters at `legs` and its instrument's at `shared`: a
/// calibrated model in memory.
fn with_parameters(
    mechanism: &Mechanism,
    legs: &[Vec<f64>],
    shared: Option<Vec<f64>>,
) -> Mechanism {
    mechanism.edited(|parts| {
        for (leg, values) in parts.legs.iter_mut().zip(legs) {
            for (p, value) in leg.params.iter_mut().zip(values) {
                p.nominal = *value;
            }
        }
        if let (Some(instrument), Some(shared)) = (parts.instrument.as_mut(), shared) {
            for (p, value) in instrument.parameters.iter_mut().zip(shared) {
                p.nominal = value;
            }
        }
    })
}
