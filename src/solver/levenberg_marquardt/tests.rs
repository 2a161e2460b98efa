//! Tests of the Levenberg–Marquardt solver: parameter validation, stopping tests and
//! non-finite or unreachable trial points. Known answers and the agreement with the
//! `levenberg-marquardt` crate are in the integration tests (tests/it/mgh.rs).

use super::*;
use argmin::core::Executor;

fn text(err: Error) -> String {
    match err.downcast_ref::<ArgminError>() {
        Some(ArgminError::InvalidParameter { text }) => text.clone(),
        _ => panic!("unexpected error {err}"),
    }
}

#[test]
fn builder_validates() {
    let lm = LevenbergMarquardt::new;
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let msg = "Levenberg-Marquardt: ftol must be positive and finite.";
        assert_eq!(text(lm().with_ftol(bad).unwrap_err()), msg);
        let msg = "Levenberg-Marquardt: xtol must be positive and finite.";
        assert_eq!(text(lm().with_xtol(bad).unwrap_err()), msg);
        let msg = "Levenberg-Marquardt: initial step bound must be positive and finite.";
        assert_eq!(text(lm().with_initial_step_bound(bad).unwrap_err()), msg);
    }
    for bad in [-1e-300, f64::NAN, f64::INFINITY] {
        let msg = "Levenberg-Marquardt: gtol must be non-negative and finite.";
        assert_eq!(text(lm().with_gtol(bad).unwrap_err()), msg);
    }
    let ok = lm()
        .with_ftol(1e-3)
        .and_then(|l| l.with_xtol(1e-4))
        .and_then(|l| l.with_gtol(0.0));
    let ok = ok.and_then(|l| l.with_initial_step_bound(0.1)).unwrap();
    assert_eq!(
        (
            ok.tolerances.ftol,
            ok.tolerances.xtol,
            ok.tolerances.gtol,
            ok.step_bound
        ),
        (1e-3, 1e-4, 0.0, 0.1)
    );
    let d = LevenbergMarquardt::default();
    assert_eq!(
        (
            d.tolerances.ftol,
            d.tolerances.xtol,
            d.tolerances.gtol,
            d.step_bound
        ),
        (1.49012e-8, 1.49012e-8, 0.0, 100.0)
    );
}

#[test]
fn send_sync_clone() {
    fn assert_traits<T: Send + Sync + Clone + std::fmt::Debug>() {}
    assert_traits::<LevenbergMarquardt>();
}

/// `r = (x₀ − 1, x₀ + 1, 10 x₁ − 10)`, NaN where `x₀ > nan_above`, Jacobian NaN if `nan_jac`.
#[derive(Clone, Copy)]
struct Trap {
    nan_above: f64,
    nan_jac: bool,
    m: usize,
}
impl Operator for Trap {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let nan = if x[0] > self.nan_above { f64::NAN } else { 0.0 };
        let r = [x[0] - 1.0 + nan, x[0] + 1.0, 10.0 * x[1] - 10.0];
        Ok(DVector::from_column_slice(&r[..self.m]))
    }
}
impl Jacobian for Trap {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, _: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        let v = if self.nan_jac { f64::NAN } else { 1.0 };
        Ok(DMatrix::from_row_slice(
            3,
            2,
            &[v, 0.0, 1.0, 0.0, 0.0, 10.0],
        ))
    }
}

/// A budget far above what these runs take, so that a broken trust-region update fails a test
/// instead of hanging it in one iteration's loop of rejected steps.
fn budgeted() -> LevenbergMarquardt {
    LevenbergMarquardt::new()
        .with_max_evaluations(10_000)
        .unwrap()
}

fn run_trap(t: Trap, x0: [f64; 2]) -> Result<(LmState, LevenbergMarquardt), Error> {
    let res = Executor::new(t, budgeted())
        .configure(|s| s.param(DVector::from_column_slice(&x0)).max_iters(50))
        .run()?;
    Ok((res.state, res.solver))
}

fn exit_text(state: &LmState) -> String {
    match state.get_termination_reason() {
        Some(TerminationReason::SolverExit(t)) => t.clone(),
        other => panic!("expected SolverExit, got {other:?}"),
    }
}

#[test]
fn trap_converges_and_reports_test() {
    let t = Trap {
        nan_above: f64::INFINITY,
        nan_jac: false,
        m: 3,
    };
    let (state, solver) = run_trap(t, [-3.0, 5.0]).unwrap();
    assert_eq!(
        state.get_termination_reason(),
        Some(&TerminationReason::SolverConverged)
    );
    // A linear problem: one exact Gauss–Newton step, then no further reduction.
    assert_eq!(solver.stop_reason(), Some(StopReason::CostReduction));
    let x = state.get_param().unwrap();
    assert!(x[0].abs() < 1e-12 && (x[1] - 1.0).abs() < 1e-12, "{x}");
    assert!((state.get_cost() - 1.0).abs() < 1e-12); // ½(1² + 1²)
}

#[test]
fn non_finite_values_stop_with_message() {
    let t = Trap {
        nan_above: 10.0,
        nan_jac: false,
        m: 3,
    };
    let (state, _) = run_trap(t, [11.0, 0.0]).unwrap();
    assert_eq!(
        exit_text(&state),
        "Levenberg-Marquardt: residual vector contains NaN or infinity at the initial point."
    );
    let t = Trap {
        nan_above: 10.0,
        nan_jac: true,
        m: 3,
    };
    let (state, _) = run_trap(t, [1.0, 0.0]).unwrap();
    assert_eq!(
        exit_text(&state),
        "Levenberg-Marquardt: Jacobian contains NaN or infinity."
    );
    // A NaN at a trial point (the minimum x₀ = 0 lies beyond the domain x₀ ≤ −2.5) is a
    // rejected step: the trust region shrinks, the iterate never leaves the domain, the cost
    // decreases, and the run ends near the domain's edge without an error. (LM is not a
    // constrained method: at the edge its trust region collapses, so the other coordinate
    // is not fully converged.)
    let t = Trap {
        nan_above: -2.5,
        nan_jac: false,
        m: 3,
    };
    let (state, solver) = run_trap(t, [-3.0, 5.0]).unwrap();
    let x = state.get_param().unwrap();
    assert!(state.get_cost().is_finite() && x[0] <= -2.5, "{x:?}");
    assert!(
        x[0] > -2.5 - 1e-6,
        "moved up to the edge of the domain: {x:?}"
    );
    let start_cost = 0.5 * (16.0 + 4.0 + 1600.0);
    assert!(state.get_cost() < start_cost, "cost {}", state.get_cost());
    // Not a stationary point: the run stalled at the edge of the domain.
    assert_eq!(solver.stop_reason(), Some(StopReason::Stalled));
}

/// Fails (as a leg that cannot reach a pose would) for x₀ > 0.5.
struct Unreachable;
impl Operator for Unreachable {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        if x[0] > 0.5 {
            return Err(Error::msg("pose out of reach"));
        }
        Ok(DVector::from_column_slice(&[x[0] - 1.0, x[1] - 2.0]))
    }
}
impl Jacobian for Unreachable {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, _: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok(DMatrix::identity(2, 2))
    }
}

#[test]
fn an_error_at_a_trial_point_is_a_rejected_step() {
    let res = Executor::new(Unreachable, budgeted())
        .configure(|s| {
            s.param(DVector::from_column_slice(&[-10.0, 0.0]))
                .max_iters(100)
        })
        .run()
        .unwrap();
    let x = res.state.get_param().unwrap();
    assert!(
        x[0] <= 0.5 && x[0] > 0.5 - 1e-6,
        "stopped at the edge: {x:?}"
    );
    assert!(res.state.get_cost() < 0.5 * (121.0 + 4.0) * 0.05, "{x:?}");
    // The edge of the domain is not a minimum (the residual still points across it): the run
    // must not claim convergence.
    let reason = res.solver.stop_reason().unwrap();
    assert!(!reason.is_convergence(), "{reason:?} at {x:?}");
}

#[test]
fn zero_residual_start_and_shape_errors() {
    let t = Trap {
        nan_above: f64::INFINITY,
        nan_jac: false,
        m: 1,
    };
    let (state, solver) = run_trap(t, [1.0, 7.0]).unwrap();
    assert_eq!(
        state.get_termination_reason(),
        Some(&TerminationReason::SolverConverged)
    );
    assert_eq!(solver.stop_reason(), Some(StopReason::ZeroResidual));
    assert_eq!(state.get_iter(), 0);
    // Residual of length 1 but a 3×2 Jacobian: a usage error, reported as `Err`.
    let err = run_trap(t, [2.0, 7.0]).unwrap_err();
    assert!(
        err.to_string()
            .contains("Jacobian row count has length 3, expected 1"),
        "{err}"
    );
}

/// `r = (x₀ − 1, 2 + e^{−x₁})` has no minimum: the cost decreases towards ½·4 as x₁ → ∞. The
/// relative cost reduction per step falls below ftol after some thirty steps, but the residual
/// still lies along the second column (cosine 1): the run is stalled, not converged.
#[derive(Clone, Copy)]
struct NoMinimum;
impl Operator for NoMinimum {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_column_slice(&[
            x[0] - 1.0,
            2.0 + (-x[1]).exp(),
        ]))
    }
}
impl Jacobian for NoMinimum {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok(DMatrix::from_row_slice(
            2,
            2,
            &[1.0, 0.0, 0.0, -(-x[1]).exp()],
        ))
    }
}

#[test]
fn progress_stopping_away_from_a_stationary_point_is_stalled() {
    let solver = budgeted()
        .with_ftol(1e-12)
        .and_then(|l| l.with_xtol(1e-12))
        .unwrap();
    let res = Executor::new(NoMinimum, solver)
        .configure(|s| {
            s.param(DVector::from_column_slice(&[0.0, 0.0]))
                .max_iters(1000)
        })
        .run()
        .unwrap();
    let x = res.state.get_param().unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::Stalled), "{x}");
    assert!(matches!(
        res.state.get_termination_reason(),
        Some(TerminationReason::SolverExit(_))
    ));
    // It did go downhill first: x₀ solved, x₁ pushed far up the plateau.
    assert!((x[0] - 1.0).abs() < 1e-9 && x[1] > 10.0, "{x}");
}

#[test]
fn the_evaluation_budget_stops_the_run_unconverged() {
    let solver = LevenbergMarquardt::new().with_max_evaluations(5).unwrap();
    let res = Executor::new(NoMinimum, solver)
        .configure(|s| {
            s.param(DVector::from_column_slice(&[0.0, 0.0]))
                .max_iters(1000)
        })
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::EvaluationBudget));
    assert_eq!(res.solver.evaluations(), 5);
    assert!(LevenbergMarquardt::new().with_max_evaluations(0).is_err());
}

#[test]
fn a_stationarity_tolerance_of_one_accepts_any_progress_stop_as_convergence() {
    // On the plateau the residual lies along the second column (cosine 1): with the default
    // tolerance the stop is a stall (test above); a tolerance of 1 calls every cosine
    // stationary, so the same run ends converged.
    let solver = budgeted()
        .with_ftol(1e-12)
        .and_then(|l| l.with_xtol(1e-12))
        .and_then(|l| l.with_stationarity_tolerance(1.0))
        .unwrap();
    assert!((solver.tolerances.stationarity - 1.0).abs() < f64::EPSILON);
    let res = Executor::new(NoMinimum, solver)
        .configure(|s| {
            s.param(DVector::from_column_slice(&[0.0, 0.0]))
                .max_iters(1000)
        })
        .run()
        .unwrap();
    let reason = res.solver.stop_reason().unwrap();
    assert!(reason.is_convergence(), "{reason:?}");
    assert!(matches!(
        res.state.get_termination_reason(),
        Some(TerminationReason::SolverConverged)
    ));
    for bad in [-1e-300, f64::NAN, f64::INFINITY] {
        let msg = "Levenberg-Marquardt: stationarity tolerance must be non-negative and finite.";
        let err = LevenbergMarquardt::new()
            .with_stationarity_tolerance(bad)
            .unwrap_err();
        assert_eq!(text(err), msg);
    }
}

#[test]
fn the_solver_names_itself() {
    let solver = LevenbergMarquardt::new();
    assert_eq!(
        Solver::<NoMinimum, LmState>::name(&solver),
        "Levenberg-Marquardt"
    );
}

/// `r = (x₀ − 1, x₀ + 1)`: the residuals do not depend on `x₁` (a zero Jacobian column).
#[derive(Clone, Copy)]
struct Idle;
impl Operator for Idle {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_column_slice(&[x[0] - 1.0, x[0] + 1.0]))
    }
}
impl Jacobian for Idle {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, _: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok(DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 1.0, 0.0]))
    }
}

#[test]
fn a_parameter_the_residuals_ignore_is_scaled_by_one_and_left_alone() {
    let res = Executor::new(Idle, budgeted())
        .configure(|s| {
            s.param(DVector::from_column_slice(&[-3.0, 5.0]))
                .max_iters(50)
        })
        .run()
        .unwrap();
    assert_eq!(
        res.state.get_termination_reason(),
        Some(&TerminationReason::SolverConverged)
    );
    let x = res.state.get_param().unwrap();
    assert!(x[0].abs() < 1e-12, "{x}");
    assert_eq!(x[1].to_bits(), 5.0f64.to_bits(), "{x}");
    // MINPACK's scaling: the column norms (√2 for x₀), a zero column counting as 1, so that
    // the first trust region is 100·‖D x₀‖ = 100·√(2·9 + 25).
    assert_eq!(res.solver.diag.as_slice(), &[2f64.sqrt(), 1.0]);
}

/// `r = (x − c − 1, x − c + 1)` with `c = 10⁶`: minimum at `x = c`, where `r = (−1, 1)`.
const FAR_PAIR: Functions = Functions {
    residuals: |x| {
        let t = x[0] - 1e6;
        Ok(DVector::from_column_slice(&[t - 1.0, t + 1.0]))
    },
    jacobian: |_| DMatrix::from_row_slice(2, 1, &[1.0, 1.0]),
};

#[test]
fn a_negligible_gauss_newton_step_relative_to_the_parameters_is_stationary() {
    // From x₀ = c + 0.01 the gradient cosine is 0.01 (above the stationarity tolerance 1e-3),
    // and the first step's reductions (1e-4) are within ftol = 1e-3: a progress stop. Its
    // Gauss–Newton step, ‖D p‖ = 0.01·√2, is below √ε (‖D x‖ + √ε) = 2.1e-2 for ‖D x‖ = √2·10⁶:
    // a stationary point at the parameters' scale, so the stop is a convergence.
    let solver = budgeted().with_ftol(1e-3).unwrap();
    let res = Executor::new(FAR_PAIR, solver)
        .configure(|s| s.param(DVector::from_element(1, 1e6 + 0.01)).max_iters(50))
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::CostReduction));
    let x = res.state.get_param().unwrap()[0];
    assert!((x - 1e6).abs() < 1e-6, "{x}");
    // The same stop with the parameter near 1 instead of 10⁶ (√ε (‖D x‖ + √ε) ≈ 2e-8 then) is
    // not stationary: stalled.
    let near_pair = Functions {
        residuals: |x| {
            let t = x[0] - 1.0;
            Ok(DVector::from_column_slice(&[t - 1.0, t + 1.0]))
        },
        jacobian: |_| DMatrix::from_row_slice(2, 1, &[1.0, 1.0]),
    };
    let solver = budgeted().with_ftol(1e-3).unwrap();
    let res = Executor::new(near_pair, solver)
        .configure(|s| s.param(DVector::from_element(1, 1.01)).max_iters(50))
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::Stalled));
}

/// A test problem given by two functions: the residuals (an error where the problem is not
/// defined) and the Jacobian.
#[derive(Clone, Copy)]
struct Functions {
    residuals: fn(&DVector<f64>) -> Result<DVector<f64>, Error>,
    jacobian: fn(&DVector<f64>) -> DMatrix<f64>,
}
impl Operator for Functions {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        (self.residuals)(x)
    }
}
impl Jacobian for Functions {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok((self.jacobian)(x))
    }
}

/// `r = (10 (x₁ − x₀²), 1 − x₀)` (Rosenbrock), whose start (−1.2, 1) makes MINPACK reject steps.
const ROSENBROCK: Functions = Functions {
    residuals: |x| {
        Ok(DVector::from_column_slice(&[
            10.0 * (x[1] - x[0] * x[0]),
            1.0 - x[0],
        ]))
    },
    jacobian: |x| DMatrix::from_row_slice(2, 2, &[-20.0 * x[0], 10.0, -1.0, 0.0]),
};

/// The values an observer sees: `trials` counts an iteration's residual evaluations (they sum
/// to the run's evaluations less the start's), a step is accepted only with a ratio of at
/// least 1e-4 and then lowers the cost, and λ and Δ stay finite and non-negative.
#[test]
fn the_observed_values_count_the_trials_and_follow_the_accepted_steps() {
    use crate::solver::observed::{count, float, Iterations};
    let iterations = Iterations::default();
    let seen = iterations.0.clone();
    let res = Executor::new(ROSENBROCK, budgeted())
        .configure(|s| {
            s.param(DVector::from_column_slice(&[-1.2, 1.0]))
                .max_iters(200)
        })
        .add_observer(iterations, argmin::core::observers::ObserverMode::Always)
        .run()
        .unwrap();
    let x = res.state.get_param().unwrap();
    assert!(
        (x[0] - 1.0).abs() < 1e-10 && (x[1] - 1.0).abs() < 1e-10,
        "{x}"
    );
    let seen = seen.borrow();
    let trials: Vec<u64> = seen.iter().map(|(_, kv)| count(kv, "trials")).collect();
    assert_eq!(trials.iter().sum::<u64>(), res.solver.evaluations() - 1);
    assert!(
        trials.iter().any(|&t| t > 1),
        "a step was rejected on the way: {trials:?}"
    );
    let mut cost = 0.5 * (4.4f64.powi(2) + 2.2f64.powi(2)); // ½‖r(−1.2, 1)‖²
    for (k, (after, kv)) in seen.iter().enumerate() {
        let ratio = float(kv, "ratio");
        if k + 1 < seen.len() {
            assert!(ratio >= 1e-4, "iteration {k} ended on an accepted step");
        }
        if ratio >= 1e-4 {
            assert!(*after < cost, "iteration {k}: cost {after} after {cost}");
        } else {
            assert_eq!(
                after.to_bits(),
                cost.to_bits(),
                "iteration {k} kept its point"
            );
        }
        cost = *after;
        let (lambda, delta) = (float(kv, "lambda"), float(kv, "delta"));
        assert!(lambda >= 0.0 && lambda.is_finite() && delta > 0.0 && delta.is_finite());
    }
}

/// At x = 0 the stationarity floor √ε (‖D x‖ + √ε) is ε itself: from the origin, a
/// Gauss–Newton step of 1e-16 on `r = (t − 1e-14, t + 1e-14)`, `t = x − 1e-16`, is stationary,
/// so the progress stop it ends with (ftol = 1e-3) is a convergence, not a stall. The gradient
/// cosine there is 1e-2, above the stationarity tolerance: only the step decides.
#[test]
fn at_the_origin_a_step_below_epsilon_is_stationary() {
    let tiny_pair = Functions {
        residuals: |x| {
            let t = x[0] - 1e-16;
            Ok(DVector::from_column_slice(&[t - 1e-14, t + 1e-14]))
        },
        jacobian: |_| DMatrix::from_row_slice(2, 1, &[1.0, 1.0]),
    };
    let solver = budgeted().with_ftol(1e-3).unwrap();
    let res = Executor::new(tiny_pair, solver)
        .configure(|s| s.param(DVector::from_element(1, 0.0)).max_iters(50))
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::CostReduction));
    assert_eq!(res.solver.evaluations(), 2, "one step, then the stop");
    let x = res.state.get_param().unwrap()[0];
    assert!((x - 1e-16).abs() < 1e-28, "{x}");
}

/// `r = x² − 2` from 1.5: the fit is exact, but √2 is not a double, so the residual ends at a
/// round-off of about 4e-16 rather than 0. Its cost, about 1e-31, is below ε times the start's
/// (1/32): a zero residual, which the cost of the step (½‖r‖², not ‖r‖) decides.
#[test]
fn an_exact_fit_reached_to_round_off_is_a_zero_residual() {
    let root = Functions {
        residuals: |x| Ok(DVector::from_element(1, x[0] * x[0] - 2.0)),
        jacobian: |x| DMatrix::from_element(1, 1, 2.0 * x[0]),
    };
    let res = Executor::new(root, budgeted())
        .configure(|s| s.param(DVector::from_element(1, 1.5)).max_iters(50))
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::ZeroResidual));
    let x = res.state.get_param().unwrap()[0];
    assert!(
        (x - std::f64::consts::SQRT_2).abs() <= 2.0 * f64::EPSILON,
        "{x}"
    );
    assert!(
        res.state.get_cost() > 0.0,
        "a round-off residual, not an exact zero"
    );
}

/// At x = 0 the step-size test Δ ≤ xtol (‖D x‖ + xtol) is Δ ≤ xtol²: from the origin, a
/// problem whose every trial point fails shrinks the trust region (by 10 a rejection, from a
/// first bound of about the step's length 1) until it is below xtol² = 1e-6, a stop after a
/// handful of evaluations. The origin is not stationary there: stalled.
#[test]
fn at_the_origin_the_trust_region_stops_below_xtol_squared() {
    let cliff = Functions {
        residuals: |x| {
            if x[0] != 0.0 {
                return Err(Error::msg("only the origin can be evaluated"));
            }
            Ok(DVector::from_element(1, x[0] - 1.0))
        },
        jacobian: |_| DMatrix::from_element(1, 1, 1.0),
    };
    let solver = budgeted().with_xtol(1e-3).unwrap();
    let res = Executor::new(cliff, solver)
        .configure(|s| s.param(DVector::from_element(1, 0.0)).max_iters(50))
        .run()
        .unwrap();
    assert_eq!(res.solver.stop_reason(), Some(StopReason::Stalled));
    let evaluations = res.solver.evaluations();
    assert!((6..=9).contains(&evaluations), "{evaluations} evaluations");
}
