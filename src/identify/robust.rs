//! Robust losses (`--robust huber|cauchy`) by iteratively reweighted least squares, around an
//! [`IdentificationProblem`]: the solver stays a plain least-squares solver.
//!
//! A robust fit minimises `Σ ρ(u_i²)` over the standardised residuals `u_i = r_i / σ_i`, with
//! `σ_i² = v_i` the residual variance the declared noise predicts
//! ([`super::statistics::row_variances`]), so the loss's scale comes from the declared noise.
//! Its stationarity condition `Σ ρ'(u_i²) u_i ∇u_i = 0` is the normal equation of a weighted
//! least-squares problem with weights `w_i = ρ'(u_i²) / σ_i²`: each round fixes the weights at
//! the current estimate and solves that weighted problem (Levenberg–Marquardt or Gauss–Newton,
//! from the current estimate) until the estimate stops moving. Cauchy's loss is not convex, so
//! a Cauchy fit starts from the Huber fit, which starts from the least-squares fit.
//!
//! Losses, with `s = u²` and tuning constant `c` (95 % efficiency on normal data):
//! Huber `ρ(s) = s` for `s ≤ c²`, `2c√s − c²` beyond (`c = 1.345`, weight `min(1, c/|u|)`);
//! Cauchy `ρ(s) = c² ln(1 + s/c²)` (`c = 2.3849`, weight `1 / (1 + s/c²)`).

use nalgebra::DVector;

use super::fit::{solve_from, FitError};
use super::problem::{BlockError, IdentificationProblem};
use crate::solver::{SolverKind, SolverOutcome, StopReason};

/// Largest number of reweighting rounds per loss.
pub const MAX_REWEIGHTINGS: usize = 50;

/// Relative change of the estimate below which the reweighting has converged.
pub const REWEIGHTING_TOLERANCE: f64 = 1e-10;

/// A robust loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobustLoss {
    /// Huber: quadratic inside `c = 1.345 σ`, linear beyond.
    Huber,
    /// Cauchy (Lorentzian): logarithmic, `c = 2.3849 σ`; a gross outlier gets almost no weight.
    Cauchy,
}

impl RobustLoss {
    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RobustLoss::Huber => "huber",
            RobustLoss::Cauchy => "cauchy",
        }
    }

    /// The tuning constant `c`, in units of the residual's standard deviation.
    pub fn tuning(self) -> f64 {
        match self {
            RobustLoss::Huber => 1.345,
            RobustLoss::Cauchy => 2.3849,
        }
    }

    /// `ρ'(u²)`: the weight of a residual `u` standard deviations away.
    pub fn weight(self, u: f64) -> f64 {
        let c = self.tuning();
        match self {
            // 1 inside the corner (also at u = 0, where c/|u| is infinite), c/|u| beyond.
            RobustLoss::Huber => (c / u.abs()).min(1.0),
            RobustLoss::Cauchy => 1.0 / (1.0 + (u / c).powi(2)),
        }
    }
}

/// Why a robust fit failed.
#[derive(Debug, thiserror::Error)]
pub enum RobustError {
    /// A residual block could not be evaluated at an estimate.
    #[error(transparent)]
    Block(#[from] BlockError),
    /// A solver run failed (its message).
    #[error("{0}")]
    Solver(String),
}

impl From<FitError> for RobustError {
    fn from(error: FitError) -> Self {
        match error {
            FitError::Block(e) => RobustError::Block(e),
            FitError::Solver(message) | FitError::NeedsNoise(message) => {
                RobustError::Solver(message)
            }
        }
    }
}

/// The result of a robust fit.
#[derive(Debug, Clone)]
pub struct RobustFit {
    /// The estimate.
    pub x: DVector<f64>,
    /// The last weighted solve, with the iterations and evaluations of every round added up.
    /// It is not converged when the last solve did not converge, or when the reweighting ran
    /// out of rounds ([`StopReason::EvaluationBudget`]).
    pub outcome: SolverOutcome,
    /// Weighted solves performed (reweighting rounds over all losses).
    pub reweightings: usize,
    /// Final weights `w_i = ρ'(u_i²) / σ_i²`, one per row.
    pub weights: Vec<f64>,
}

/// Robust fit of `problem` (its own weights ignored) from `x0` with `loss`; `sigma` holds each
/// row's standard deviation (all positive).
///
/// # Errors
/// A block out of reach at an estimate, or a solver failure.
pub fn fit(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    loss: RobustLoss,
    sigma: &[f64],
    solver: SolverKind,
) -> Result<RobustFit, RobustError> {
    let raw = problem.unweighted();
    let losses: &[RobustLoss] = match loss {
        RobustLoss::Huber => &[RobustLoss::Huber],
        RobustLoss::Cauchy => &[RobustLoss::Huber, RobustLoss::Cauchy],
    };
    let mut x = x0.clone();
    let mut last: Option<SolverOutcome> = None;
    let mut reweightings = 0;
    let mut weights = vec![1.0; sigma.len()];
    let mut settled = true;
    for &loss in losses {
        settled = false;
        for _ in 0..MAX_REWEIGHTINGS {
            let r = raw.residuals(&x)?;
            weights = r
                .iter()
                .zip(sigma)
                .map(|(ri, si)| loss.weight(ri / si) / (si * si))
                .collect();
            let weighted = raw.clone().with_weights(&weights);
            let mut outcome = solve_from(&weighted, &x, solver)?;
            reweightings += 1;
            let change = (&outcome.x - &x).norm();
            x.clone_from(&outcome.x);
            if let Some(previous) = &last {
                outcome.iterations += previous.iterations;
                outcome.residual_evaluations += previous.residual_evaluations;
                outcome.jacobian_evaluations += previous.jacobian_evaluations;
            }
            last = Some(outcome);
            if change <= REWEIGHTING_TOLERANCE * (x.norm() + REWEIGHTING_TOLERANCE) {
                settled = true;
                break;
            }
        }
    }
    let mut outcome = match last {
        Some(outcome) => outcome,
        None => solve_from(&raw, &x, solver)?,
    };
    if !settled && outcome.converged {
        outcome.converged = false;
        outcome.stop_reason = StopReason::EvaluationBudget;
    }
    Ok(RobustFit {
        x,
        outcome,
        reweightings,
        weights,
    })
}
