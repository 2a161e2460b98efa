//! Why a solver stopped, as a typed value, and whether that stop is a convergence.

use std::fmt;

use nalgebra::{DMatrix, DVector};

/// Why a solver run stopped.
///
/// The first five are convergence: the solver stopped because a test says the estimate is a
/// minimiser to the requested precision (or to machine precision). The others are not, and a
/// report must say that the estimate is not to be trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StopReason {
    /// The residual vanished: ½‖r‖² ≤ `f64::MIN_POSITIVE`, or the cost fell below ε times
    /// its starting value (an exact fit to working precision).
    ZeroResidual,
    /// The actual and predicted relative reductions of the cost in a step fell below the
    /// cost tolerance, at a stationary point.
    CostReduction,
    /// The step (Levenberg–Marquardt: the trust region; Gauss–Newton: the step itself) fell
    /// below the step tolerance relative to the parameters, at a stationary point.
    StepSize,
    /// The residual is orthogonal to every Jacobian column (to the gradient tolerance, or to
    /// machine precision).
    Gradient,
    /// The tolerances ask for more than machine precision allows; no further reduction of the
    /// cost or improvement of the parameters is possible, at a stationary point.
    ToleranceTooSmall,
    /// The budget of residual evaluations ran out first.
    EvaluationBudget,
    /// Progress stopped at a point that is not stationary: the step vanished or the cost and
    /// step tests fired while the residual still has a large component along a Jacobian
    /// column (for example a parameter driven where the model no longer depends on it).
    Stalled,
    /// A residual, Jacobian, step or damping value became NaN or infinite.
    NonFinite,
}

impl StopReason {
    /// Every reason, in declaration order.
    pub const ALL: [StopReason; 8] = [
        StopReason::ZeroResidual,
        StopReason::CostReduction,
        StopReason::StepSize,
        StopReason::Gradient,
        StopReason::ToleranceTooSmall,
        StopReason::EvaluationBudget,
        StopReason::Stalled,
        StopReason::NonFinite,
    ];

    /// Whether stopping for this reason means the solver converged.
    pub fn is_convergence(self) -> bool {
        matches!(
            self,
            StopReason::ZeroResidual
                | StopReason::CostReduction
                | StopReason::StepSize
                | StopReason::Gradient
                | StopReason::ToleranceTooSmall
        )
    }

    /// The snake_case name used in the JSON report (`cost_reduction`, `evaluation_budget`, …).
    pub fn key(self) -> &'static str {
        match self {
            StopReason::ZeroResidual => "zero_residual",
            StopReason::CostReduction => "cost_reduction",
            StopReason::StepSize => "step_size",
            StopReason::Gradient => "gradient",
            StopReason::ToleranceTooSmall => "tolerance_too_small",
            StopReason::EvaluationBudget => "evaluation_budget",
            StopReason::Stalled => "stalled",
            StopReason::NonFinite => "non_finite",
        }
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::ZeroResidual => "zero residual",
            StopReason::CostReduction => "relative cost reduction below tolerance",
            StopReason::StepSize => "step below tolerance",
            StopReason::Gradient => "residual orthogonal to the Jacobian (gradient test)",
            StopReason::ToleranceTooSmall => "no further improvement possible at machine precision",
            StopReason::EvaluationBudget => "budget of residual evaluations exhausted",
            StopReason::Stalled => "stalled at a point that is not stationary",
            StopReason::NonFinite => "a value became NaN or infinite",
        })
    }
}

/// MINPACK's scale-invariant measure of stationarity, `max_j |cos(J e_j, r)|`: the largest
/// cosine between the residual and a non-zero Jacobian column (0 for a zero residual). It is
/// 0 at a stationary point whatever the units of the parameters, and close to 1 where the
/// residual still lies along some column however small that column is.
pub fn gradient_cosine(jacobian: &DMatrix<f64>, residuals: &DVector<f64>) -> f64 {
    let r_norm = residuals.norm();
    if r_norm == 0.0 {
        return 0.0;
    }
    jacobian
        .column_iter()
        .filter_map(|column| {
            let c_norm = column.norm();
            (c_norm > 0.0).then(|| (column.dot(residuals) / c_norm / r_norm).abs())
        })
        .fold(0.0, f64::max)
}
