//! argmin's Gauss–Newton with a step-size stopping rule.
//!
//! argmin's `GaussNewton` stops when ‖r‖ changes by less than a tolerance; near the minimum the
//! change of ‖r‖ is quadratic in the parameter error, so that rule leaves the parameters
//! accurate only to about √tol. This wrapper delegates each iteration to argmin's solver and
//! stops when the step is small: ‖Δx‖ ≤ x_tol (‖x‖ + x_tol), or when the iterate no longer
//! moves. A non-finite step stops the run at the last finite iterate.

use argmin::core::{
    Error, IterState, Jacobian, Operator, Problem, Solver, State, TerminationReason,
    TerminationStatus, KV,
};
use argmin::solver::gaussnewton::GaussNewton;
use nalgebra::{DMatrix, DVector};

use super::stop::StopReason;

type GnState = IterState<DVector<f64>, (), DMatrix<f64>, (), DVector<f64>, f64>;

/// # Gauss–Newton (argmin) with a step-size stopping rule
///
/// ## Requirements on the optimization problem
/// `Operator` (residuals) and `Jacobian`; a full-rank Jacobian (check the rank first: argmin
/// inverts JᵀJ explicitly).
///
/// ## Reference
/// Nocedal & Wright, Numerical Optimization, §10.3.
#[derive(Clone)]
pub struct StepGaussNewton {
    inner: GaussNewton<f64>,
    xtol: f64,
    last_step: f64,
    last_norm: f64,
    stop: Option<StopReason>,
}

impl StepGaussNewton {
    /// Gauss–Newton stopping when ‖Δx‖ ≤ 1e-12 (‖x‖ + 1e-12).
    pub fn new() -> Self {
        Self {
            inner: GaussNewton::new(),
            xtol: 1e-12,
            last_step: f64::INFINITY,
            last_norm: 0.0,
            stop: None,
        }
    }

    /// Sets the relative step tolerance.
    ///
    /// # Errors
    /// If `xtol` is not positive and finite.
    pub fn with_xtol(mut self, xtol: f64) -> Result<Self, Error> {
        self.xtol = super::settings::validated("Gauss-Newton", xtol, "xtol", false)?;
        Ok(self)
    }

    /// Why the last run stopped: [`StopReason::StepSize`] or [`StopReason::NonFinite`];
    /// `None` while it runs or when argmin stopped it (at `max_iters`).
    pub fn stop_reason(&self) -> Option<StopReason> {
        self.stop
    }
}

impl std::fmt::Debug for StepGaussNewton {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StepGaussNewton")
            .field("xtol", &self.xtol)
            .finish()
    }
}

impl Default for StepGaussNewton {
    fn default() -> Self {
        Self::new()
    }
}

impl<O> Solver<O, GnState> for StepGaussNewton
where
    O: Operator<Param = DVector<f64>, Output = DVector<f64>>
        + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>,
{
    fn name(&self) -> &str {
        "Gauss-Newton (step-size stopping)"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        state: GnState,
    ) -> Result<(GnState, Option<KV>), Error> {
        (self.stop, self.last_step) = (None, f64::INFINITY);
        self.inner.init(problem, state)
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        state: GnState,
    ) -> Result<(GnState, Option<KV>), Error> {
        let before = state.get_param().cloned().unwrap_or_default();
        let (state, kv) = self.inner.next_iter(problem, state)?;
        let after = state.get_param().cloned().unwrap_or_default();
        if !after.iter().all(|v| v.is_finite()) {
            self.stop = Some(StopReason::NonFinite);
            let reason = TerminationReason::SolverExit(
                "Gauss-Newton: the step is not finite (singular normal equations)".into(),
            );
            return Ok((state.param(before).terminate_with(reason), kv));
        }
        self.last_step = (&after - &before).norm();
        self.last_norm = after.norm();
        Ok((state, kv))
    }

    fn terminate(&mut self, _state: &GnState) -> TerminationStatus {
        // ‖Δx‖ ≤ x_tol (‖x‖ + x_tol)
        if self.last_step <= self.xtol * (self.last_norm + self.xtol) {
            self.stop = Some(StopReason::StepSize);
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        TerminationStatus::NotTerminated
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use argmin::core::Executor;

    /// r(x) = x²: with J = 2x, Gauss–Newton's step is −x/2 exactly, so from x₀ = 1 the iterates
    /// are 2⁻ᵏ and every step is as long as the new iterate.
    struct Square;
    impl Operator for Square {
        type Param = DVector<f64>;
        type Output = DVector<f64>;
        fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
            Ok(x.map(|v| v * v))
        }
    }
    impl Jacobian for Square {
        type Param = DVector<f64>;
        type Jacobian = DMatrix<f64>;
        fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
            Ok(DMatrix::from_element(1, 1, 2.0 * x[0]))
        }
    }

    /// The rule ‖Δx‖ ≤ t(‖x‖ + t) with ‖Δx‖ = ‖x‖ = 2⁻ᵏ holds from 2⁻ᵏ ≤ t²/(1 − t) on:
    /// k = ⌈log₂((1 − t)/t²)⌉, i.e. 4 for t = 1/4 (12 → 3.58), 14 for t = 10⁻² (9900 → 13.27)
    /// and 20 for t = 10⁻³ (999000 → 19.93).
    #[test]
    fn it_stops_at_the_first_step_within_the_tolerance() {
        for (tolerance, iterations) in [(0.25, 4), (1e-2, 14), (1e-3, 20)] {
            let solver = StepGaussNewton::new().with_xtol(tolerance).unwrap();
            let result = Executor::new(Square, solver)
                .configure(|s| s.param(DVector::from_element(1, 1.0)).max_iters(100))
                .run()
                .unwrap();
            assert_eq!(result.state.get_iter(), iterations, "tolerance {tolerance}");
            let x = result.state.get_param().unwrap()[0];
            assert_eq!(x.to_bits(), 0.5f64.powi(iterations as i32).to_bits());
            assert_eq!(result.solver.stop_reason(), Some(StopReason::StepSize));
        }
    }

    #[test]
    fn the_tolerance_must_be_positive_and_finite() {
        for bad in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
            let err = StepGaussNewton::new().with_xtol(bad).unwrap_err();
            assert!(
                err.to_string().contains("xtol must be positive and finite"),
                "{bad}: {err}"
            );
        }
        let solver = StepGaussNewton::new().with_xtol(f64::MIN_POSITIVE).unwrap();
        assert_eq!(
            format!("{solver:?}"),
            format!("StepGaussNewton {{ xtol: {:?} }}", f64::MIN_POSITIVE)
        );
        assert_eq!(
            format!("{:?}", StepGaussNewton::default()),
            "StepGaussNewton { xtol: 1e-12 }"
        );
        assert_eq!(
            <StepGaussNewton as Solver<Square, GnState>>::name(&solver),
            "Gauss-Newton (step-size stopping)"
        );
        assert_eq!(solver.stop_reason(), None, "not run yet");
    }
}
