//! One problem fitted as [`FitOptions`] ask: plain least squares, weighted by the declared
//! noise, or with a robust loss (iteratively reweighted, [`super::robust`]). The result carries
//! the problem as finally weighted, so its residuals, Jacobian and statistics match the fit.

use nalgebra::{DMatrix, DVector};

use super::problem::{BlockError, IdentificationProblem};
use super::result::{FitOptions, Weighting};
use super::robust::{self, RobustError};
use super::statistics::{row_variances, FitKind};
use crate::model::mechanism::MeasurementNoise;
use crate::solver::{solve, SolverKind, SolverOutcome, StopReason};

/// Why a fit failed.
#[derive(Debug)]
pub(super) enum FitError {
    /// A residual block could not be evaluated.
    Block(BlockError),
    /// The solver failed (its message).
    Solver(String),
    /// The option (named) needs a declared, non-zero noise.
    NeedsNoise(String),
}

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
    let weighted = match (options.weights, options.robust) {
        (Weighting::Noise, None) => {
            let noise = noise.ok_or_else(|| needs_noise("--weights noise"))?;
            let variances = row_variances(problem, x0, noise).map_err(FitError::Block)?;
            let weights = inverse(&variances).ok_or_else(|| {
                needs_noise("--weights noise (a row's expected residual variance is zero)")
            })?;
            problem.clone().with_weights(&weights)
        }
        _ => problem.unweighted(),
    };
    let outcome = solve_from(&weighted, x0, solver)?;
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

/// `1 / v` for every variance, if all are positive and finite.
fn inverse(variances: &[f64]) -> Option<Vec<f64>> {
    variances
        .iter()
        .map(|&v| (v > 0.0 && v.is_finite()).then(|| 1.0 / v))
        .collect()
}

/// Solves `problem` from `x0`, unless `x0` is already its minimiser ([`already_minimal`]): a
/// solver started at its answer may find no step to take and call that a stall.
///
/// # Errors
/// A block out of reach at `x0`, or the solver's failure.
pub(super) fn solve_from(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    solver: SolverKind,
) -> Result<SolverOutcome, FitError> {
    let (r0, c0) = problem
        .residuals_and_jacobian(x0)
        .map_err(FitError::Block)?;
    // The Jacobian goes into the SVD and is not kept through the solve (a large problem's is
    // tens of megabytes).
    let minimal = already_minimal(x0, &r0, c0);
    match minimal {
        Some(outcome) => Ok(outcome),
        None => solve(problem, x0.clone(), solver).map_err(|e| FitError::Solver(e.to_string())),
    }
}

/// Relative length of the Gauss–Newton step below which the start is already the minimiser.
const STATIONARY_STEP: f64 = 1e-12;

/// The outcome of a solve that is not needed: `x0` is already the least-squares minimiser (its
/// Gauss–Newton step, solved by SVD, is shorter than [`STATIONARY_STEP`]`·(‖x0‖ + 1)`), e.g.
/// when identifying again from a calibrated model on the same measurements.
///
/// The step `C⁺r = V Σ⁻¹ Uᵀr` is taken as `V Σ⁻² Vᵀ (Cᵀr)` (singular values up to machine
/// epsilon count as zero), without the SVD's `m × n` factor `U` (a large problem's Jacobian is
/// tens of megabytes).
fn already_minimal(
    x0: &DVector<f64>,
    r0: &DVector<f64>,
    c0: DMatrix<f64>,
) -> Option<SolverOutcome> {
    let gradient = c0.tr_mul(r0);
    let svd = c0.svd(false, true);
    let v_t = svd.v_t?;
    let mut projected = &v_t * gradient;
    for (value, &s) in projected.iter_mut().zip(svd.singular_values.iter()) {
        *value = if s > f64::EPSILON {
            *value / (s * s)
        } else {
            0.0
        };
    }
    let step = v_t.tr_mul(&projected);
    let length = step.norm();
    (length.is_finite() && length <= STATIONARY_STEP * (x0.norm() + 1.0)).then(|| SolverOutcome {
        x: x0.clone(),
        iterations: 0,
        converged: true,
        stop_reason: StopReason::StepSize,
        refinement_steps: 0,
        residual_evaluations: 1,
        jacobian_evaluations: 1,
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::{already_minimal, inverse, STATIONARY_STEP};

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

    /// With C = I the Gauss–Newton step is r itself, so its length is set exactly: at
    /// ‖x₀‖ = 3 the start is already the minimiser for a step up to 1e-12 · (3 + 1) = 4e-12,
    /// and not beyond. Each side is checked 2.5 % from the bound.
    #[test]
    fn the_start_is_minimal_below_a_step_relative_to_the_parameters() {
        let x0 = DVector::from_vec(vec![0.0, 3.0, 0.0]);
        let bound = STATIONARY_STEP * (3.0 + 1.0);
        let along = |length: f64| DVector::from_vec(vec![length * 0.6, 0.0, length * 0.8]);
        let minimal = |length: f64| already_minimal(&x0, &along(length), DMatrix::identity(3, 3));
        let below = minimal(0.975 * bound).expect("a step below the bound");
        assert_eq!(below.x, x0);
        assert_eq!(below.iterations, 0);
        assert!(below.converged);
        assert!(minimal(1.025 * bound).is_none());
        // A zero start keeps an absolute bound of 1e-12.
        let origin = DVector::zeros(3);
        let at_origin = |length: f64| {
            already_minimal(&origin, &along(length), DMatrix::identity(3, 3)).is_some()
        };
        assert!(at_origin(0.975 * STATIONARY_STEP));
        assert!(!at_origin(1.025 * STATIONARY_STEP));
    }

    /// With a consistent `r = C s` the Gauss–Newton step is `s` itself whatever `C` (here
    /// non-orthogonal, with singular values far apart): the step taken without `U` is the
    /// least-squares solution, not a scaled one.
    #[test]
    fn the_step_of_a_general_jacobian_is_its_least_squares_solution() {
        let c = DMatrix::from_row_slice(
            4,
            3,
            &[20.0, 1.0, 0.0, 0.0, 0.5, 0.3, 1.0, 0.0, 0.01, 2.0, 2.0, 2.0],
        );
        let x0 = DVector::from_vec(vec![0.0, 3.0, 0.0]);
        let bound = STATIONARY_STEP * (3.0 + 1.0);
        let direction = DVector::from_vec(vec![0.48, -0.6, 0.64]);
        let minimal = |length: f64| {
            let r = &c * (&direction * length);
            already_minimal(&x0, &r, c.clone()).is_some()
        };
        assert!(minimal(0.975 * bound));
        assert!(!minimal(1.025 * bound));
        // A large step is far from minimal.
        assert!(!minimal(1.0));
    }
}
