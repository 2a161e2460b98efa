//! What the two Levenberg–Marquardt solvers (the dense MINPACK port and the Schur-complement
//! one) share besides their step: the stopping tolerances with their validation and builder
//! methods, argmin's error and termination values worded with the solver's name, and the
//! tests made after every trial step, in MINPACK's order.

use argmin::core::{ArgminError, Error, TerminationReason};

use super::stop::StopReason;

/// Default stationarity tolerance on MINPACK's gradient measure `max_j |cos(J e_j, r)|` for
/// calling a cost-reduction or step stop a convergence. A cost-reduction stop with an undamped
/// step implies a measure of at most √ftol (≤ 1.2e-4 at MINPACK's default ftol). Measured at
/// the stopping iteration: at most 6.3e-7 over the 54 NIST StRD fits and 2.8e-7 over the MGH
/// problems and the simulated 5R (non-zero residuals); 0.64 where MINPACK stalls on NIST BoxBOD.
pub const STATIONARITY_TOLERANCE: f64 = 1e-3;

/// MINPACK's default relative cost-reduction and step tolerance (≈ √ε).
const MINPACK_TOLERANCE: f64 = 1.49012e-8;

/// The stopping tolerances and evaluation budget of a Levenberg–Marquardt solver.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Tolerances {
    /// Relative cost-reduction tolerance.
    pub ftol: f64,
    /// Relative step tolerance.
    pub xtol: f64,
    /// Gradient tolerance on `max_j |cos(J e_j, r)|`.
    pub gtol: f64,
    /// Gradient cosine below which a progress stop is a convergence.
    pub stationarity: f64,
    /// Budget of residual evaluations, the starting point included.
    pub max_evaluations: u64,
}

impl Tolerances {
    /// MINPACK's defaults: `ftol = xtol = 1.49e-8`, `gtol = 0`; the stationarity tolerance
    /// [`STATIONARITY_TOLERANCE`]; no evaluation budget.
    pub(crate) const MINPACK: Tolerances = Tolerances {
        ftol: MINPACK_TOLERANCE,
        xtol: MINPACK_TOLERANCE,
        gtol: 0.0,
        stationarity: STATIONARITY_TOLERANCE,
        max_evaluations: u64::MAX,
    };
}

/// argmin's error for an invalid setting.
pub(crate) fn invalid(text: &str) -> Error {
    ArgminError::InvalidParameter {
        text: text.to_string(),
    }
    .into()
}

/// `value` if it is finite and positive (or zero, with `allow_zero`); otherwise an
/// `InvalidParameter` error "{solver}: {what} must be positive and finite." (or non-negative).
pub(crate) fn validated(
    solver: &str,
    value: f64,
    what: &str,
    allow_zero: bool,
) -> Result<f64, Error> {
    if value.is_finite() && (value > 0.0 || (allow_zero && value >= 0.0)) {
        return Ok(value);
    }
    let rule = if allow_zero {
        "non-negative"
    } else {
        "positive"
    };
    Err(invalid(&format!(
        "{solver}: {what} must be {rule} and finite."
    )))
}

/// A budget of at least one evaluation; otherwise an `InvalidParameter` error.
pub(crate) fn validated_budget(solver: &str, budget: u64) -> Result<u64, Error> {
    if budget == 0 {
        return Err(invalid(&format!(
            "{solver}: the evaluation budget must be at least 1."
        )));
    }
    Ok(budget)
}

/// A stop that is not a convergence, with its message.
pub(crate) fn exit(solver: &str, text: &str) -> TerminationReason {
    TerminationReason::SolverExit(format!("{solver}: {text}"))
}

/// argmin's termination for a typed stop: convergence, or an exit with a message.
pub(crate) fn termination(solver: &str, reason: StopReason) -> TerminationReason {
    if reason.is_convergence() {
        TerminationReason::SolverConverged
    } else {
        exit(solver, &reason.to_string())
    }
}

/// The value a state must hold, or argmin's "not initialized" error.
pub(crate) fn take<T>(solver: &str, value: Option<T>, what: &str) -> Result<T, Error> {
    value.ok_or_else(|| {
        ArgminError::NotInitialized {
            text: format!(
                "{solver}: {what} not set; provide an initial parameter vector via \
                 `Executor::configure`."
            ),
        }
        .into()
    })
}

/// The figures of one trial step that the stopping tests read (relative reductions are
/// relative to the cost before the step).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Trial {
    /// Cost `½‖r‖²` of the iterate after the step (the trial point if accepted).
    pub cost: f64,
    /// Cost at the starting point of the run.
    pub initial_cost: f64,
    /// Actual relative reduction (−1 for a large rise).
    pub actred: f64,
    /// Predicted relative reduction of the damped linear model.
    pub prered: f64,
    /// Their ratio.
    pub ratio: f64,
    /// The step (or trust region) is within the step tolerance.
    pub step_converged: bool,
    /// The step (or trust region) is at machine precision relative to the iterate.
    pub step_at_precision: bool,
    /// MINPACK's gradient cosine at the iteration's point.
    pub gradient_cosine: f64,
    /// The damping, trust region or ratio is no longer finite.
    pub non_finite: bool,
    /// The evaluation budget is spent.
    pub budget_spent: bool,
}

impl Trial {
    /// The stop the tests call for after this trial, if any, in MINPACK's order: zero
    /// residual; a progress stop (cost reduction within `ftol`, step within tolerance, either
    /// at machine precision), which is a convergence only at a stationary point
    /// (`stationary` is asked only then) or an exact fit, and [`StopReason::Stalled`]
    /// otherwise; the gradient at machine precision; a non-finite value; the budget.
    pub(crate) fn verdict(
        &self,
        ftol: f64,
        stationary: impl FnOnce() -> bool,
    ) -> Option<StopReason> {
        let eps = f64::EPSILON;
        let reduction_within =
            |tol: f64| self.actred.abs() <= tol && self.prered <= tol && self.ratio <= 2.0;
        // A rejected trial (both solvers accept from a ratio of 1e-4) whose predicted reduction
        // is below the double's resolution of the cost and whose actual change is within
        // √ε (MINPACK's default ftol): that change, of either sign, is the round-off of the
        // computed cost (about 1e-12 relative for residuals that are small differences of the
        // kinematics' positions), and more damping only predicts less. Nothing further is
        // resolvable from this point. (A failed or wild trial changes the cost by more.)
        let unresolvable =
            self.prered <= eps && self.ratio < 1e-4 && self.actred.abs() <= eps.sqrt();
        let progress = if reduction_within(ftol) {
            Some(StopReason::CostReduction)
        } else if self.step_converged {
            Some(StopReason::StepSize)
        } else if reduction_within(eps) || self.step_at_precision || unresolvable {
            Some(StopReason::ToleranceTooSmall)
        } else {
            None
        };
        if self.cost <= f64::MIN_POSITIVE {
            Some(StopReason::ZeroResidual)
        } else if let Some(reason) = progress {
            Some(if self.cost <= eps * self.initial_cost {
                StopReason::ZeroResidual
            } else if stationary() {
                reason
            } else {
                StopReason::Stalled
            })
        } else if self.gradient_cosine <= eps {
            Some(StopReason::Gradient)
        } else if self.non_finite {
            Some(StopReason::NonFinite)
        } else if self.budget_spent {
            Some(StopReason::EvaluationBudget)
        } else {
            None
        }
    }
}

/// The builder methods for the [`Tolerances`] held in a solver's `tolerances` field, the
/// errors naming the solver as `$name` does.
macro_rules! tolerance_builders {
    ($name:expr) => {
        /// Relative cost-reduction tolerance: a progress stop when both the actual and the
        /// predicted relative reduction of the cost in a step are at most `ftol` (default
        /// MINPACK's 1.49e-8). Must be positive and finite.
        pub fn with_ftol(mut self, ftol: f64) -> Result<Self, argmin::core::Error> {
            self.tolerances.ftol = $crate::solver::settings::validated($name, ftol, "ftol", false)?;
            Ok(self)
        }

        /// Relative step tolerance: a progress stop when the step (the trust region of the
        /// dense solver, the damped step of the Schur one) is at most `xtol·(‖D x‖ + xtol)`
        /// (default MINPACK's 1.49e-8). Must be positive and finite.
        pub fn with_xtol(mut self, xtol: f64) -> Result<Self, argmin::core::Error> {
            self.tolerances.xtol = $crate::solver::settings::validated($name, xtol, "xtol", false)?;
            Ok(self)
        }

        /// Gradient tolerance on MINPACK's scale-invariant max-cosine
        /// `max_j |(Jᵀr)_j| / (‖J e_j‖·‖r‖) ≤ gtol`. Must be non-negative and finite; `0` (the
        /// default) only stops on an exactly zero cosine.
        pub fn with_gtol(mut self, gtol: f64) -> Result<Self, argmin::core::Error> {
            self.tolerances.gtol = $crate::solver::settings::validated($name, gtol, "gtol", true)?;
            Ok(self)
        }

        /// Stationarity tolerance on `max_j |cos(J e_j, r)|` for a cost-reduction or step stop
        /// to count as convergence (default
        /// [`STATIONARITY_TOLERANCE`](crate::solver::settings::STATIONARITY_TOLERANCE)).
        /// Must be non-negative and finite.
        pub fn with_stationarity_tolerance(
            mut self,
            tolerance: f64,
        ) -> Result<Self, argmin::core::Error> {
            self.tolerances.stationarity = $crate::solver::settings::validated(
                $name,
                tolerance,
                "stationarity tolerance",
                true,
            )?;
            Ok(self)
        }

        /// Budget of residual evaluations (the starting point included); the run stops with
        /// [`StopReason::EvaluationBudget`](crate::solver::stop::StopReason::EvaluationBudget)
        /// when it is spent. Default: unlimited (argmin's `max_iters` still applies). Must be
        /// at least 1.
        pub fn with_max_evaluations(mut self, budget: u64) -> Result<Self, argmin::core::Error> {
            self.tolerances.max_evaluations =
                $crate::solver::settings::validated_budget($name, budget)?;
            Ok(self)
        }
    };
}

pub(crate) use tolerance_builders;

#[cfg(test)]
mod tests {
    use super::*;

    fn quiet() -> Trial {
        Trial {
            cost: 1.0,
            initial_cost: 4.0,
            actred: 0.5,
            prered: 0.5,
            ratio: 1.0,
            step_converged: false,
            step_at_precision: false,
            gradient_cosine: 0.5,
            non_finite: false,
            budget_spent: false,
        }
    }

    #[test]
    fn a_step_far_from_every_test_goes_on() {
        assert_eq!(quiet().verdict(1e-8, || panic!("not asked")), None);
    }

    #[test]
    fn progress_stops_are_convergence_only_at_a_stationary_point() {
        let small = Trial {
            actred: 1e-9,
            prered: 1e-9,
            ..quiet()
        };
        assert_eq!(
            small.verdict(1e-8, || true),
            Some(StopReason::CostReduction)
        );
        assert_eq!(small.verdict(1e-8, || false), Some(StopReason::Stalled));
        // ρ > 2: the model predicted far less than happened; not a cost-reduction stop.
        let wild = Trial {
            ratio: 2.5,
            ..small
        };
        assert_eq!(wild.verdict(1e-8, || true), None);
        let step = Trial {
            step_converged: true,
            ..quiet()
        };
        assert_eq!(step.verdict(1e-8, || true), Some(StopReason::StepSize));
        let precise = Trial {
            step_at_precision: true,
            ..quiet()
        };
        assert_eq!(
            precise.verdict(1e-8, || true),
            Some(StopReason::ToleranceTooSmall)
        );
        let tiny = Trial {
            actred: 1e-17,
            prered: 1e-17,
            ..quiet()
        };
        // Below ε with ftol smaller still: only the machine-precision test fires.
        assert_eq!(
            tiny.verdict(1e-20, || true),
            Some(StopReason::ToleranceTooSmall)
        );
        // A rejected trial predicting less than the cost's resolution, its actual reduction
        // the cost's round-off (a forward fit's last iteration): nothing left to resolve, a
        // convergence at a stationary point only.
        let noise = Trial {
            actred: -1.5e-12,
            prered: 4.5e-19,
            ratio: -3.3e6,
            ..quiet()
        };
        assert_eq!(
            noise.verdict(1e-12, || true),
            Some(StopReason::ToleranceTooSmall)
        );
        assert_eq!(noise.verdict(1e-12, || false), Some(StopReason::Stalled));
        // The same prediction on an accepted trial, or a rejected one predicting more than ε:
        // no stop.
        let accepted = Trial {
            ratio: 1e-4,
            ..noise
        };
        assert_eq!(accepted.verdict(1e-12, || true), None);
        let resolvable = Trial {
            prered: 1e-15,
            ..noise
        };
        assert_eq!(resolvable.verdict(1e-12, || true), None);
        // A failed trial point (a large rise) is no round-off: the damping goes on.
        let failed = Trial {
            actred: -1.0,
            ratio: -1.0 / 4.5e-19,
            ..noise
        };
        assert_eq!(failed.verdict(1e-12, || true), None);
        let beyond = Trial {
            actred: -2e-8,
            ..noise
        };
        assert_eq!(beyond.verdict(1e-12, || true), None);
    }

    #[test]
    fn an_exact_fit_is_a_zero_residual_whatever_the_stationarity() {
        let zero = Trial {
            cost: 0.0,
            ..quiet()
        };
        assert_eq!(zero.verdict(1e-8, || false), Some(StopReason::ZeroResidual));
        // ε·start = 8.9e-16 for a start of 4 (a start of 1 could not tell ε·start from ε/start).
        let exact = Trial {
            cost: 5e-16,
            initial_cost: 4.0,
            step_converged: true,
            ..quiet()
        };
        assert_eq!(
            exact.verdict(1e-8, || false),
            Some(StopReason::ZeroResidual)
        );
        // A cost just above ε·start is not an exact fit.
        let above = Trial {
            cost: 9e-16,
            ..exact
        };
        assert_eq!(above.verdict(1e-8, || false), Some(StopReason::Stalled));
    }

    #[test]
    fn the_remaining_tests_in_order() {
        let orthogonal = Trial {
            gradient_cosine: 0.0,
            non_finite: true,
            budget_spent: true,
            ..quiet()
        };
        assert_eq!(
            orthogonal.verdict(1e-8, || true),
            Some(StopReason::Gradient)
        );
        let broken = Trial {
            gradient_cosine: 1e-15,
            ..orthogonal
        };
        assert_eq!(broken.verdict(1e-8, || true), Some(StopReason::NonFinite));
        let spent = Trial {
            non_finite: false,
            ..broken
        };
        assert_eq!(
            spent.verdict(1e-8, || true),
            Some(StopReason::EvaluationBudget)
        );
    }

    #[test]
    fn settings_are_validated_with_the_solver_name() {
        assert_eq!(
            validated("S", 1.0, "ftol", false).unwrap().to_bits(),
            1.0f64.to_bits()
        );
        assert_eq!(
            validated("S", 0.0, "gtol", true).unwrap().to_bits(),
            0.0f64.to_bits()
        );
        let text = validated("S", 0.0, "ftol", false).unwrap_err().to_string();
        assert!(
            text.contains("S: ftol must be positive and finite."),
            "{text}"
        );
        let text = validated("S", -1.0, "gtol", true).unwrap_err().to_string();
        assert!(
            text.contains("S: gtol must be non-negative and finite."),
            "{text}"
        );
        assert!(validated("S", f64::NAN, "x", true).is_err());
        assert!(validated("S", f64::INFINITY, "x", false).is_err());
        assert_eq!(validated_budget("S", 1).unwrap(), 1);
        let text = validated_budget("S", 0).unwrap_err().to_string();
        assert!(
            text.contains("S: the evaluation budget must be at least 1."),
            "{text}"
        );
    }
}
