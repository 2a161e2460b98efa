//! Each row's residual through a model seen by its instrument: where the model puts the
//! targets at the row's readings (forward kinematics, then the model's frame and offsets)
//! against what the instrument reported there, with the platform's place (x, y) to draw it at.
//! What an owner looks at without a truth to compare with: a probe's touches, above or below
//! where the model expects the bed.

use crate::error::Result;
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::observations::{instrument_of, Observations};
use crate::measure::targets::observe;
use crate::model::Mechanism;

/// One row's residual.
#[derive(Debug, Clone, PartialEq)]
pub struct RowResidual {
    /// Its line in the file (or its index + 2).
    pub line: usize,
    /// The platform's x, y at the row under the model (m).
    pub at: [f64; 2],
    /// Reported minus predicted, per reported coordinate (SI units).
    pub residual: Vec<f64>,
}

/// Every row of `data` holding all readings and some reported coordinates that the model
/// `mechanism` (its nominal values) assembles, with its residual.
///
/// # Errors
/// The model has no instrument.
pub fn row_residuals(mechanism: &Mechanism, data: &Observations) -> Result<Vec<RowResidual>> {
    let instrument = instrument_of(mechanism)?;
    let params = mechanism.nominal_parameters();
    let shared = instrument.nominal();
    let kinematics = ForwardKinematics::new(mechanism, &params);
    Ok(data
        .rows
        .iter()
        .enumerate()
        .filter(|(_, row)| !row.observed.is_empty())
        .filter_map(|(i, row)| {
            let readings: Vec<f64> = row.readings.iter().copied().collect::<Option<_>>()?;
            let pose = kinematics.solve(&readings).ok()?;
            let predicted = observe(instrument, &shared, &pose);
            Some(RowResidual {
                line: row.line.unwrap_or(i + 2),
                at: [pose[0], pose[1]],
                residual: row
                    .observed
                    .iter()
                    .zip(&predicted)
                    .map(|(seen, model)| seen - model)
                    .collect(),
            })
        })
        .collect())
}
