//! One solve of an identification problem, and why a fit fails: the solver from a start,
//! skipped when the start is already the least-squares minimiser (a solver started at its
//! answer may find no step to take and call that a stall).

use nalgebra::{DMatrix, DVector};

use super::problem::{BlockError, IdentificationProblem};
use crate::solver::qr_step::qr_step;
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
    // The Jacobian goes into the factorisation and is not kept through the solve (a large
    // problem's is tens of megabytes); asked for again (kept by the problem) if the QR hands
    // it to the SVD.
    let again = || problem.residuals_and_jacobian(x0).ok().map(|(_, c)| c);
    let minimal = already_minimal(x0, &r0, c0, again);
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
/// The step `C⁺r` is solved by Householder QR where `C` is well conditioned
/// ([`qr_step`]); otherwise (`C` asked for again from `again`) as `V Σ⁻² Vᵀ (Cᵀr)` from the
/// SVD (singular values up to machine epsilon count as zero), without its `m × n` factor `U`
/// (a large problem's Jacobian is tens of megabytes).
fn already_minimal(
    x0: &DVector<f64>,
    r0: &DVector<f64>,
    c0: DMatrix<f64>,
    again: impl FnOnce() -> Option<DMatrix<f64>>,
) -> Option<SolverOutcome> {
    let step = match qr_step(c0, r0) {
        Some(step) => step,
        None => svd_step(again()?, r0)?,
    };
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

/// `C⁺r` as `V Σ⁻² Vᵀ (Cᵀr)` from the SVD of `c` without `U` (singular values up to machine
/// epsilon count as zero).
fn svd_step(c: DMatrix<f64>, r: &DVector<f64>) -> Option<DVector<f64>> {
    let gradient = c.tr_mul(r);
    let svd = c.svd(false, true);
    let v_t = svd.v_t?;
    let mut projected = &v_t * gradient;
    for (value, &s) in projected.iter_mut().zip(svd.singular_values.iter()) {
        *value = if s > f64::EPSILON {
            *value / (s * s)
        } else {
            0.0
        };
    }
    Some(v_t.tr_mul(&projected))
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::{already_minimal, STATIONARY_STEP};

    /// With C = I the Gauss–Newton step is r itself, so its length is set exactly: at
    /// ‖x₀‖ = 3 the start is already the minimiser for a step up to 1e-12 · (3 + 1) = 4e-12,
    /// and not beyond. Each side is checked 2.5 % from the bound.
    #[test]
    fn the_start_is_minimal_below_a_step_relative_to_the_parameters() {
        let x0 = DVector::from_vec(vec![0.0, 3.0, 0.0]);
        let bound = STATIONARY_STEP * (3.0 + 1.0);
        let along = |length: f64| DVector::from_vec(vec![length * 0.6, 0.0, length * 0.8]);
        let minimal = |length: f64| {
            let identity = || Some(DMatrix::identity(3, 3));
            already_minimal(&x0, &along(length), DMatrix::identity(3, 3), identity)
        };
        let below = minimal(0.975 * bound).expect("a step below the bound");
        assert_eq!(below.x, x0);
        assert_eq!(below.iterations, 0);
        assert!(below.converged);
        assert!(minimal(1.025 * bound).is_none());
        // A zero start keeps an absolute bound of 1e-12.
        let origin = DVector::zeros(3);
        let at_origin = |length: f64| {
            let identity = || Some(DMatrix::identity(3, 3));
            already_minimal(&origin, &along(length), DMatrix::identity(3, 3), identity).is_some()
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
            already_minimal(&x0, &r, c.clone(), || Some(c.clone())).is_some()
        };
        assert!(minimal(0.975 * bound));
        assert!(!minimal(1.025 * bound));
        // A large step is far from minimal.
        assert!(!minimal(1.0));
    }
}
