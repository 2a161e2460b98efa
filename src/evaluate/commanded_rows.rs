//! Forward rows at known poses: the readings a model commands there, as the observations of a
//! forward problem, with the configurations it reaches (each row's forward kinematics then
//! closes there at once, [`IdentificationProblem::close_forward_rows_at`]). The predicted
//! position σ over a grid and the forward pose selection's candidates are such rows.
//!
//! [`IdentificationProblem::close_forward_rows_at`]:
//! crate::identify::problem::IdentificationProblem::close_forward_rows_at

use super::accuracy::commanded;
use crate::kinematics::platform::Configuration;
use crate::measure::observations::{Observations, ObservedRow};
use crate::model::Mechanism;

/// The rows of every pose of `poses` the model of parameters `params` reaches: the poses kept,
/// their rows (every leg's commanded reading, `width` target coordinates at zero) and the
/// configurations reached there.
pub(crate) fn commanded_rows(
    mechanism: &Mechanism,
    params: &[Vec<f64>],
    poses: &[[f64; 6]],
    width: usize,
) -> (Vec<[f64; 6]>, Observations, Vec<Configuration>) {
    let mut kept = Vec::new();
    let mut rows = Vec::new();
    let mut configurations = Vec::new();
    for (pose, command) in poses
        .iter()
        .zip(commanded(mechanism, params, poses, &mut Vec::new()))
    {
        let Some((readings, configuration)) = command else {
            continue;
        };
        kept.push(*pose);
        rows.push(ObservedRow {
            line: None,
            leg: None,
            observed: vec![0.0; width],
            readings: readings.into_iter().map(Some).collect(),
            id: None,
            pose: None,
        });
        configurations.push(configuration);
    }
    let observations = Observations {
        source: None,
        rows,
        distances: Vec::new(),
    };
    (kept, observations, configurations)
}
