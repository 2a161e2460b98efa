//! Why a solver stopped, as a typed value, and whether that stop is a convergence.

use std::fmt;

use nalgebra::{DMatrix, DVector};

/// Why a solver run stopped.
///
/// The first five are convergence: the solver stopped because a test says the estimate is a
/// minimiser to the requested precision (or to machine precision). The others are not, and a
/// report must say that the estimate is not to be trusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
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
    // A zero column's cosine is 0/0 = NaN, which `f64::max` ignores (it returns the other
    // operand): zero columns do not count.
    jacobian
        .column_iter()
        .map(|column| (column.dot(residuals) / column.norm() / r_norm).abs())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_reason_reads_as_its_own_sentence() {
        let texts: Vec<String> = StopReason::ALL.iter().map(|r| r.to_string()).collect();
        for (i, text) in texts.iter().enumerate() {
            assert!(text.len() > 10, "{text:?}");
            assert!(!texts[..i].contains(text), "{text}");
        }
        assert_eq!(StopReason::ZeroResidual.to_string(), "zero residual");
        assert_eq!(
            StopReason::Stalled.to_string(),
            "stalled at a point that is not stationary"
        );
    }

    /// Column 0 = (3, 4, 0) (norm 5), column 1 = 0, column 2 = (0, 6, 8) (norm 10); r = (0, 2, 0)
    /// (norm 2): the cosines are |8|/(5·2) = 0.8 and |12|/(10·2) = 0.6, the zero column has
    /// none, so the measure is 0.8; flipping r's sign changes nothing; a zero r gives 0.
    #[test]
    fn gradient_cosine_is_the_largest_column_cosine() {
        let j = DMatrix::from_row_slice(3, 3, &[3.0, 0.0, 0.0, 4.0, 0.0, 6.0, 0.0, 0.0, 8.0]);
        let r = DVector::from_column_slice(&[0.0, 2.0, 0.0]);
        assert!((gradient_cosine(&j, &r) - 0.8).abs() < 1e-15);
        assert!((gradient_cosine(&j, &(-&r)) - 0.8).abs() < 1e-15);
        // Only the third column: 0.6.
        let third = j.columns(2, 1).into_owned();
        assert!((gradient_cosine(&third, &r) - 0.6).abs() < 1e-15);
        // r orthogonal to every column: 0 (not NaN from the zero column).
        let orthogonal = DVector::from_column_slice(&[4.0, -3.0, 2.25]);
        assert!(gradient_cosine(&j, &orthogonal).abs() < 1e-15);
        assert_eq!(
            gradient_cosine(&j, &DVector::zeros(3)).to_bits(),
            0.0f64.to_bits()
        );
    }
}
