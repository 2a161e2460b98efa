//! How well a calibration seen through the forward kinematics knows where its target goes:
//! the fit's covariance propagated to the first target's position over the workspace.
//!
//! At a grid pose the calibrated model's inverse kinematics gives the readings a controller
//! would command; the target's position in the instrument frame at those readings moves with
//! the unknowns as the forward rows' prediction does (the implicit-function derivatives of
//! `problem/forward.rs`, here for all its coordinates, reported or not), so its covariance is
//! `J_i C J_iᵀ` (`C` the fit's covariance) and its σ the square root of the trace. As the
//! map's error in the frame the observations define ([`super::observed_frame`]), the motions
//! of the frame the observations cannot see (at the estimated frame) are projected out first
//! (over the whole grid at once): the prediction is of that error.

use nalgebra::{DMatrix, DVector};

use super::accuracy::map_slice;
use super::commanded_rows::commanded_rows;
use super::observed_frame::unseen_frame;
use crate::identify::problem::IdentificationProblem;
use crate::identify::result::{PredictedPosition, StrategyResult};
use crate::measure::forward_simulate::home_side;
use crate::model::instrument::{Instrument, Measures};
use crate::model::Mechanism;

/// Fraction of the workspace region the prediction covers (as the accuracy map's default).
const SCALE: f64 = 0.95;

/// The predicted σ of the first target's position over the model's workspace
/// ([`prediction_poses`] at `workspace.grid`) for `result`, a joint fit through a forward instrument with its
/// covariance; `None` otherwise, without a `workspace.grid`, or when no grid point is
/// reachable.
pub fn predicted_position(
    mechanism: &Mechanism,
    result: &StrategyResult,
) -> Option<PredictedPosition> {
    let estimate = result.instrument.as_ref()?;
    let covariance = estimate.covariance.as_ref()?;
    let params = crate::evaluate::accuracy::result_parameters(mechanism, result);
    let shared: Vec<f64> = estimate.parameters.iter().map(|p| p.estimate).collect();
    let named: Vec<(&str, f64)> = result
        .parameters()
        .map(|p| (p.name.as_str(), p.estimate))
        .collect();
    predicted_position_of(mechanism, (&params, &shared), &named, covariance)
}

/// [`predicted_position`] of an estimate given as every leg's parameters and every shared
/// parameter (`estimate`), the problem's unknowns by name (`named`: at least those `mechanism`
/// identifies, legs in model order then the instrument's) and their `covariance`, in the
/// order of the problem of `mechanism` through its instrument.
pub fn predicted_position_of(
    mechanism: &Mechanism,
    (params, shared): (&[Vec<f64>], &[f64]),
    named: &[(&str, f64)],
    covariance: &DMatrix<f64>,
) -> Option<PredictedPosition> {
    let instrument = mechanism.forward_instrument()?;
    // Every target reports its whole position: the first one's rows are the first three.
    let every = if instrument.spatial { 0b111 } else { 0b011 };
    let seen = mechanism.edited(|parts| {
        if let Some(instrument) = parts.instrument.as_mut() {
            for target in &mut instrument.targets {
                target.measures = Measures::Coordinates(every);
            }
            instrument.distances = None;
        }
    });
    let grid = prediction_poses(mechanism, instrument, mechanism.workspace.grid?)?;
    let width = seen.instrument.as_ref()?.observed_len();
    // The grid poses every leg reaches, the readings the model commands there and the
    // configuration it reaches (where each row's forward kinematics then closes at once).
    let (poses, observations, configurations) = commanded_rows(mechanism, params, &grid, width);
    if poses.is_empty() {
        return None;
    }
    let problem = IdentificationProblem::through_instrument(&seen, &observations).ok()?;
    let x = unknowns(&problem, named)?;
    problem.close_forward_rows_at(&x, configurations);
    if covariance.nrows() != x.len() {
        return None;
    }
    let (_, jacobian) = problem.residuals_and_jacobian(&x).ok()?;
    let points = poses.len();
    // The first target's rows, with the motions its observations cannot see projected out.
    let mut target = DMatrix::from_fn(3 * points, x.len(), |r, j| {
        jacobian[((r / 3) * width + r % 3, j)]
    });
    let unseen = unseen_frame(instrument, shared, &poses);
    unseen.project_out(&mut target);
    let sigmas: Vec<f64> = (0..points)
        .map(|i| {
            let block = target.rows(3 * i, 3).into_owned();
            (&block * covariance * block.transpose())
                .trace()
                .max(0.0)
                .sqrt()
        })
        .collect();
    let rms = (sigmas.iter().map(|s| s * s).sum::<f64>() / points as f64).sqrt();
    Some(PredictedPosition {
        target: instrument.targets[0].name.clone(),
        points,
        rms,
        max: sigmas.iter().copied().fold(0.0, f64::max),
        tolerance: instrument.tolerance,
    })
}

/// The poses the prediction is taken over: the accuracy map's lattice (spacing `grid`, 0.95 of
/// the region) on every horizontal slice of a spatial region at the same spacing, centred on
/// the region's middle height (one slice at home for a planar region), the orientation at
/// home, where every touching target is on home's side of its touch surface (the nominal
/// one: above the bed). `None` when no pose is left.
fn prediction_poses(
    mechanism: &Mechanism,
    instrument: &Instrument,
    grid: f64,
) -> Option<Vec<[f64; 6]>> {
    let levels = slice_levels(
        mechanism.workspace.region.z_bounds(),
        mechanism.home_pose[2],
        grid,
    );
    let nominal = instrument.nominal();
    let clear = home_side(mechanism, instrument, &nominal);
    let mut poses = Vec::new();
    for level in levels {
        if let Ok(slice) = map_slice(mechanism, grid, SCALE, level) {
            poses.extend(slice.into_iter().filter(|p| clear(p)));
        }
    }
    (!poses.is_empty()).then_some(poses)
}

/// The heights of the slices the prediction is taken on, each with the height in the region
/// whose section it samples (the lattice is the section's, shrunk to [`SCALE`] about the
/// region's middle): the spacing `grid` within the shrunk height `bounds`, centred on its
/// middle; one slice at `home` for a planar region (`None`).
fn slice_levels(bounds: Option<[f64; 2]>, home: f64, grid: f64) -> Vec<(f64, f64)> {
    let Some([lo, hi]) = bounds else {
        return vec![(home, home)];
    };
    let middle = (lo + hi) / 2.0;
    let count = spacings_within((hi - lo) * SCALE, grid) as f64;
    (0..=count as usize)
        .map(|k| {
            let z = middle + (k as f64 - count / 2.0) * grid;
            (z, middle + (z - middle) / SCALE)
        })
        .collect()
}

/// Whole spacings `grid` within `span`, a span that is a whole number of them counting as one
/// even where its division rounds just below (0.3 · 0.95 / 0.0285 is 9.999999999999998).
fn spacings_within(span: f64, grid: f64) -> usize {
    (span / grid + 1e-9).floor() as usize
}

/// The estimate as the problem's unknowns (by name).
fn unknowns(problem: &IdentificationProblem<'_>, named: &[(&str, f64)]) -> Option<DVector<f64>> {
    let values = problem
        .names()
        .iter()
        .map(|name| named.iter().find(|(n, _)| n == name).map(|(_, v)| *v))
        .collect::<Option<Vec<f64>>>()?;
    Some(DVector::from_vec(values))
}

#[cfg(test)]
mod tests {
    use super::{slice_levels, spacings_within};

    /// A region 0.1 m high from z = 0.02 m at a 0.02 m grid: 0.095 m shrunk, four spacings,
    /// five slices about 0.07 m; each samples the region's section at its height scaled back
    /// out from the middle (0.03 m samples 0.07 − 0.04 / 0.95).
    #[test]
    fn slices_are_centred_and_sample_the_unshrunk_section() {
        let levels = slice_levels(Some([0.02, 0.12]), 0.3, 0.02);
        let expected = [0.03, 0.05, 0.07, 0.09, 0.11];
        assert_eq!(levels.len(), 5, "{levels:?}");
        for ((z, section), e) in levels.iter().zip(expected) {
            assert!((z - e).abs() < 1e-15, "{levels:?}");
            let scaled = 0.07 + (e - 0.07) / 0.95;
            assert!((section - scaled).abs() < 1e-15, "{levels:?}");
        }
        assert_eq!(slice_levels(None, 0.3, 0.02), [(0.3, 0.3)]);
    }

    #[test]
    fn a_whole_number_of_spacings_survives_rounding() {
        assert_eq!(spacings_within(0.3 * 0.95, 0.0285), 10);
        assert_eq!(spacings_within(0.3 * 0.95, 0.057), 5);
        assert_eq!(spacings_within(0.1 * 0.95, 0.02), 4);
        assert_eq!(spacings_within(0.01, 0.02), 0);
    }
}
