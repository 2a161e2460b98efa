//! The whole identification job, one entry point for every set-up: the measurements given or
//! simulated (at selected or random poses), the identification by the strategies the model
//! calls for (divide and conquer; through an instrument, joint and two-stage), the statistics
//! and trust checks of every fit, and in simulation the accuracy maps — returned as one
//! [`Report`], from which the terminal text, the JSON document and the calibrated model come.
//!
//! ```no_run
//! use legwise::{identify, Measurements, Mechanism, Settings};
//!
//! let mechanism = Mechanism::load("models/5r.yaml".as_ref())?;
//! let data = Measurements::read("measurements.csv".as_ref(), &mechanism)?;
//! let report = identify(&mechanism, &data, &Settings::default())?;
//! println!("{}", report.terminal_text());
//! # Ok::<(), legwise::Error>(())
//! ```

mod settings;
mod simulation;

pub use settings::{MapSettings, PoseSource, Settings, SimulationSettings};
pub(crate) use simulation::measured;
pub use simulation::{simulate, Simulated};

use crate::error::{Error, Result};
use crate::evaluate::accuracy::{accuracy_map_seen, result_parameters};
use crate::evaluate::predicted_position::predicted_position;
use crate::identify::estimate::identify_with;
use crate::identify::held_test::held_frame_test;
use crate::identify::result::{FitOptions, Strategy, StrategyResult};
use crate::identify::shared_estimate::identify_shared;
use crate::identify::trust::implausible_estimates;
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::report::{AccuracyMaps, RealValues, Report};
use crate::solver::SolverKind;

/// Simulates the model's experiment as `settings.simulation` says and identifies it: the
/// report knows the real parameters, so it holds the parameter errors and, with
/// `settings.map`, the accuracy maps. The fits expect the declared noise times the
/// simulation's noise scale.
///
/// # Errors
/// No `simulation` block, no reachable pose, or any error of [`identify`].
pub fn run<'m>(mechanism: &'m Mechanism, settings: &Settings) -> Result<Report<'m>> {
    if let Some(map) = settings.map {
        crate::evaluate::accuracy::map_grid(mechanism, map.grid_m, map.scale)?;
    }
    let simulated = simulate(mechanism, &settings.simulation)?;
    let fit = FitOptions {
        noise_scale: settings.simulation.options.noise_scale,
        ..settings.fit
    };
    let mut report = identify_all(
        mechanism,
        simulated.measurements,
        simulated.source,
        settings,
        fit,
    )?;
    if let Some(map) = settings.map {
        report.maps = Some(maps(&report, &simulated.real, map)?);
    }
    report.real = Some(simulated.real);
    Ok(report)
}

/// Identifies the mechanism from measured `data` (read with [`Measurements::read`], or made
/// in memory) as `settings` say.
///
/// # Errors
/// `settings.map` (the map needs the real parameters, known only in simulation), measurements
/// of the wrong kind for the model, an option the model's pipeline does not offer, or any
/// error of the identification (a leg without rows, a rank-deficient design naming the
/// parameters, a pose a leg cannot reach, a solver failure).
pub fn identify<'m>(
    mechanism: &'m Mechanism,
    data: &Measurements,
    settings: &Settings,
) -> Result<Report<'m>> {
    identify_owned(mechanism, data.clone(), settings)
}

/// As [`identify`], keeping `data` in the report without a copy (a file of a million rows
/// is a hundred megabytes of measurements).
///
/// # Errors
/// As [`identify`].
pub fn identify_owned<'m>(
    mechanism: &'m Mechanism,
    data: Measurements,
    settings: &Settings,
) -> Result<Report<'m>> {
    if settings.map.is_some() {
        return Err(Error::Invalid(
            "the accuracy map needs the real parameters, known only in simulation".into(),
        ));
    }
    let source = data
        .origin()
        .unwrap_or_else(|| "measurements given in memory".into());
    identify_all(mechanism, data, source, settings, settings.fit)
}

/// Every strategy of `settings` on `data`.
fn identify_all<'m>(
    mechanism: &'m Mechanism,
    data: Measurements,
    source: String,
    settings: &Settings,
    fit: FitOptions,
) -> Result<Report<'m>> {
    let results = settings
        .strategies_for(mechanism)
        .into_iter()
        .map(|strategy| identify_one(mechanism, &data, strategy, settings.solver, fit))
        .collect::<Result<Vec<_>>>()?;
    Ok(Report {
        mechanism,
        source,
        measurements: data,
        real: None,
        results,
        maps: None,
    })
}

/// One strategy on `data`, by the pipeline the measurements' kind calls for: readings at
/// measured poses by [`identify_with`], targets through the instrument by
/// [`identify_shared`] (with the held-frame test for the joint strategy).
///
/// # Errors
/// Measurements of the other kind than the model's, a strategy or option the pipeline does
/// not offer, or the identification's error.
pub fn identify_one(
    mechanism: &Mechanism,
    data: &Measurements,
    strategy: Strategy,
    solver: SolverKind,
    fit: FitOptions,
) -> Result<StrategyResult> {
    let mut result = identify_by_kind(mechanism, data, strategy, solver, fit)?;
    // Estimates the model would refuse are the result's warnings too (the verdict names them:
    // `Report::trust_issues`).
    let implausible = implausible_estimates(mechanism, &result);
    result.warnings.extend(implausible);
    Ok(result)
}

/// [`identify_one`] before the plausibility of its estimates is judged.
fn identify_by_kind(
    mechanism: &Mechanism,
    data: &Measurements,
    strategy: Strategy,
    solver: SolverKind,
    fit: FitOptions,
) -> Result<StrategyResult> {
    match data {
        Measurements::Readings(set) => {
            if mechanism.instrument.is_some() {
                return Err(Measurements::poses_for_an_instrument(mechanism));
            }
            identify_with(mechanism, set, strategy, solver, fit)
        }
        Measurements::Targets(observations) => {
            if solver != SolverKind::LevenbergMarquardt {
                return Err(Error::Invalid(format!(
                    "{}: through an instrument the legs and the instrument are identified by \
                     Levenberg-Marquardt, weighted by the declared noise or not (`--weights`), \
                     with a robust loss or outlier dropping, not by Gauss-Newton",
                    mechanism.model_path.display()
                )));
            }
            let mut result = identify_shared(mechanism, observations, strategy, fit)?;
            if strategy == Strategy::Joint {
                let test = match unseen_frame(mechanism) {
                    // Freed, a frame component the observations cannot see leaves the problem
                    // rank-deficient: there is nothing to test.
                    true => None,
                    false => held_frame_test(mechanism, observations, &result),
                };
                let predicted = predicted_position(mechanism, &result);
                if let Some(instrument) = result.instrument.as_mut() {
                    instrument.held_frame = test;
                    instrument.predicted_position = predicted;
                }
            }
            Ok(result)
        }
    }
}

/// Seen through the forward kinematics, is there a motion of the instrument frame its first
/// target's reported coordinates cannot see (a bed's motion along its own plane under a height
/// probe; tested at the home pose and the nominal frame)?
fn unseen_frame(mechanism: &Mechanism) -> bool {
    let Some(instrument) = mechanism.forward_instrument() else {
        return false;
    };
    let nominal = instrument.nominal();
    !crate::evaluate::observed_frame::unseen_frame(instrument, &nominal, &[mechanism.home_pose])
        .is_empty()
}

/// The accuracy map of the nominal model, then of each result, against the `real` legs (the
/// instrument only measures: the maps compare the legs; seen through the forward kinematics,
/// each map also gives the error in the frame the observations define, against the real
/// instrument).
fn maps(report: &Report<'_>, real: &RealValues, settings: MapSettings) -> Result<AccuracyMaps> {
    let mechanism = report.mechanism;
    let range = (settings.grid_m, settings.scale);
    let nominal = mechanism.nominal_parameters();
    let nominal_shared = mechanism.instrument.as_ref().map(|i| i.nominal());
    let real_seen = (real.legs.as_slice(), real.instrument.as_deref());
    let before = accuracy_map_seen(
        mechanism,
        (&nominal, nominal_shared.as_deref()),
        real_seen,
        range,
        "map before",
    )?;
    let after = report
        .results
        .iter()
        .map(|result| {
            let label = format!("map after, {}", result.strategy.name());
            let parameters = result_parameters(mechanism, result);
            let shared: Option<Vec<f64>> = result
                .instrument
                .as_ref()
                .map(|i| i.parameters.iter().map(|p| p.estimate).collect());
            accuracy_map_seen(
                mechanism,
                (&parameters, shared.as_deref()),
                real_seen,
                range,
                &label,
            )
        })
        .collect::<Result<_>>()?;
    Ok(AccuracyMaps { before, after })
}
