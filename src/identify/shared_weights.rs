//! The joint fit through an instrument weighted by the declared noise (docs/statistics.md,
//! "Weights"): generalised least squares on the residuals' variances, each residual by the
//! inverse of its expected variance under the declared noise (`V`'s diagonal,
//! [`IdentificationProblem::row_variances`]: a height by the probe's σ, a distance by its own,
//! a measured pose's rows by the pose and reading noise), evaluated at the estimate: weights at
//! the start, a fit, then weights at the estimate and a fit from it until they agree. The
//! covariance of the weighted estimate is the sandwich of [`super::sandwich`] on the weighted
//! rows ([`super::sandwich::NoiseLoadings::scaled`]), which holds whatever correlation `V` has beyond its
//! diagonal.

use nalgebra::DVector;

use super::problem::IdentificationProblem;
use crate::model::mechanism::MeasurementNoise;
use crate::solver::{solve_bordered, SolverOutcome};

/// Most fits of [`weighted_joint_fit`].
const MAX_WEIGHTINGS: usize = 20;

/// Largest relative change of a residual's weight between two fits at which the weights are
/// consistent with the estimate.
const WEIGHT_TOLERANCE: f64 = 1e-12;

/// A joint fit weighted by the declared noise: its outcome (the iterations and evaluations of
/// every fit), and `√w` of every residual (the weights the estimate minimises).
#[derive(Debug, Clone)]
pub struct WeightedFit {
    /// The last fit's outcome, with every fit's iterations and evaluations.
    pub outcome: SolverOutcome,
    /// `√w_i` per residual, in the problem's row order.
    pub scales: Vec<f64>,
}

/// `1 / v` for every variance, if all are positive and finite.
fn inverse(variances: &[f64]) -> Option<Vec<f64>> {
    variances
        .iter()
        .map(|&v| (v > 0.0 && v.is_finite()).then(|| 1.0 / v))
        .collect()
}

/// The joint fit of `problem` (unweighted, as built) from `x0` weighted by `noise`, each
/// weight times `mask[i]` when given (0 leaves a dropped row out); `Ok(None)` when a
/// residual's expected variance is zero (nothing to weight it by: the caller fits unweighted
/// and says so).
///
/// # Errors
/// The variances cannot be evaluated, or the solver's error, as text.
pub fn weighted_joint_fit(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    noise: &MeasurementNoise,
    mask: Option<&[f64]>,
) -> Result<Option<WeightedFit>, String> {
    let weights_at = |x: &DVector<f64>| -> Result<Option<Vec<f64>>, String> {
        let variances = problem.row_variances(x, noise).map_err(|e| e.to_string())?;
        Ok(inverse(&variances).map(|w| match mask {
            Some(mask) => w.iter().zip(mask).map(|(w, m)| w * m).collect(),
            None => w,
        }))
    };
    let Some(mut weights) = weights_at(x0)? else {
        return Ok(None);
    };
    let fit = |weights: &[f64], from: &DVector<f64>| {
        let weighted = problem.clone().with_weights(weights);
        solve_bordered(&weighted, from.clone()).map_err(|e| e.to_string())
    };
    let mut outcome = fit(&weights, x0)?;
    let (mut iterations, mut residuals, mut jacobians) = (0, 0, 0);
    for _ in 1..MAX_WEIGHTINGS {
        let Some(next) = weights_at(&outcome.x)? else {
            return Ok(None);
        };
        let change = next
            .iter()
            .zip(&weights)
            .filter(|(_, b)| **b > 0.0)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0, f64::max);
        if change <= WEIGHT_TOLERANCE {
            break;
        }
        iterations += outcome.iterations;
        residuals += outcome.residual_evaluations;
        jacobians += outcome.jacobian_evaluations;
        weights = next;
        outcome = fit(&weights, &outcome.x)?;
    }
    outcome.iterations += iterations;
    outcome.residual_evaluations += residuals;
    outcome.jacobian_evaluations += jacobians;
    Ok(Some(WeightedFit {
        outcome,
        scales: weights.iter().map(|w| w.sqrt()).collect(),
    }))
}
