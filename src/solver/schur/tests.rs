//! Unit tests of the Schur-complement Levenberg–Marquardt solver: parameter validation, usage
//! errors, the stopping tests, groups without own or shared unknowns and singular blocks.
//! The step against the dense solve and whole nonlinear solves are in tests/it/schur.rs.

use super::*;
use crate::solver::bordered::{to_dense, BorderedBlock};
use crate::solver::observed::{count, float, Iterations};
use argmin::core::observers::ObserverMode;
use argmin::core::Executor;
use nalgebra::DMatrix;

fn text(err: Error) -> String {
    match err.downcast_ref::<ArgminError>() {
        Some(ArgminError::InvalidParameter { text }) => text.clone(),
        _ => panic!("unexpected error {err}"),
    }
}

#[test]
fn builder_validates() {
    let lm = SchurLevenbergMarquardt::new;
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let msg = "Schur Levenberg-Marquardt: ftol must be positive and finite.";
        assert_eq!(text(lm().with_ftol(bad).unwrap_err()), msg);
        let msg = "Schur Levenberg-Marquardt: xtol must be positive and finite.";
        assert_eq!(text(lm().with_xtol(bad).unwrap_err()), msg);
        let msg = "Schur Levenberg-Marquardt: initial damping must be positive and finite.";
        assert_eq!(text(lm().with_initial_damping(bad).unwrap_err()), msg);
    }
    for bad in [-1e-300, f64::NAN, f64::INFINITY] {
        let msg = "Schur Levenberg-Marquardt: gtol must be non-negative and finite.";
        assert_eq!(text(lm().with_gtol(bad).unwrap_err()), msg);
        let msg =
            "Schur Levenberg-Marquardt: stationarity tolerance must be non-negative and finite.";
        assert_eq!(
            text(lm().with_stationarity_tolerance(bad).unwrap_err()),
            msg
        );
    }
    assert!(lm().with_max_evaluations(0).is_err());
    let ok = lm()
        .with_ftol(1e-3)
        .and_then(|l| l.with_xtol(1e-4))
        .unwrap();
    assert_eq!(
        (ok.tolerances.ftol, ok.tolerances.xtol, ok.tolerances.gtol),
        (1e-3, 1e-4, 0.0)
    );
}

#[test]
fn send_sync_clone() {
    fn assert_traits<T: Send + Sync + Clone + std::fmt::Debug>() {}
    assert_traits::<SchurLevenbergMarquardt>();
}

/// A linear bordered problem `r = J x − y` with constant blocks (`blocks[k].residuals` holds
/// `y_k`); `nan_jacobian` makes every block NaN.
#[derive(Clone)]
struct Linear {
    layout: BorderedLayout,
    blocks: Vec<BorderedBlock>,
    nan_jacobian: bool,
    /// Claims a layout the blocks do not fit (same number of unknowns).
    wrong_layout: bool,
}

impl Linear {
    fn dense(&self) -> (DVector<f64>, DMatrix<f64>) {
        to_dense(&self.layout, &self.blocks)
    }
}

impl Operator for Linear {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let (y, j) = self.dense();
        Ok(j * x - y)
    }
}

impl BorderedLeastSquares for Linear {
    fn layout(&self) -> BorderedLayout {
        if self.wrong_layout {
            return BorderedLayout {
                own: vec![2, 0, 1],
                shared: 3,
            };
        }
        self.layout.clone()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        let r = self.apply(x)?;
        let mut row = 0;
        let nan = if self.nan_jacobian { f64::NAN } else { 1.0 };
        Ok(self
            .blocks
            .iter()
            .map(|b| {
                let m = b.residuals.len();
                row += m;
                BorderedBlock {
                    residuals: r.rows(row - m, m).into_owned(),
                    own: &b.own * nan,
                    shared: b.shared.clone(),
                }
            })
            .collect())
    }
}

fn block(rows: usize, y: &[f64], own: &[f64], shared: &[f64]) -> BorderedBlock {
    BorderedBlock {
        residuals: DVector::from_column_slice(y),
        own: DMatrix::from_row_slice(rows, own.len() / rows.max(1), own),
        shared: DMatrix::from_row_slice(rows, shared.len() / rows.max(1), shared),
    }
}

/// Two groups with two own unknowns, a group with none, two shared unknowns; inconsistent data
/// (a non-zero residual at the minimum).
fn linear() -> Linear {
    Linear {
        layout: BorderedLayout {
            own: vec![2, 0, 2],
            shared: 2,
        },
        blocks: vec![
            block(
                3,
                &[1.0, 2.0, 0.5],
                &[1.0, 0.0, 0.5, 2.0, 1.0, 1.0],
                &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            ),
            block(2, &[0.3, -0.2], &[], &[1.0, 2.0, -1.0, 1.0]),
            block(
                3,
                &[-1.0, 0.0, 4.0],
                &[2.0, 1.0, 0.0, 1.0, 1.0, -1.0],
                &[0.0, 1.0, 1.0, 0.0, 2.0, 2.0],
            ),
        ],
        nan_jacobian: false,
        wrong_layout: false,
    }
}

fn run(
    problem: Linear,
    x0: DVector<f64>,
    solver: SchurLevenbergMarquardt,
) -> Result<(SchurState, SchurLevenbergMarquardt), Error> {
    let result = Executor::new(problem, solver)
        .configure(|s| s.param(x0).max_iters(200))
        .run()?;
    Ok((result.state, result.solver))
}

fn exit_text(state: &SchurState) -> String {
    match state.get_termination_reason() {
        Some(TerminationReason::SolverExit(t)) => t.clone(),
        other => panic!("expected SolverExit, got {other:?}"),
    }
}

/// The minimiser of the linear problem (a group without own unknowns included) is the dense
/// least-squares solution (SVD), and the stop is a convergence of the cost reduction.
#[test]
fn a_linear_problem_converges_to_the_least_squares_solution() {
    let problem = linear();
    let (y, j) = problem.dense();
    let expected = j.clone().svd(true, true).solve(&y, 1e-14).unwrap();
    let solver = SchurLevenbergMarquardt::new()
        .with_ftol(1e-12)
        .and_then(|l| l.with_xtol(1e-12))
        .unwrap();
    let (state, solver) = run(problem, DVector::zeros(6), solver).unwrap();
    let x = state.get_param().unwrap();
    // The cost-reduction test resolves the parameters to about √ftol (the damped steps
    // contract the error by ~λ each); the refinement of `solve_bordered` does the rest.
    assert!((x - &expected).amax() <= 1e-7, "{x} vs {expected}");
    assert_eq!(solver.stop_reason(), Some(StopReason::CostReduction));
    assert_eq!(
        state.get_termination_reason(),
        Some(&TerminationReason::SolverConverged)
    );
    let minimum = 0.5 * (&j * &expected - &y).norm_squared();
    assert!((state.get_cost() - minimum).abs() <= 1e-12 * minimum);
    let refined = crate::solver::solve_bordered(&linear(), DVector::zeros(6)).unwrap();
    assert!(
        refined.converged && refined.refinement_steps >= 1,
        "{refined:?}"
    );
    assert!((&refined.x - &expected).amax() <= 1e-12, "{refined:?}");
}

#[test]
fn usage_errors_and_non_finite_values() {
    let problem = linear();
    let err = run(
        problem.clone(),
        DVector::zeros(5),
        SchurLevenbergMarquardt::new(),
    );
    let err = err.unwrap_err().to_string();
    assert!(
        err.contains("has length 5, the layout has 6 unknowns"),
        "{err}"
    );
    let wrong = Linear {
        wrong_layout: true,
        ..problem.clone()
    };
    let err = run(wrong, DVector::zeros(6), SchurLevenbergMarquardt::new());
    let err = err.unwrap_err().to_string();
    assert!(
        err.contains("group 0's shared block is 3×2, expected 3×3"),
        "{err}"
    );
    let mut nan_start = problem.clone();
    nan_start.blocks[1].residuals[0] = f64::NAN;
    let (state, solver) =
        run(nan_start, DVector::zeros(6), SchurLevenbergMarquardt::new()).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::NonFinite));
    assert_eq!(
        exit_text(&state),
        "Schur Levenberg-Marquardt: residual vector contains NaN or infinity at the initial point."
    );
    let nan = Linear {
        nan_jacobian: true,
        ..problem
    };
    let (state, solver) = run(nan, DVector::zeros(6), SchurLevenbergMarquardt::new()).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::NonFinite));
    assert_eq!(
        exit_text(&state),
        "Schur Levenberg-Marquardt: Jacobian blocks contain NaN or infinity."
    );
}

#[test]
fn an_exact_start_and_a_spent_budget() {
    let mut problem = linear();
    let x = DVector::from_column_slice(&[1.0, -1.0, 2.0, 0.5, 0.25, 3.0]);
    let exact = problem.dense().1 * &x;
    let mut row = 0;
    for b in &mut problem.blocks {
        let m = b.residuals.len();
        b.residuals.copy_from(&exact.rows(row, m));
        row += m;
    }
    let (state, solver) = run(problem, x, SchurLevenbergMarquardt::new()).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::ZeroResidual));
    assert_eq!((state.get_iter(), solver.evaluations()), (0, 1));
    let budget = SchurLevenbergMarquardt::new()
        .with_max_evaluations(3)
        .unwrap();
    let (state, solver) = run(linear(), DVector::zeros(6), budget).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::EvaluationBudget));
    assert_eq!(solver.evaluations(), 3);
    assert!(matches!(
        state.get_termination_reason(),
        Some(TerminationReason::SolverExit(_))
    ));
}

/// One group with one own unknown, and one shared unknown.
fn one_own_one_shared() -> BorderedLayout {
    BorderedLayout {
        own: vec![1],
        shared: 1,
    }
}

/// The block of [`one_own_one_shared`] with two rows: residuals `r`, own column `own`, shared
/// column `shared`.
fn two_rows(r: DVector<f64>, own: [f64; 2], shared: [f64; 2]) -> Vec<BorderedBlock> {
    vec![BorderedBlock {
        residuals: r,
        own: DMatrix::from_column_slice(2, 1, &own),
        shared: DMatrix::from_column_slice(2, 1, &shared),
    }]
}

/// `r = (x₀ − 1, 2 + e^{−s})` (one group with one own unknown, one shared unknown) has no
/// minimum: progress stops with the residual along the shared column (cosine 1): stalled.
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
impl BorderedLeastSquares for NoMinimum {
    fn layout(&self) -> BorderedLayout {
        one_own_one_shared()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        Ok(two_rows(self.apply(x)?, [1.0, 0.0], [0.0, -(-x[1]).exp()]))
    }
}

#[test]
fn progress_stopping_away_from_a_stationary_point_is_stalled() {
    let solver = SchurLevenbergMarquardt::new()
        .with_ftol(1e-12)
        .and_then(|l| l.with_xtol(1e-12))
        .unwrap();
    let result = Executor::new(NoMinimum, solver)
        .configure(|s| s.param(DVector::zeros(2)).max_iters(1000))
        .run()
        .unwrap();
    let x = result.state.get_param().unwrap();
    assert_eq!(
        result.solver.stop_reason(),
        Some(StopReason::Stalled),
        "{x}"
    );
    assert!((x[0] - 1.0).abs() < 1e-6 && x[1] > 10.0, "{x}");
}

/// Without shared unknowns each group's step is its own damped solve; a rank-deficient group
/// (two equal columns) has no undamped step (a clear error, not NaN) but a finite damped one.
#[test]
fn independent_groups_and_a_singular_block() {
    let layout = BorderedLayout {
        own: vec![2, 1],
        shared: 0,
    };
    let blocks = vec![
        block(3, &[1.0, 2.0, 3.0], &[1.0, 1.0, 2.0, 2.0, 0.5, 0.5], &[]),
        block(2, &[1.0, -1.0], &[2.0, 1.0], &[]),
    ];
    let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
    let scale = DVector::from_column_slice(&[2.0, 3.0, 0.5]);
    assert_eq!(
        system.damped_step(0.0, &scale),
        Err(arrowhead::SingularBlock::Group(0))
    );
    let lambda = 0.1;
    let step = system.damped_step(lambda, &scale).unwrap();
    // Group 0: [[5.25, 5.25], [5.25, 5.25]] + 0.1·diag(4, 9), gradient (6.5, 6.5).
    let a = DMatrix::from_row_slice(2, 2, &[5.65, 5.25, 5.25, 6.15]);
    let own = a
        .lu()
        .solve(&DVector::from_column_slice(&[6.5, 6.5]))
        .unwrap();
    assert!((step.rows(0, 2) - own).amax() <= 1e-14, "{step}");
    // Group 1: (5 + 0.1·0.25) p = 2 − 1.
    assert!((step[2] - 1.0 / 5.025).abs() <= 1e-15, "{step}");
}

/// [`Linear`] whose residuals fail at the listed evaluations (1 = the start).
#[derive(Clone)]
struct FailingAt {
    inner: Linear,
    calls: std::sync::Arc<std::sync::atomic::AtomicU64>,
    failing: Vec<u64>,
}

impl Operator for FailingAt {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let call = 1 + self.calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        if self.failing.contains(&call) {
            return Err(Error::msg("out of reach"));
        }
        self.inner.apply(x)
    }
}

impl BorderedLeastSquares for FailingAt {
    fn layout(&self) -> BorderedLayout {
        self.inner.layout()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        self.inner.bordered(x)
    }
}

/// The iterates of the damped Gauss–Newton recursion `x ← x − (JᵀJ + λ_k D²)⁻¹ Jᵀ(J x − y)`
/// on the linear problem, `D` its column norms, by dense LU.
fn recursion(lambdas: &[f64]) -> DVector<f64> {
    let (y, j) = linear().dense();
    let d2 = j.row_iter().fold(DVector::zeros(j.ncols()), |acc, row| {
        acc + row.transpose().map(|v| v * v)
    });
    let mut x = DVector::zeros(j.ncols());
    for &lambda in lambdas {
        let normal = j.transpose() * &j + DMatrix::from_diagonal(&(&d2 * lambda));
        let gradient = j.transpose() * (&j * &x - &y);
        x -= normal.lu().solve(&gradient).unwrap();
    }
    x
}

/// An accepted step divides `λ` by 3 down to `ε²` and no further (a multiplicative update
/// could otherwise underflow to zero and never recover): from `λ₀ = 1e-31` the first
/// iteration's `λ` after its step is `max(λ₀/3, ε²) = ε²`, and the iterate is the damped
/// Gauss–Newton recursion with `1e-31` and then `ε²`.
#[test]
fn the_damping_stops_at_epsilon_squared() {
    let initial = 1e-31;
    let floor = f64::EPSILON * f64::EPSILON;
    assert!(initial / 3.0 < floor);
    let solver = SchurLevenbergMarquardt::new()
        .with_initial_damping(initial)
        .unwrap();
    let iterations = Iterations::default();
    let seen = iterations.0.clone();
    let result = Executor::new(linear(), solver)
        .configure(|s| s.param(DVector::zeros(6)).max_iters(2))
        .add_observer(iterations, ObserverMode::Always)
        .run()
        .unwrap();
    let lambdas: Vec<f64> = seen
        .borrow()
        .iter()
        .map(|(_, kv)| float(kv, "lambda"))
        .collect();
    assert_eq!(lambdas.first(), Some(&floor));
    let x = result.state.get_param().unwrap();
    let expected = recursion(&[initial, floor][..lambdas.len()]);
    assert!((x - &expected).amax() <= 1e-12 * expected.amax());
}

/// On a linear problem every step's gain ratio is exactly 1, so an accepted step divides `λ`
/// by 3 (`max(⅓, 1 − (2ρ − 1)³)`), and a rejected one (a trial point whose residuals fail)
/// multiplies it by `ν` = 2, 4, 8, … : after three iterations the iterate is the damped
/// Gauss–Newton recursion with those damping factors, `D` the column norms.
#[test]
fn the_damping_follows_nielsens_rule() {
    let cases: [(&[u64], [f64; 3]); 4] = [
        (&[], [1.0, 1.0 / 3.0, 1.0 / 9.0]),
        (&[2], [2.0, 2.0 / 3.0, 2.0 / 9.0]),
        (&[2, 3], [8.0, 8.0 / 3.0, 8.0 / 9.0]),
        (&[2, 3, 4], [64.0, 64.0 / 3.0, 64.0 / 9.0]),
    ];
    for (failing, factors) in cases {
        for initial in [0.05, 0.5] {
            let problem = FailingAt {
                inner: linear(),
                calls: Default::default(),
                failing: failing.to_vec(),
            };
            let solver = SchurLevenbergMarquardt::new()
                .with_initial_damping(initial)
                .unwrap();
            let iterations = Iterations::default();
            let seen = iterations.0.clone();
            let result = Executor::new(problem, solver)
                .configure(|s| s.param(DVector::zeros(6)).max_iters(3))
                .add_observer(iterations, ObserverMode::Always)
                .run()
                .unwrap();
            let x = result.state.get_param().unwrap();
            let expected = recursion(&factors.map(|f| f * initial));
            assert!(
                (x - &expected).amax() <= 1e-12 * expected.amax(),
                "{failing:?} λ₀ {initial}: {x} vs {expected}"
            );
            assert_eq!(result.solver.stop_reason(), None);
            assert_eq!(result.solver.evaluations(), 4 + failing.len() as u64);
            // What an observer sees: each iteration's trials (the failing calls all fall in the
            // first iteration, one more trial each), its accepted step's ratio 1 (to the
            // round-off of 1 − (‖r₁‖/‖r‖)²), and λ divided by 3 after it.
            let seen = seen.borrow();
            assert_eq!(seen.len(), 3);
            for (k, (_, kv)) in seen.iter().enumerate() {
                let trials = if k == 0 { 1 + failing.len() as u64 } else { 1 };
                assert_eq!(count(kv, "trials"), trials, "{failing:?} iteration {k}");
                let ratio = float(kv, "ratio");
                assert!(
                    (ratio - 1.0).abs() < 1e-9,
                    "{failing:?} iteration {k}: ratio {ratio}"
                );
                let lambda = factors[k] * initial / 3.0;
                assert!((float(kv, "lambda") - lambda).abs() <= 1e-14 * lambda);
            }
        }
    }
}

#[test]
fn the_gradient_and_stationarity_tolerances() {
    // gtol 1: every point passes the gradient test, before any step.
    let solver = SchurLevenbergMarquardt::new().with_gtol(1.0).unwrap();
    let (state, solver) = run(linear(), DVector::zeros(6), solver).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::Gradient));
    assert_eq!(state.get_param().unwrap(), &DVector::zeros(6));
    assert_eq!(solver.evaluations(), 1);
    // A stationarity tolerance of 1 calls any progress stop a convergence: the plateau of
    // `NoMinimum` then stops with a cost-reduction or step convergence instead of a stall.
    let solver = SchurLevenbergMarquardt::new()
        .with_ftol(1e-12)
        .and_then(|l| l.with_xtol(1e-12))
        .and_then(|l| l.with_stationarity_tolerance(1.0))
        .unwrap();
    let result = Executor::new(NoMinimum, solver)
        .configure(|s| s.param(DVector::zeros(2)).max_iters(1000))
        .run()
        .unwrap();
    let reason = result.solver.stop_reason().unwrap();
    assert!(reason.is_convergence(), "{reason:?}");
    assert_eq!(
        <SchurLevenbergMarquardt as Solver<NoMinimum, SchurState>>::name(&result.solver),
        "Schur Levenberg-Marquardt"
    );
}

/// A shared column equal to the group's own column: the group's block is regular but the
/// reduced shared system is singular without damping (a clear error); damped, the step is
/// the closed form of `[[5 + 5λ, 5], [5, 5 + 5λ]] p = (3, 3)`: `p₀ = p₁ = 3 / (10 + 5λ)`.
#[test]
fn a_shared_unknown_duplicating_an_own_one_is_singular_only_undamped() {
    let layout = one_own_one_shared();
    let blocks = vec![block(2, &[1.0, 1.0], &[1.0, 2.0], &[1.0, 2.0])];
    let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
    let scale = DVector::from_element(2, 5.0_f64.sqrt());
    let singular = system.damped_step(0.0, &scale);
    assert_eq!(singular, Err(arrowhead::SingularBlock::Shared));
    assert_eq!(
        singular.unwrap_err().to_string(),
        "the reduced shared system is singular"
    );
    assert_eq!(
        arrowhead::SingularBlock::Group(3).to_string(),
        "group 3's damped block is singular"
    );
    let step = system.damped_step(0.2, &scale).unwrap();
    assert!((step[0] - 3.0 / 11.0).abs() <= 1e-15, "{step}");
    assert!((step[1] - 3.0 / 11.0).abs() <= 1e-15, "{step}");
}

/// One group of two rows and `own` own unknowns, no shared one: `r = J x − y`.
fn single_group(own: &[f64], y: &[f64]) -> Linear {
    Linear {
        layout: BorderedLayout {
            own: vec![own.len() / 2],
            shared: 0,
        },
        blocks: vec![block(2, y, own, &[])],
        nan_jacobian: false,
        wrong_layout: false,
    }
}

/// `r = (x₀ − 1, x₀ + 1)`: the residuals ignore `x₁` (a zero Jacobian column). Its scale is
/// 1, as MINPACK's, not 0: damped by `λ·1`, the step along it is 0 and the fit converges
/// with `x₁` untouched. (Scaled by 0, its damped block would stay singular whatever `λ`.)
#[test]
fn a_parameter_the_residuals_ignore_is_scaled_by_one_and_left_alone() {
    let problem = single_group(&[1.0, 0.0, 1.0, 0.0], &[1.0, -1.0]);
    let (state, solver) = run(
        problem,
        DVector::from_column_slice(&[-3.0, 5.0]),
        SchurLevenbergMarquardt::new(),
    )
    .unwrap();
    assert!(solver.stop_reason().unwrap().is_convergence());
    let x = state.get_param().unwrap();
    assert!(x[0].abs() < 1e-8, "{x}");
    assert_eq!(x[1].to_bits(), 5.0f64.to_bits(), "{x}");
    assert_eq!(solver.diag.as_slice(), &[2f64.sqrt(), 1.0]);
}

/// `r = (x − c − 1, x − c + 1)` from `x₀ = c + 0.01`: the gradient cosine is 0.01 (above the
/// stationarity tolerance 1e-3) and the first step's reductions (1e-4) are within
/// `ftol = 1e-3`: a progress stop. Its Gauss–Newton step, `‖D p‖ = 0.01·√2`, is below
/// `√ε (‖D x‖ + √ε)` = 2.1e-2 for `c = 10⁶` (a stationary point at the parameters' scale: a
/// convergence) and far above it (2e-8) for `c = 1`: stalled.
#[test]
fn a_negligible_gauss_newton_step_relative_to_the_parameters_is_stationary() {
    for (c, expected) in [(1e6, StopReason::CostReduction), (1.0, StopReason::Stalled)] {
        let problem = single_group(&[1.0, 1.0], &[c + 1.0, c - 1.0]);
        let solver = SchurLevenbergMarquardt::new().with_ftol(1e-3).unwrap();
        let (state, solver) = run(problem, DVector::from_element(1, c + 0.01), solver).unwrap();
        assert_eq!(solver.stop_reason(), Some(expected), "c = {c}");
        let x = state.get_param().unwrap()[0];
        // One step damped by λ₀ = 1e-3: x = c + 0.01 − 0.01/(1 + 1e-3).
        assert!(
            (x - c - 0.01 * (1.0 - 1.0 / 1.001)).abs() < 1e-9 * c,
            "c = {c}: {x}"
        );
    }
}

/// At x = 0 the stationarity floor `√ε (‖D x‖ + √ε)` is ε itself: from the origin, a
/// Gauss–Newton step of about 1e-16 on `r = (x − 1e-16 − 1e-14, x − 1e-16 + 1e-14)` is
/// stationary, so the progress stop it ends with (`ftol = 1e-3`) is a convergence, not a
/// stall (the gradient cosine, 1e-2, is above the stationarity tolerance: the step decides).
#[test]
fn at_the_origin_a_step_below_epsilon_is_stationary() {
    let problem = single_group(&[1.0, 1.0], &[1e-16 + 1e-14, 1e-16 - 1e-14]);
    let solver = SchurLevenbergMarquardt::new().with_ftol(1e-3).unwrap();
    let (state, solver) = run(problem, DVector::zeros(1), solver).unwrap();
    assert_eq!(solver.stop_reason(), Some(StopReason::CostReduction));
    let x = state.get_param().unwrap()[0];
    // One step damped by λ₀ = 1e-3.
    assert!((x - 1e-16 / 1.001).abs() < 1e-28, "{x}");
}

/// Every trial point failing: each rejection multiplies `λ` by `ν` (2, 4, 8, …), and the run
/// stops with a damping overflow as soon as `λ` is no longer finite (long before `ν` is):
/// one residual evaluation per rejected trial, and one more trial that sees the overflow.
/// (The data are scaled by 1e150 so that ‖D p‖ ≈ 1e150/λ stays representable up to the
/// overflow: for data of order 1 its square underflows near λ = 1e154 and the shrinking step
/// ends the run first.)
#[test]
fn rejections_end_in_a_damping_overflow() {
    let (mut lambda, mut nu, mut rejections) = (1e-3_f64, 2.0_f64, 0_u64);
    while lambda.is_finite() {
        lambda *= nu;
        nu *= 2.0;
        rejections += 1;
    }
    assert!(nu.is_finite());
    let mut inner = linear();
    for block in &mut inner.blocks {
        block.residuals *= 1e150;
    }
    let problem = FailingAt {
        inner,
        calls: Default::default(),
        failing: (2..=1000).collect(),
    };
    let iterations = Iterations::default();
    let seen = iterations.0.clone();
    // No step-size or cost-reduction stop on the way (the steps shrink as λ grows).
    let solver = SchurLevenbergMarquardt::new()
        .with_xtol(f64::MIN_POSITIVE)
        .and_then(|l| l.with_ftol(f64::MIN_POSITIVE))
        .unwrap();
    let result = Executor::new(problem, solver)
        .configure(|s| s.param(DVector::zeros(6)).max_iters(10))
        .add_observer(iterations, ObserverMode::Always)
        .run()
        .unwrap();
    assert_eq!(result.solver.stop_reason(), Some(StopReason::NonFinite));
    assert_eq!(
        exit_text(&result.state),
        "Schur Levenberg-Marquardt: damping factor overflow."
    );
    assert_eq!(result.solver.evaluations(), 1 + rejections);
    let seen = seen.borrow();
    assert_eq!(seen.len(), 1);
    assert_eq!(count(&seen[0].1, "trials"), rejections + 1);
}

/// [`Linear`] that records every point its residuals are evaluated at, and whose residual
/// vector loses its last entry after `full_calls` evaluations.
#[derive(Clone)]
struct Recording {
    inner: Linear,
    points: std::sync::Arc<std::sync::Mutex<Vec<DVector<f64>>>>,
    full_calls: usize,
}

impl Operator for Recording {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let mut points = self.points.lock().unwrap();
        points.push(x.clone());
        let r = self.inner.apply(x)?;
        Ok(if points.len() > self.full_calls {
            r.rows(0, r.len() - 1).into_owned()
        } else {
            r
        })
    }
}

impl BorderedLeastSquares for Recording {
    fn layout(&self) -> BorderedLayout {
        self.inner.layout()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        self.inner.bordered(x)
    }
}

/// `r = J x − y` with `J = (1e-160, 1e-160)ᵀ`, `y = (1e150, 1e150)`: the undamped step
/// `(JᵀJ)⁻¹Jᵀr` is about 1e310, beyond the largest double. A step that is not finite is
/// rejected without evaluating the residuals there (more damping instead), so every point
/// evaluated is finite.
#[test]
fn a_step_that_overflows_is_damped_without_an_evaluation() {
    let problem = Recording {
        inner: single_group(&[1e-160, 1e-160], &[1e150, 1e150]),
        points: Default::default(),
        full_calls: usize::MAX,
    };
    let points = problem.points.clone();
    let result = Executor::new(problem, SchurLevenbergMarquardt::new())
        .configure(|s| s.param(DVector::zeros(1)).max_iters(3))
        .run()
        .unwrap();
    let points = points.lock().unwrap();
    assert!(points.len() > 1, "a step was evaluated");
    assert!(
        points.iter().all(|x| x.iter().all(|v| v.is_finite())),
        "{points:?}"
    );
    assert!(result.solver.evaluations() as usize == points.len());
}

/// A problem whose residual vector changes length at a trial point breaks the solver's
/// contract: a clear error, not a step.
#[test]
fn a_trial_residual_of_another_length_is_an_error() {
    let problem = Recording {
        inner: linear(),
        points: Default::default(),
        full_calls: 1,
    };
    let Err(err) = Executor::new(problem, SchurLevenbergMarquardt::new())
        .configure(|s| s.param(DVector::zeros(6)).max_iters(10))
        .run()
    else {
        panic!("a residual vector of another length was accepted");
    };
    let err = err.to_string();
    assert!(
        err.contains("residual vector has length 7, expected 8"),
        "{err}"
    );
}

/// `r = (10 (s − x²), 1 − x)` (Rosenbrock) with `x` a group's own unknown and `s` shared.
#[derive(Clone, Copy)]
struct Rosenbrock;
impl Operator for Rosenbrock {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_column_slice(&[
            10.0 * (x[1] - x[0] * x[0]),
            1.0 - x[0],
        ]))
    }
}
impl BorderedLeastSquares for Rosenbrock {
    fn layout(&self) -> BorderedLayout {
        one_own_one_shared()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        Ok(two_rows(self.apply(x)?, [-20.0 * x[0], -1.0], [10.0, 0.0]))
    }
}

/// On a nonlinear problem the gain ratio ρ of an accepted step varies, and Nielsen's update
/// `λ ← λ·max(⅓, 1 − (2ρ − 1)³)` follows it: recomputed from the ρ an observer sees, for
/// every iteration accepted at its first trial, including ratios far from 1 (where the
/// factor is not ⅓).
#[test]
fn nielsens_update_follows_the_gain_ratio() {
    let iterations = Iterations::default();
    let seen = iterations.0.clone();
    let result = Executor::new(Rosenbrock, SchurLevenbergMarquardt::new())
        .configure(|s| {
            s.param(DVector::from_column_slice(&[-1.2, 1.0]))
                .max_iters(200)
        })
        .add_observer(iterations, ObserverMode::Always)
        .run()
        .unwrap();
    let x = result.state.get_param().unwrap();
    assert!(
        (x[0] - 1.0).abs() < 1e-6 && (x[1] - 1.0).abs() < 1e-6,
        "{x}"
    );
    let seen = seen.borrow();
    let mut lambda = 1e-3;
    let mut away_from_one = 0;
    for (k, (_, kv)) in seen.iter().enumerate() {
        let (ratio, after) = (float(kv, "ratio"), float(kv, "lambda"));
        if count(kv, "trials") == 1 && ratio >= 1e-4 {
            let factor = (1.0 - (2.0 * ratio - 1.0).powi(3)).max(1.0 / 3.0);
            let expected = (lambda * factor).max(f64::EPSILON * f64::EPSILON);
            assert!(
                (after - expected).abs() <= 1e-14 * expected,
                "iteration {k}: ρ = {ratio}, λ = {after}, expected {expected}"
            );
            if factor > 0.4 {
                away_from_one += 1;
            }
        }
        lambda = after;
    }
    assert!(
        away_from_one >= 2,
        "{away_from_one} steps with a factor above ⅓"
    );
}

/// At x = 0 the step-size test `‖D p‖ ≤ xtol (‖D x‖ + xtol)` is `‖D p‖ ≤ xtol²`: with every
/// trial point failing, `λ` grows (×2, ×4, …) until the damped step, recomputed here by a
/// dense solve, is below `xtol² ≈ 2.2e-16`; the run then stops, stalled (the origin is not
/// stationary), after exactly that many trials.
#[test]
fn at_the_origin_the_step_size_test_is_below_xtol_squared() {
    let (y, j) = linear().dense();
    let d2 = j.row_iter().fold(DVector::zeros(j.ncols()), |acc, row| {
        acc + row.transpose().map(|v| v * v)
    });
    let gradient = j.transpose() * -&y;
    let xtol = Tolerances::MINPACK.xtol;
    let (mut lambda, mut nu, mut trials) = (1e-3_f64, 2.0_f64, 0_u64);
    loop {
        trials += 1;
        let normal = j.transpose() * &j + DMatrix::from_diagonal(&(&d2 * lambda));
        let p = normal.lu().solve(&gradient).unwrap();
        if p.component_mul(&d2.map(f64::sqrt)).norm() <= xtol * xtol {
            break;
        }
        lambda *= nu;
        nu *= 2.0;
    }
    assert!(trials > 5, "{trials}");
    let problem = FailingAt {
        inner: linear(),
        calls: Default::default(),
        failing: (2..=1000).collect(),
    };
    let result = Executor::new(problem, SchurLevenbergMarquardt::new())
        .configure(|s| s.param(DVector::zeros(6)).max_iters(10))
        .run()
        .unwrap();
    assert_eq!(result.solver.stop_reason(), Some(StopReason::Stalled));
    assert_eq!(result.solver.evaluations(), 1 + trials);
}

/// Every part of the normal equations is checked: a group's `JᵀJ` that overflows while its
/// gradient does not (`J` = 1e160, `r` = 1), a gradient that overflows while `JᵀJ` does not
/// (`J` = 1e150, `r` = 1e160), and a NaN residual (one group, no shared unknowns, so only the
/// group's own gradient carries it).
#[test]
fn the_normal_equations_are_finite_only_if_every_part_is() {
    let layout = BorderedLayout {
        own: vec![1],
        shared: 0,
    };
    let finite = |own: f64, residual: f64| {
        let blocks = vec![block(2, &[residual, residual], &[own, own], &[])];
        ArrowheadSystem::assemble(&layout, &blocks)
            .unwrap()
            .is_finite()
    };
    assert!(finite(1.0, 1.0));
    assert!(!finite(1e160, 1.0));
    assert!(!finite(1e150, 1e160));
    assert!(!finite(1.0, f64::NAN));
}

/// A shared column that is a multiple of the group's own column: the reduced shared system
/// `S − CᵀA⁻¹C` is zero in exact arithmetic, and what its round-off leaves (up to 1e-14 here)
/// passes nalgebra's factorisation for these multiples but not the pivot tolerance (16 ε
/// times the diagonal it was formed from): a singular shared system, not a step of 1e14.
#[test]
fn a_round_off_pivot_of_the_reduced_system_is_singular() {
    let layout = one_own_one_shared();
    for (a, b, multiple) in [
        (1.0, 3.0, 0.7),
        (1.0, 3.0, 1.0 / 7.0),
        (1.0, 3.0, 1.9),
        (1.0, 7.0, 0.1),
        (0.2, 1.3, 1.0 / 3.0),
    ] {
        let blocks = vec![block(
            2,
            &[1.0, 1.0],
            &[a, b],
            &[a * multiple, b * multiple],
        )];
        let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
        let scale = DVector::from_element(2, 1.0);
        assert_eq!(
            system.damped_step(0.0, &scale),
            Err(arrowhead::SingularBlock::Shared),
            "({a}, {b}) × {multiple}"
        );
    }
}
