//! The Gauss–Newton refinement after a converged solve ([`refine`]), on problems whose every
//! step is known in closed form: r(x) = (x₀ᵖ, x₁ − t, c) has the Gauss–Newton step
//! (x₀/p, x₁ − t), so from x₁ = t the iterates are x₀·(1 − 1/p)ᵏ, and the cost x₀²ᵖ + c² is
//! resolved (c = 0) or lost in the constant (c = 1, the round-off regime where only the steps'
//! contraction counts). The expected step counts follow from the documented rules:
//! first step ≤ 1e-6 (‖x₀‖ + 1); each step no longer than the one before; progress while the
//! cost falls or the step at least halves; stop at a step ≤ 1e-15 (‖x‖ + 1e-15), or at one
//! whose length times its ratio to the one before (the next step's bound) is, after
//! [`MAX_REFINEMENT_STEPS`] or when the budget of residual evaluations is spent.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use argmin::core::{Error, Jacobian, Operator};
use legwise::solver::{
    default_budget, refine, solve, SolverKind, EVALUATIONS_PER_PARAMETER, MAX_REFINEMENT_STEPS,
};
use nalgebra::{DMatrix, DVector};

#[derive(Clone)]
struct Power {
    p: i32,
    /// a in r₀ = a·x₀ᵖ: a power of two, large enough that the Jacobian entry stays above the
    /// SVD's absolute cut-off ε (smaller singular values count as zero: no step).
    gain: f64,
    target: f64,
    constant: f64,
    /// −1 turns the Jacobian's first column around: every step then goes uphill.
    sign: f64,
    residuals: Arc<AtomicU64>,
    jacobians: Arc<AtomicU64>,
}

impl Power {
    fn new(p: i32, target: f64, constant: f64) -> Self {
        Self {
            p,
            gain: 1.0,
            target,
            constant,
            sign: 1.0,
            residuals: Arc::default(),
            jacobians: Arc::default(),
        }
    }

    fn counts(&self) -> (u64, u64) {
        (
            self.residuals.load(Ordering::Relaxed),
            self.jacobians.load(Ordering::Relaxed),
        )
    }
}

impl Operator for Power {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        self.residuals.fetch_add(1, Ordering::Relaxed);
        Ok(DVector::from_column_slice(&[
            self.gain * x[0].powi(self.p),
            x[1] - self.target,
            self.constant,
        ]))
    }
}

impl Jacobian for Power {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        self.jacobians.fetch_add(1, Ordering::Relaxed);
        let d = self.sign * self.gain * f64::from(self.p) * x[0].powi(self.p - 1);
        Ok(DMatrix::from_row_slice(3, 2, &[d, 0.0, 0.0, 1.0, 0.0, 0.0]))
    }
}

fn start(x0: f64, x1: f64) -> DVector<f64> {
    DVector::from_column_slice(&[x0, x1])
}

fn close(actual: f64, expected: f64) -> bool {
    (actual - expected).abs() <= 1e-12 * expected.abs()
}

/// p = 2, ‖x‖ ≈ 3: steps 2⁻²¹, 2⁻²², …, each half the one before; the first whose half is
/// ≤ 1e-15·3 is 2⁻⁴⁸ (its half 2⁻⁴⁹ ≈ 1.8e-15; 2⁻⁴⁸ ≈ 3.6e-15 is not): 28 steps, with the
/// cost falling (c = 0) or, unresolved under c = 1, the steps halving exactly.
#[test]
fn refinement_stops_at_a_round_off_step() {
    for constant in [0.0, 1.0] {
        let problem = Power::new(2, 3.0, constant);
        let refined = refine(&problem, &start(0.5f64.powi(20), 3.0), 1000);
        assert_eq!(refined.steps, 28, "c = {constant}");
        assert!(close(refined.x[0], 0.5f64.powi(48)), "{}", refined.x[0]);
        assert!(close(refined.x[1], 3.0));
        assert_eq!(
            (refined.residual_evaluations, refined.jacobian_evaluations),
            (29, 28)
        );
        assert_eq!(problem.counts(), (29, 28));
    }
}

/// The first step must be ≤ 1e-6 (‖x₀‖ + 1) = 4e-6 here: 2⁻²¹ ≈ 4.8e-7 is, 2⁻¹¹ is not.
#[test]
fn refinement_only_starts_from_a_converged_point() {
    let problem = Power::new(2, 3.0, 0.0);
    let x0 = start(0.5f64.powi(10), 3.0);
    let refined = refine(&problem, &x0, 1000);
    assert_eq!(refined.steps, 0);
    assert_eq!(refined.x, x0);
    assert_eq!(
        (refined.residual_evaluations, refined.jacobian_evaluations),
        (1, 1)
    );
    // 2⁻²¹ is above 1e-6/(‖x₀‖ + 1) = 2.5e-7 but below the bound: it is taken.
    assert_eq!(
        refine(&problem, &start(0.5f64.powi(20), 3.0), 1000).steps,
        28
    );
}

/// Around 0 (x₁ = t = 0) the round-off step would be 2⁻¹⁰⁰: the cap of 50 steps comes first
/// (a = 2⁴⁰ keeps the Jacobian entry 2⁴¹x₀ above ε down to 2⁻⁹³).
#[test]
fn refinement_stops_after_its_step_cap_or_budget() {
    let mut problem = Power::new(2, 0.0, 0.0);
    problem.gain = 2f64.powi(40);
    let refined = refine(&problem, &start(0.5f64.powi(20), 0.0), 1000);
    assert_eq!(refined.steps, MAX_REFINEMENT_STEPS);
    assert_eq!(MAX_REFINEMENT_STEPS, 50);
    assert!(close(refined.x[0], 0.5f64.powi(70)), "{}", refined.x[0]);
    assert_eq!(
        (refined.residual_evaluations, refined.jacobian_evaluations),
        (51, 50)
    );
    // From 2⁻⁶⁰ (a = 2⁸⁰) the absolute part of the round-off bound, 1e-15·1e-15, is reached
    // within the cap: the step 2⁻⁹⁹'s half 2⁻¹⁰⁰ ≈ 7.9e-31 ≤ 1e-30 < 2⁻⁹⁹, after 39 steps.
    let mut tiny = Power::new(2, 0.0, 0.0);
    tiny.gain = 2f64.powi(80);
    let refined = refine(&tiny, &start(0.5f64.powi(60), 0.0), 1000);
    assert_eq!(refined.steps, 39);
    assert!(close(refined.x[0], 0.5f64.powi(99)), "{}", refined.x[0]);
    // A budget of 10 residual evaluations: the start and 9 steps.
    let refined = refine(&problem, &start(0.5f64.powi(20), 0.0), 10);
    assert_eq!(refined.steps, 9);
    assert_eq!(
        (refined.residual_evaluations, refined.jacobian_evaluations),
        (10, 9)
    );
    // No budget: nothing is evaluated.
    let refined = refine(&problem, &start(0.5f64.powi(20), 0.0), 0);
    assert_eq!((refined.steps, refined.residual_evaluations), (0, 0));
    assert_eq!(problem.counts(), (61, 59));
}

/// p = 4: each step is ¾ of the one before. With the cost resolved (c = 0, a = 2²⁰⁰) that is
/// progress, up to the cap (the round-off step 0.75ᵏ·2⁻²² ≤ 3e-15 needs k ≥ 64); with the cost
/// lost in c = 1 (a = 1, cost 1 + x₀⁸) it is not: the second step is accepted, then the
/// refinement stops.
#[test]
fn at_round_off_the_steps_must_at_least_halve() {
    let mut problem = Power::new(4, 3.0, 0.0);
    problem.gain = 2f64.powi(200);
    let resolved = refine(&problem, &start(0.5f64.powi(20), 3.0), 1000);
    assert_eq!(resolved.steps, MAX_REFINEMENT_STEPS);
    assert!(close(resolved.x[0], 0.5f64.powi(20) * 0.75f64.powi(50)));
    let unresolved = refine(&Power::new(4, 3.0, 1.0), &start(0.5f64.powi(17), 3.0), 1000);
    assert_eq!(unresolved.steps, 2);
    assert!(close(unresolved.x[0], 0.5f64.powi(17) * 0.5625));
    assert_eq!(unresolved.residual_evaluations, 3);
}

/// A wrong-signed Jacobian: the step x₀ → 1.5 x₀ multiplies the cost by 1.5⁴, far above
/// round-off: it is evaluated and refused.
#[test]
fn a_step_that_raises_the_cost_is_refused() {
    let mut problem = Power::new(2, 3.0, 0.0);
    problem.sign = -1.0;
    let x0 = start(0.5f64.powi(20), 3.0);
    let refined = refine(&problem, &x0, 1000);
    assert_eq!(refined.steps, 0);
    assert_eq!(refined.x, x0);
    assert_eq!(
        (refined.residual_evaluations, refined.jacobian_evaluations),
        (2, 1)
    );
}

/// `solve` reports every evaluation, the refinement's included, as the problem counted them.
#[test]
fn solve_counts_every_evaluation_the_refinement_included() {
    for kind in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
        let problem = Power::new(2, 3.0, 0.0);
        let outcome = solve(&problem, start(0.5f64.powi(20), 2.0), kind).unwrap();
        assert!(outcome.converged, "{kind:?}: {:?}", outcome.stop_reason);
        assert!(outcome.refinement_steps >= 2, "{kind:?}: {outcome:?}");
        let (residuals, jacobians) = problem.counts();
        assert_eq!(outcome.residual_evaluations, residuals, "{kind:?}");
        assert_eq!(outcome.jacobian_evaluations, jacobians, "{kind:?}");
        assert!(
            (outcome.x[1] - 3.0).abs() < 1e-15,
            "{kind:?}: {}",
            outcome.x
        );
    }
}

#[test]
fn the_default_budget_is_a_thousand_evaluations_per_unknown_plus_one() {
    assert_eq!(EVALUATIONS_PER_PARAMETER, 1000);
    for (n, budget) in [(0, 1000), (1, 2000), (2, 3000), (6, 7000)] {
        assert_eq!(default_budget(n), budget, "n = {n}");
    }
    assert_eq!(default_budget(usize::MAX), u64::MAX, "saturates");
}

/// At an exact zero of the residuals (cost 0) the step is zero: it raises no cost, so it is
/// taken, and as a round-off step it ends the refinement: one step, two residual evaluations
/// and one Jacobian, the point unchanged.
#[test]
fn at_an_exact_zero_one_zero_step_is_taken() {
    let problem = Power::new(2, 3.0, 0.0);
    let x0 = start(0.0, 3.0);
    let refined = refine(&problem, &x0, 1000);
    assert_eq!(refined.x, x0);
    assert_eq!(
        (
            refined.steps,
            refined.residual_evaluations,
            refined.jacobian_evaluations
        ),
        (1, 2, 1)
    );
}

/// r(x) = x² − 4 near its zero x = 2: Gauss–Newton (Newton here) converges quadratically,
/// each error the square of the one before over 2x.
#[derive(Clone)]
struct Square;

impl Operator for Square {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        Ok(DVector::from_column_slice(&[x[0] * x[0] - 4.0]))
    }
}

impl Jacobian for Square {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok(DMatrix::from_element(1, 1, 2.0 * x[0]))
    }
}

/// From 2 + 1e-7 the first step is 1e-7 and the second about 2.7e-15 (the error squared over
/// 4, six ulps of 2): above the round-off bound 1e-15·(2 + 1e-15), so a refinement that only
/// stopped at a round-off step would take a third (of zero length). Its bound, 2.7e-15 ×
/// 2.7e-15/1e-7 ≈ 7e-23, is of round-off length: two steps, at x = 2 exactly.
#[test]
fn a_quadratic_refinement_stops_before_its_round_off_step() {
    let refined = refine(&Square, &DVector::from_column_slice(&[2.0 + 1e-7]), 1000);
    assert_eq!(refined.x[0].to_bits(), 2.0f64.to_bits());
    assert_eq!(
        (
            refined.steps,
            refined.residual_evaluations,
            refined.jacobian_evaluations
        ),
        (2, 3, 2)
    );
}
