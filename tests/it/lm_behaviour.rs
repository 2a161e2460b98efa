//! Levenberg–Marquardt behaviour seen from outside, against the `levenberg-marquardt` crate (a
//! MINPACK port): the same minimiser and the same number of residual evaluations from the
//! standard start and from x₀ = 0 (where the first trust region comes from the step bound
//! alone), the stop at an exactly zero residual reached inside the loop, and the stop when
//! the tolerances are below machine precision.
use crate::support::Minpack;
use argmin::core::{Error, Executor, Jacobian, Operator, State, TerminationReason};
use legwise::solver::levenberg_marquardt::LevenbergMarquardt;
use legwise::solver::stop::StopReason;
use nalgebra::{DMatrix, DVector};

/// A least-squares problem with analytic residuals and a row-major Jacobian.
#[derive(Clone, Copy)]
struct Problem {
    m: usize,
    n: usize,
    res: fn(&[f64]) -> Vec<f64>,
    jac: fn(&[f64]) -> Vec<f64>,
}

impl Operator for Problem {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_vec((self.res)(x.as_slice())))
    }
}

impl Jacobian for Problem {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        let values = (self.jac)(x.as_slice());
        Ok(DMatrix::from_row_slice(self.m, self.n, &values))
    }
}

struct Outcome {
    x: DVector<f64>,
    cost: f64,
    iterations: u64,
    residual_evaluations: u64,
    jacobian_evaluations: u64,
    reason: TerminationReason,
    stop: Option<StopReason>,
}

fn ours(p: Problem, x0: &[f64], tolerance: f64) -> Outcome {
    // The evaluation budget only bounds a broken solver (whose trust region never shrinks
    // enough for a step to pass): these runs take a few dozen evaluations.
    let lm = LevenbergMarquardt::new()
        .with_ftol(tolerance)
        .and_then(|l| l.with_xtol(tolerance))
        .and_then(|l| l.with_max_evaluations(10_000))
        .unwrap();
    let x0 = DVector::from_column_slice(x0);
    let result = Executor::new(p, lm)
        .configure(|s| s.param(x0).max_iters(1000).counting(true))
        .run()
        .unwrap();
    let state = result.state();
    let count = |k: &str| state.get_func_counts().get(k).copied().unwrap_or(0);
    Outcome {
        x: state.get_best_param().unwrap().clone(),
        cost: state.get_best_cost(),
        iterations: state.get_iter(),
        residual_evaluations: count("operator_count"),
        jacobian_evaluations: count("jacobian_count"),
        reason: state.get_termination_reason().unwrap().clone(),
        stop: result.solver.stop_reason(),
    }
}

/// The crate's minimiser, cost and residual evaluations (its count includes the start).
fn minpack(p: Problem, x0: &[f64], tolerance: f64) -> (DVector<f64>, f64, usize) {
    let (fitted, report) = levenberg_marquardt::LevenbergMarquardt::new()
        .with_ftol(tolerance)
        .with_xtol(tolerance)
        .with_gtol(0.0)
        .with_patience(10_000)
        .minimize(Minpack(p, DVector::from_column_slice(x0)));
    (
        fitted.1,
        report.objective_function,
        report.number_of_evaluations,
    )
}

fn rosenbrock() -> Problem {
    Problem {
        m: 2,
        n: 2,
        res: |x| vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]],
        jac: |x| vec![-20.0 * x[0], 10.0, -1.0, 0.0],
    }
}

/// `y = a·exp(−b t) + c` on 12 points with a deterministic ±0.01 perturbation (non-zero
/// residual at the minimum).
fn exp_decay() -> Problem {
    fn data(i: usize) -> (f64, f64) {
        let t = 0.5 * i as f64;
        let y = 3.0 * (-0.7 * t).exp() + 0.5 + 0.01 * (1.7 * i as f64).sin();
        (t, y)
    }
    Problem {
        m: 12,
        n: 3,
        res: |x| {
            (0..12)
                .map(|i| {
                    let (t, y) = data(i);
                    x[0] * (-x[1] * t).exp() + x[2] - y
                })
                .collect()
        },
        jac: |x| {
            (0..12)
                .flat_map(|i| {
                    let (t, _) = data(i);
                    let e = (-x[1] * t).exp();
                    [e, -x[0] * t * e, 1.0]
                })
                .collect()
        },
    }
}

fn assert_same_run(name: &str, p: Problem, x0: &[f64], tolerance: f64) -> Outcome {
    let out = ours(p, x0, tolerance);
    let (x, cost, evaluations) = minpack(p, x0, tolerance);
    let difference = (&out.x - &x).amax();
    assert!(difference <= 1e-10, "{name}: x {} vs {x}", out.x);
    assert!(
        (out.cost - cost).abs() <= 1e-12 * cost.max(1e-300),
        "{name}: cost {} vs {cost}",
        out.cost
    );
    assert_eq!(
        out.residual_evaluations as usize, evaluations,
        "{name}: residual evaluations"
    );
    // One Jacobian per iteration.
    assert_eq!(out.jacobian_evaluations, out.iterations, "{name}");
    out
}

#[test]
fn same_minimiser_and_evaluation_counts_as_minpack() {
    assert_same_run("Rosenbrock", rosenbrock(), &[-1.2, 1.0], 1e-12);
    assert_same_run("exponential decay", exp_decay(), &[1.0, 1.0, 0.0], 1e-12);
    assert_same_run("exponential decay", exp_decay(), &[1.0, 1.0, 0.0], 1e-8);
}

#[test]
fn a_start_at_the_origin_takes_its_first_trust_region_from_the_step_bound() {
    let out = assert_same_run("Rosenbrock from 0", rosenbrock(), &[0.0, 0.0], 1e-12);
    assert!((out.x[0] - 1.0).abs() < 1e-12 && (out.x[1] - 1.0).abs() < 1e-12);
    assert_same_run(
        "exponential decay from 0",
        exp_decay(),
        &[0.0, 0.5, 0.0],
        1e-12,
    );
}

#[test]
fn an_exact_zero_residual_reached_in_the_loop_stops_at_once() {
    // A consistent linear system: the first (undamped Gauss–Newton) step lands exactly on the
    // solution (2, −1), with integer arithmetic, so the cost is exactly 0 after one iteration.
    let p = Problem {
        m: 3,
        n: 2,
        res: |x| vec![x[0] - 2.0, x[1] + 1.0, x[0] + x[1] - 1.0],
        jac: |_| vec![1.0, 0.0, 0.0, 1.0, 1.0, 1.0],
    };
    let out = ours(p, &[1.0, 1.0], 1e-12);
    assert_eq!(out.reason, TerminationReason::SolverConverged);
    assert_eq!(out.stop, Some(StopReason::ZeroResidual));
    assert_eq!(out.x.as_slice(), &[2.0, -1.0]);
    assert_eq!(out.cost.to_bits(), 0.0f64.to_bits());
    assert_eq!(
        (
            out.iterations,
            out.jacobian_evaluations,
            out.residual_evaluations
        ),
        (1, 1, 2)
    );
}

#[test]
fn tolerances_below_machine_precision_stop_at_the_minimum() {
    for (x0, name) in [([1.0, 1.0, 0.0], "standard"), ([2.0, 0.5, 1.0], "other")] {
        let out = ours(exp_decay(), &x0, 1e-300);
        let (x, _, _) = minpack(exp_decay(), &x0, 1e-12);
        assert!((&out.x - &x).amax() <= 1e-9, "{name}: {} vs {x}", out.x);
        assert_eq!(out.stop, Some(StopReason::ToleranceTooSmall), "{name}");
        assert!(
            out.iterations < 100,
            "{name}: {} iterations",
            out.iterations
        );
    }
}
