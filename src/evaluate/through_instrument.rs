//! How well a model with an `instrument` block explains measurements through its instrument
//! (target coordinates in the instrument frame and readings), typically held out of the fit.
//!
//! At every row holding all actuator readings, the model's forward kinematics from the readings
//! (home assembly mode kept) gives the platform pose; the model's instrument (its frame and
//! target offsets, [`observe`]) says where the instrument would see each target there; the
//! error is the distance to where the instrument saw it (and, for a target whose pose it
//! measures, the angle between the orientations). This is what a user checks: where the model
//! says the target is, against where the instrument saw it. Each leg's reading residual is
//! taken at the platform pose fitted from the row's targets with the model's instrument
//! ([`platform_pose`]); seen through the forward kinematics (`instrument.kinematics: forward`),
//! whose targets do not give the pose, at the rows of a measured pose only (`instrument.poses`).

use super::accuracy::{orientation_error, position_error, ErrorStats};
use super::held_out::{
    no_full_row, reading_residuals, summarised, Evaluation, ResidualRow, RowPoseError, TargetErrors,
};
use crate::error::Result;
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::observations::{instrument_of, Observations};
use crate::measure::targets::{observe, platform_pose, target_position};
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// A target's reported coordinates (named `names`: `x`, `y`, `yaw`, …) as a pose
/// `[x, y, z, roll, pitch, yaw]`, the coordinates not reported at zero.
fn as_pose(names: &[&str], values: &[f64]) -> [f64; 6] {
    let mut pose = [0.0; 6];
    for (name, &value) in names.iter().zip(values) {
        if let Some(c) = COORDINATES.iter().position(|c| c == name) {
            pose[c] = value;
        }
    }
    pose
}

/// Evaluates the model `mechanism` (its nominal legs, frame and target offsets: a calibrated
/// model's identified values) on the instrument measurements `data`.
///
/// # Errors
/// [`crate::error::Error::Model`] if the model has no instrument;
/// [`crate::error::Error::Measurement`] if no row holds every actuator reading.
pub fn evaluate_observed(mechanism: &Mechanism, data: &Observations) -> Result<Evaluation> {
    let instrument = instrument_of(mechanism)?;
    data.check_distances()?;
    let params = mechanism.nominal_parameters();
    let shared = instrument.nominal();
    let line = |index: usize| data.rows[index].line.unwrap_or(index + 2);
    // Rows with every reading and the targets' coordinates (not a row only distances use).
    let full: Vec<usize> = (0..data.rows.len())
        .filter(|&i| data.rows[i].readings.iter().all(Option::is_some))
        .filter(|&i| !data.rows[i].observed.is_empty())
        .collect();
    if full.is_empty() {
        return Err(no_full_row(mechanism, data.source.as_deref()));
    }
    let kinematics = ForwardKinematics::new(mechanism, &params);
    // Every row with all its readings closed once (distances join rows without coordinates).
    let reached: Vec<Option<[f64; 6]>> = data
        .rows
        .iter()
        .map(|row| {
            let readings: Option<Vec<f64>> = row.readings.iter().copied().collect();
            readings.and_then(|r| kinematics.solve(&r).ok())
        })
        .collect();
    let mut row_errors = Vec::new();
    let mut non_assemblable = Vec::new();
    let mut per_target: Vec<(Vec<f64>, Vec<f64>)> =
        vec![(Vec::new(), Vec::new()); instrument.targets.len()];
    for &i in &full {
        let row = &data.rows[i];
        if reached[i].is_none() {
            non_assemblable.push(line(i));
        }
        let predicted = reached[i].map(|pose| observe(instrument, &shared, &pose));
        let mut at = 0;
        for (k, target) in instrument.targets.iter().enumerate() {
            let names = target.coordinates();
            let seen = as_pose(names, &row.observed[at..at + names.len()]);
            let model = predicted
                .as_ref()
                .map(|p| as_pose(names, &p[at..at + names.len()]));
            at += names.len();
            let position = model.map(|m| position_error(&m, &seen));
            let orientation = model
                .filter(|_| names.iter().any(|n| COORDINATES[3..].contains(n)))
                .map(|m| orientation_error(&m, &seen));
            per_target[k].0.extend(position);
            per_target[k].1.extend(orientation);
            row_errors.push(RowPoseError {
                line: line(i),
                position_error: position,
                orientation_error: orientation,
                target: Some(k),
            });
        }
    }
    let home = &mechanism.home_pose;
    // Seen through the forward kinematics, the targets do not give the pose: the reading
    // residuals are those of the rows of a measured pose only.
    let fitted: Vec<ResidualRow<'_>> = data
        .rows
        .iter()
        .enumerate()
        .filter_map(|(i, row)| {
            let pose = match (instrument.forward, row.pose) {
                (false, _) => platform_pose::<f64>(instrument, &shared, &row.observed, home),
                (true, Some(pose)) => pose,
                (true, None) => return None,
            };
            Some(ResidualRow {
                line: line(i),
                readings: &row.readings,
                pose,
            })
        })
        .collect();
    let reading_residual = reading_residuals(mechanism, &params, &fitted);
    let targets = instrument
        .targets
        .iter()
        .zip(per_target)
        .map(|(target, (position, orientation))| TargetErrors {
            name: target.name.clone(),
            position_error: ErrorStats::of(&position),
            orientation_error: ErrorStats::of(&orientation),
        })
        .collect();
    let mut evaluation = summarised(
        mechanism,
        data.source.as_deref(),
        data.rows.len(),
        (row_errors, non_assemblable),
        reading_residual,
        targets,
    );
    if let Some(distances) = &instrument.distances {
        let errors: Vec<f64> = data
            .distances
            .iter()
            .filter_map(|d| {
                let [a, b] = d.rows.map(|r| {
                    reached[r]
                        .map(|pose| target_position(instrument, &shared, distances.target, &pose))
                });
                let (a, b) = (a?, b?);
                let length = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
                Some((length - d.value).abs())
            })
            .collect();
        evaluation.distance_error = ErrorStats::of(&errors);
        evaluation.distances = data.distances.len();
    }
    Ok(evaluation)
}
