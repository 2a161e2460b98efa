//! One problem fitted as [`FitOptions`] ask: plain least squares, weighted by the declared
//! noise, or with a robust loss (iteratively reweighted, [`super::robust`]). The result carries
//! the problem as finally weighted, so its residuals, Jacobian and statistics match the fit.

use nalgebra::DVector;

use super::problem::IdentificationProblem;
use super::result::{FitOptions, Weighting};
use super::robust::{self, RobustError};
use super::solve_from::{solve_from, FitError};
use super::statistics::{row_variances, FitKind};
use crate::model::mechanism::MeasurementNoise;
use crate::solver::qr_step::qr_step;
use crate::solver::{SolverKind, SolverOutcome};

/// A fitted problem.
pub(super) struct Fitted<'a> {
    /// The problem with the weights of the fit (none, the noise's, or the final robust ones).
    pub(super) problem: IdentificationProblem<'a>,
    /// The solver's outcome (of the last weighted solve for a robust fit), at the estimate.
    pub(super) outcome: SolverOutcome,
    /// Least squares or robust.
    pub(super) kind: FitKind,
}

/// Fits `problem` from `x0` with `solver` as `options` ask; `noise` is the declared noise (only
/// if some σ is non-zero).
pub(super) fn fit<'a>(
    problem: &IdentificationProblem<'a>,
    x0: &DVector<f64>,
    solver: SolverKind,
    options: FitOptions,
    noise: Option<&MeasurementNoise>,
) -> Result<Fitted<'a>, FitError> {
    let needs_noise = |what: &str| FitError::NeedsNoise(what.to_string());
    let (weighted, outcome) = match (options.weights, options.robust) {
        (Weighting::Noise, None) => {
            let noise = noise.ok_or_else(|| needs_noise("--weights noise"))?;
            consistent_weights(problem, x0, solver, noise)?
        }
        _ => {
            let plain = problem.unweighted();
            let outcome = solve_from(&plain, x0, solver)?;
            (plain, outcome)
        }
    };
    let Some(loss) = options.robust else {
        return Ok(Fitted {
            problem: weighted,
            outcome,
            kind: FitKind::LeastSquares,
        });
    };
    let option = format!("--robust {}", loss.name());
    let noise = noise.ok_or_else(|| needs_noise(&option))?;
    let variances = row_variances(problem, &outcome.x, noise).map_err(FitError::Block)?;
    let sigma: Vec<f64> = inverse(&variances)
        .ok_or_else(|| {
            needs_noise(&format!(
                "{option} (a row's expected residual variance is zero)"
            ))
        })?
        .iter()
        .map(|w| 1.0 / w.sqrt())
        .collect();
    let robust = robust::fit(problem, &outcome.x, loss, &sigma, solver).map_err(|e| match e {
        RobustError::Block(e) => FitError::Block(e),
        RobustError::Solver(message) => FitError::Solver(message),
    })?;
    let mut outcome = robust.outcome;
    outcome.x = robust.x;
    Ok(Fitted {
        problem: problem.clone().with_weights(&robust.weights),
        outcome,
        kind: FitKind::Robust,
    })
}

/// Most fits of [`consistent_weights`].
const MAX_WEIGHTINGS: usize = 20;

/// Largest relative change of a row's weight between two fits at which the weights are
/// consistent with the estimate.
const WEIGHT_TOLERANCE: f64 = 1e-12;

/// Relative change of the weights above which a reweighting round is one Gauss–Newton step
/// from the previous estimate ([`gauss_newton_step`]) rather than a full solve: far from the
/// consistent weights a round's minimiser is not the answer, only the way to it.
const STEP_ROUNDS_ABOVE: f64 = 1e-9;

/// Generalised least squares on the rows' variances under `noise`: weights at `x0`, a fit,
/// then weights at the estimate and a fit from it, until the weights change by at most
/// [`WEIGHT_TOLERANCE`] (relative) or after [`MAX_WEIGHTINGS`] fits. The weighted problem and
/// the last fit's outcome (its iterations and evaluations those of every fit).
///
/// While the weights still change by more than [`STEP_ROUNDS_ABOVE`], a round is one
/// Gauss–Newton step of the newly weighted problem from the previous estimate (kept if it
/// lowers that problem's cost; else the round is a full solve): the weights and the estimate
/// then converge together, one evaluation a round. Only a full solve ends it (after a step,
/// a full solve follows whatever the change), so the estimate is the same fixed point, found
/// by the same test.
fn consistent_weights<'a>(
    problem: &IdentificationProblem<'a>,
    x0: &DVector<f64>,
    solver: SolverKind,
    noise: &MeasurementNoise,
) -> Result<(IdentificationProblem<'a>, SolverOutcome), FitError> {
    let weights_at = |x: &DVector<f64>| -> Result<Vec<f64>, FitError> {
        let variances = row_variances(problem, x, noise).map_err(FitError::Block)?;
        inverse(&variances).ok_or_else(|| {
            FitError::NeedsNoise(
                "--weights noise (a row's expected residual variance is zero)".to_string(),
            )
        })
    };
    let mut weights = weights_at(x0)?;
    let mut weighted = problem.clone().with_weights(&weights);
    let mut outcome = solve_from(&weighted, x0, solver)?;
    let (mut iterations, mut residuals, mut jacobians) = (0, 0, 0);
    // Whether the estimate is a Gauss–Newton step's (then the weights' test does not end it).
    let mut stepped = false;
    for round in 1..MAX_WEIGHTINGS {
        let next = weights_at(&outcome.x)?;
        let change = next
            .iter()
            .zip(&weights)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0, f64::max);
        if change <= WEIGHT_TOLERANCE && !stepped {
            break;
        }
        iterations += outcome.iterations;
        residuals += outcome.residual_evaluations;
        jacobians += outcome.jacobian_evaluations;
        weights = next;
        weighted = problem.clone().with_weights(&weights);
        // The last rounds left are full solves, whatever the change.
        let stepping = change > STEP_ROUNDS_ABOVE && round + 2 < MAX_WEIGHTINGS;
        let step = match stepping {
            true => gauss_newton_step(&weighted, &outcome.x)?,
            false => None,
        };
        if let Some(x) = step {
            outcome.x = x;
            (outcome.iterations, outcome.refinement_steps) = (1, 0);
            (outcome.residual_evaluations, outcome.jacobian_evaluations) = (1, 1);
            stepped = true;
            continue;
        }
        stepped = false;
        let start = outcome.x.clone();
        outcome = solve_from(&weighted, &start, solver)?;
        // Already the minimiser: the weights at the estimate are the ones it was fitted with.
        if outcome.x == start {
            break;
        }
    }
    outcome.iterations += iterations;
    outcome.residual_evaluations += residuals;
    outcome.jacobian_evaluations += jacobians;
    Ok((weighted, outcome))
}

/// One Gauss–Newton step of `problem` from `x` (the step `C⁺r` by Householder QR, or from the
/// SVD of an ill-conditioned Jacobian without its `m × n` factor `U`), if it lowers the cost;
/// `None` if it does not, if the Jacobian is rank-deficient or a row cannot be solved at the
/// step's end (a full solve then handles the round).
///
/// # Errors
/// A block whose leg cannot reach its pose at `x`.
fn gauss_newton_step(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
) -> Result<Option<DVector<f64>>, FitError> {
    let (r, jacobian) = problem.residuals_and_jacobian(x).map_err(FitError::Block)?;
    // Householder QR where the Jacobian is well conditioned (the same step to round-off); the
    // SVD otherwise, on the Jacobian asked for again (kept by the problem).
    let step = match qr_step(jacobian, &r) {
        Some(step) => step,
        None => {
            let (_, jacobian) = problem.residuals_and_jacobian(x).map_err(FitError::Block)?;
            let gradient = jacobian.tr_mul(&r);
            let svd = jacobian.svd(false, true);
            let (Some(v_t), s) = (svd.v_t, &svd.singular_values) else {
                return Ok(None);
            };
            if s.iter().any(|&value| value <= f64::EPSILON * s.max()) {
                return Ok(None);
            }
            let mut projected = &v_t * gradient;
            for (value, &s) in projected.iter_mut().zip(s.iter()) {
                *value /= s * s;
            }
            v_t.tr_mul(&projected)
        }
    };
    let next = x - step;
    if !next.iter().all(|v| v.is_finite()) {
        return Ok(None);
    }
    let Ok(r_next) = problem.residuals(&next) else {
        return Ok(None);
    };
    // Lower, or the same to round-off: near the consistent weights the step and the cost's
    // decrease are at round-off, and a step refused on the cost's last bits costs a full solve.
    let (before, after) = (r.norm_squared(), r_next.norm_squared());
    Ok((after < before || after <= before * (1.0 + COST_ROUND_OFF)).then_some(next))
}

/// Relative rise of the cost a reweighting round's Gauss–Newton step may make and still be
/// taken: round-off of the cost (a sum of squares of `m` rows).
const COST_ROUND_OFF: f64 = 1e-12;

/// `1 / v` for every variance, if all are positive and finite.
pub(super) fn inverse(variances: &[f64]) -> Option<Vec<f64>> {
    variances
        .iter()
        .map(|&v| (v > 0.0 && v.is_finite()).then(|| 1.0 / v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::inverse;

    /// Weights are `1/v` only when every variance is a usable one: a zero variance (a row no
    /// declared noise reaches) or an infinite one must refuse the weighting, not give an
    /// infinite or a zero weight.
    #[test]
    fn only_positive_finite_variances_are_inverted() {
        assert_eq!(inverse(&[4.0, 0.5]), Some(vec![0.25, 2.0]));
        assert_eq!(inverse(&[4.0, 0.0]), None);
        assert_eq!(inverse(&[f64::INFINITY, 4.0]), None);
        assert_eq!(inverse(&[-1.0]), None);
        assert_eq!(inverse(&[f64::NAN]), None);
        assert_eq!(inverse(&[]), Some(vec![]));
    }
}
