//! Least-squares solvers on argmin: Levenberg–Marquardt (hand-written argmin `Solver`) and
//! argmin's Gauss–Newton, behind one entry point for any least-squares problem
//! ([`LeastSquares`]). Every solve reports whether it converged and a typed [`StopReason`].

use argmin::core::{Executor, IterState, Jacobian, Operator, OptimizationResult, State};
use nalgebra::{DMatrix, DVector};

/// Which solver identifies the parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    /// Levenberg–Marquardt (trust region; robust far from the solution).
    LevenbergMarquardt,
    /// Gauss–Newton (argmin; needs a full-rank Jacobian: check the rank first, as
    /// identification does).
    GaussNewton,
}

impl SolverKind {
    /// Short name (`lm`, `gn`).
    pub fn short_name(self) -> &'static str {
        match self {
            SolverKind::LevenbergMarquardt => "lm",
            SolverKind::GaussNewton => "gn",
        }
    }

    /// Full name.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::LevenbergMarquardt => "Levenberg-Marquardt",
            SolverKind::GaussNewton => "Gauss-Newton",
        }
    }
}

/// Relative cost-reduction and step tolerances of Levenberg–Marquardt (MINPACK's defaults are
/// √ε ≈ 1.5e-8; identification wants the parameters to round-off, and below ~1e-13 the
/// accept/reject decisions become round-off noise).
pub const LM_TOLERANCE: f64 = 1e-12;

/// Residual evaluations allowed per unknown (plus one): the default budget of a solve is
/// `EVALUATIONS_PER_PARAMETER · (n + 1)` for `n` unknowns.
///
/// MINPACK's default, 100 · (n + 1), is too small at tolerance [`LM_TOLERANCE`]: on the 27 NIST
/// StRD problems from both starts, Levenberg–Marquardt and its refinement need up to 764
/// residual evaluations (Bennett5 from start 1, n = 3: 191 · (n + 1)), 532 on MGH09 (n = 4)
/// and 501 on MGH17 (n = 5), both from start 1; every other fit needs fewer than 300. The
/// default leaves a factor of five over the worst case; tests/it/nist.rs asserts that every
/// fit converges within it.
pub const EVALUATIONS_PER_PARAMETER: u64 = 1000;

/// The default budget of residual evaluations for `n` unknowns.
pub fn default_budget(n: usize) -> u64 {
    EVALUATIONS_PER_PARAMETER.saturating_mul((n as u64).saturating_add(1))
}

/// Relative rise of the cost that [`refine`] still calls round-off: the computed residuals
/// carry the error of whatever computes them (an inner Newton solve of the inverse kinematics
/// stops at ~1e-12), so near the minimum the computed cost is only known to ~1e-10 relative.
const ROUND_OFF: f64 = 1e-8;

/// Gauss–Newton refinement steps at most (each one residual and one Jacobian evaluation).
pub const MAX_REFINEMENT_STEPS: usize = 50;

/// What a solver run produced.
#[derive(Debug, Clone)]
pub struct SolverOutcome {
    /// The estimate.
    pub x: DVector<f64>,
    /// Iterations performed (without the refinement).
    pub iterations: u64,
    /// Whether the solver converged ([`StopReason::is_convergence`] of `stop_reason`).
    pub converged: bool,
    /// Why the solver stopped.
    pub stop_reason: StopReason,
    /// Accepted Gauss–Newton refinement steps after the solver ([`refine`]).
    pub refinement_steps: usize,
    /// Residual evaluations, the refinement included.
    pub residual_evaluations: u64,
    /// Jacobian evaluations, the refinement included.
    pub jacobian_evaluations: u64,
}

/// Runs `kind` on `problem` from `x0` within [`default_budget`] residual evaluations, then
/// refines a converged result with [`refine`].
///
/// # Errors
/// The solver's error (for example a usage error such as mismatched dimensions, or the
/// problem's error at the starting point).
pub fn solve<P>(
    problem: &P,
    x0: DVector<f64>,
    kind: SolverKind,
) -> Result<SolverOutcome, argmin::core::Error>
where
    P: LeastSquares,
{
    let budget = default_budget(x0.len());
    solve_within(problem, x0, kind, budget)
}

/// [`solve`] with an explicit budget of residual evaluations (at least 1; the refinement only
/// spends what the solver left).
///
/// # Errors
/// As [`solve`].
pub fn solve_within<P>(
    problem: &P,
    x0: DVector<f64>,
    kind: SolverKind,
    budget: u64,
) -> Result<SolverOutcome, argmin::core::Error>
where
    P: LeastSquares,
{
    let outcome = run(problem, x0, kind, budget)?;
    Ok(refined(problem, outcome, budget))
}

/// Initial damping of [`solve_bordered`]'s Levenberg–Marquardt, relative to the squared column
/// norms: `τ = 1e-6`, the value Madsen, Nielsen and Tingleff (2004, §3.2) recommend when the
/// start is believed to be a good approximation, as an identification's nominal parameters
/// are. The solver's default `1e-3` (for a start of unknown quality) damps the weak
/// directions of an ill-conditioned identification (the instrument frame against the base
/// joints) for several iterations: on the tracker models it took 10–11 iterations and 13–15
/// block evaluations where this takes 6 and 9–10, for the same estimate to round-off (the
/// dense Levenberg–Marquardt, whose first trust region is MINPACK's `100‖D x₀‖`, takes 4).
/// The price is paid from a start far off: with the tracker frame 0.5 m and 0.5 rad away
/// from the estimate (a hundred times the models' perturbation) the 3-RPR took 72 iterations
/// where `1e-3` takes 14, to the same estimate; at 0.05 m and rad this start is still the
/// faster (7 against 11 iterations on the 5R, 11 against 13 on the 3-RPR).
pub const BORDERED_INITIAL_DAMPING: f64 = 1e-6;

/// Runs [`SchurLevenbergMarquardt`] (Levenberg–Marquardt with every step solved by the Schur
/// complement on the shared unknowns) on a bordered problem from `x0` within
/// [`default_budget`] residual evaluations (initial damping [`BORDERED_INITIAL_DAMPING`]),
/// then refines a converged result with [`refine`] on the problem's dense view
/// ([`DenseView`]: rare and small, like [`solve`]'s).
///
/// # Errors
/// The solver's error: a usage error (`x0` does not fit the layout, blocks of the wrong
/// dimensions) or the problem's error at the starting point.
pub fn solve_bordered<P>(
    problem: &P,
    x0: DVector<f64>,
) -> Result<SolverOutcome, argmin::core::Error>
where
    P: BorderedProblem,
{
    let budget = default_budget(x0.len());
    solve_bordered_within(problem, x0, budget)
}

/// [`solve_bordered`] with an explicit budget of residual evaluations (at least 1; the
/// refinement only spends what the solver left). Jacobian evaluations count the evaluations
/// of the blocks ([`BorderedLeastSquares::bordered`]).
///
/// # Errors
/// As [`solve_bordered`].
pub fn solve_bordered_within<P>(
    problem: &P,
    x0: DVector<f64>,
    budget: u64,
) -> Result<SolverOutcome, argmin::core::Error>
where
    P: BorderedProblem,
{
    let solver = SchurLevenbergMarquardt::new()
        .with_ftol(LM_TOLERANCE)?
        .with_xtol(LM_TOLERANCE)?
        .with_max_evaluations(budget)?
        .with_initial_damping(BORDERED_INITIAL_DAMPING)?;
    // Every iteration spends at least one residual evaluation: the budget bounds them.
    let result = Executor::new(problem.clone(), solver)
        .configure(|state| state.param(x0).max_iters(budget))
        .run()?;
    let stop = result.solver.stop_reason();
    let outcome = outcome(&result, stop, "bordered_count");
    Ok(refined(&DenseView(problem), outcome, budget))
}

/// Any least-squares problem on argmin: residuals `r(x)` ([`Operator`]) and their Jacobian
/// ([`Jacobian`]) over `DVector<f64>` parameters. Implemented for every such type.
pub trait LeastSquares:
    Operator<Param = DVector<f64>, Output = DVector<f64>>
    + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>
    + Clone
{
}

impl<P> LeastSquares for P where
    P: Operator<Param = DVector<f64>, Output = DVector<f64>>
        + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>
        + Clone
{
}

/// Result of [`refine`].
#[derive(Debug, Clone)]
pub struct Refinement {
    /// The refined estimate.
    pub x: DVector<f64>,
    /// Accepted Gauss–Newton steps.
    pub steps: usize,
    /// Residual evaluations spent.
    pub residual_evaluations: u64,
    /// Jacobian evaluations spent.
    pub jacobian_evaluations: u64,
}

/// Refines a converged estimate with Gauss–Newton steps solved by SVD, while the cost
/// decreases, within `budget` residual evaluations.
///
/// Why: near a flat minimum, the cost-ratio tests that stop Levenberg–Marquardt (and argmin's
/// cost-change test) cannot resolve the parameters better than about √(ε·cost)/s_min — 1e-9
/// on the noisy 5R — and where exactly a solver stops within that band depends on round-off:
/// the computed cost itself is only known to ~1e-11 relative there. The stationarity condition
/// Jᵀr = 0 determines the minimiser to ~1e-15, and Gauss–Newton steps reach it: quadratically
/// on a small-residual problem, linearly on a large-residual one (so the steps need not halve).
///
/// The first step is taken only from a converged point (length ≤ 1e-6 (‖x‖ + 1)). A step is
/// accepted if the cost does not rise by more than round-off (1e-8 relative) and the step is
/// no longer than the one before. The refinement goes on while the cost decreases (or, at
/// round-off level where the computed cost cannot tell, while the steps at least halve), and
/// stops at a step of round-off length (1e-15 relative), before one (the step times its ratio
/// to the one before, what the next step is at most under quadratic or linear convergence, is
/// of round-off length), after [`MAX_REFINEMENT_STEPS`], or when the budget is spent. The
/// prediction saves the step that only moves the estimate within its round-off: on the 5R's
/// leg the second step is 1e-14 relative after one of 1e-11, and a third would be round-off
/// again.
pub fn refine<P>(problem: &P, x0: &DVector<f64>, budget: u64) -> Refinement
where
    P: LeastSquares,
{
    let mut refinement = Refinement {
        x: x0.clone(),
        steps: 0,
        residual_evaluations: 0,
        jacobian_evaluations: 0,
    };
    if budget == 0 {
        return refinement;
    }
    refinement.residual_evaluations += 1;
    let Ok(mut r) = problem.apply(&refinement.x) else {
        return refinement;
    };
    let mut cost = r.norm_squared();
    let mut limit = 1e-6 * (x0.norm() + 1.0);
    let mut previous = f64::INFINITY;
    while refinement.steps < MAX_REFINEMENT_STEPS && refinement.residual_evaluations < budget {
        refinement.jacobian_evaluations += 1;
        let Ok(jacobian) = problem.jacobian(&refinement.x) else {
            break;
        };
        // Householder QR where the Jacobian is well conditioned (the same step to round-off),
        // the SVD otherwise (the QR's copy is the size of the SVD's factor U).
        let step = match qr_step::qr_step(jacobian.clone(), &r) {
            Some(step) => step,
            None => match jacobian.svd(true, true).solve(&r, f64::EPSILON) {
                Ok(step) => step,
                Err(_) => break,
            },
        };
        let length = step.norm();
        if !(length.is_finite() && length <= limit) {
            break;
        }
        let x = &refinement.x - &step;
        refinement.residual_evaluations += 1;
        let Ok(r_new) = problem.apply(&x) else {
            break;
        };
        let cost_new = r_new.norm_squared();
        // A NaN cost is no better either.
        if cost_new.is_nan() || cost_new > cost * (1.0 + ROUND_OFF) {
            break;
        }
        refinement.x = x;
        refinement.steps += 1;
        // Progress: the cost went down, or (at round-off level, where the computed cost no
        // longer resolves it) the step contracted at least twofold.
        let progress = cost_new < cost || length <= 0.5 * previous;
        (r, cost) = (r_new, cost_new);
        // The next step, from this one's contraction (quadratic or linear convergence: at
        // most this one times the ratio to the one before; none known after the first).
        let next = if previous.is_finite() {
            length * (length / previous)
        } else {
            length
        };
        let round_off = 1e-15 * (refinement.x.norm() + 1e-15);
        if !progress || length <= round_off || next <= round_off {
            break;
        }
        (limit, previous) = (length, length);
    }
    refinement
}

fn run<P>(
    problem: &P,
    x0: DVector<f64>,
    kind: SolverKind,
    budget: u64,
) -> Result<SolverOutcome, argmin::core::Error>
where
    P: LeastSquares,
{
    match kind {
        SolverKind::GaussNewton => {
            // One residual evaluation per iteration, plus the starting point.
            let solver = gauss_newton::StepGaussNewton::new();
            let result = Executor::new(problem.clone(), solver)
                .configure(|state| state.param(x0).max_iters(budget.saturating_sub(1)))
                .run()?;
            let stop = result.solver.stop_reason();
            Ok(outcome(&result, stop, "jacobian_count"))
        }
        SolverKind::LevenbergMarquardt => {
            let solver = levenberg_marquardt::LevenbergMarquardt::new()
                .with_ftol(LM_TOLERANCE)?
                .with_xtol(LM_TOLERANCE)?
                .with_max_evaluations(budget)?;
            // Every iteration spends at least one residual evaluation: the budget bounds them.
            let result = Executor::new(problem.clone(), solver)
                .configure(|state| state.param(x0).max_iters(budget))
                .run()?;
            let stop = result.solver.stop_reason();
            Ok(outcome(&result, stop, "jacobian_count"))
        }
    }
}

/// The argmin state of every solver here: parameters, residuals and cost, with the solver's
/// own Jacobian type `J` (a matrix, or nothing where the solver keeps blocks).
type LeastSquaresState<J> = IterState<DVector<f64>, (), J, (), DVector<f64>, f64>;

/// The outcome of an argmin run, before any refinement: the last accepted point, and the
/// solver's stop (a run argmin stopped at `max_iters` spent its evaluation budget).
/// `jacobian_counter` is the problem's counter of Jacobian evaluations.
fn outcome<O, S, J>(
    result: &OptimizationResult<O, S, LeastSquaresState<J>>,
    stop: Option<StopReason>,
    jacobian_counter: &str,
) -> SolverOutcome {
    let state = result.state();
    let stop_reason = stop.unwrap_or(StopReason::EvaluationBudget);
    SolverOutcome {
        x: state.get_param().cloned().unwrap_or_default(),
        iterations: state.get_iter(),
        converged: stop_reason.is_convergence(),
        stop_reason,
        refinement_steps: 0,
        residual_evaluations: count(&result.problem.counts, "operator_count"),
        jacobian_evaluations: count(&result.problem.counts, jacobian_counter),
    }
}

/// `outcome` followed, if it converged, by [`refine`] on `problem` within what is left of
/// `budget`.
fn refined<P: LeastSquares>(problem: &P, mut outcome: SolverOutcome, budget: u64) -> SolverOutcome {
    if outcome.converged {
        let left = budget.saturating_sub(outcome.residual_evaluations);
        let refinement = refine(problem, &outcome.x, left);
        outcome.x = refinement.x;
        outcome.refinement_steps = refinement.steps;
        outcome.residual_evaluations += refinement.residual_evaluations;
        outcome.jacobian_evaluations += refinement.jacobian_evaluations;
    }
    outcome
}

fn count(counts: &std::collections::HashMap<&'static str, u64>, key: &str) -> u64 {
    counts.get(key).copied().unwrap_or(0)
}

pub mod bordered;
mod column_dot;
pub mod gauss_newton;
pub mod levenberg_marquardt;
#[cfg(test)]
mod observed;
pub mod qr_step;
pub mod schur;
mod settings;
pub mod stop;

pub use bordered::{BorderedLeastSquares, BorderedProblem, DenseView};
pub use schur::SchurLevenbergMarquardt;
pub use stop::{gradient_cosine, StopReason};

#[cfg(test)]
mod tests {
    use super::*;
    use argmin::core::Error;

    /// `y = a·exp(−b t)` through four exact points of a = 2, b = 0.5.
    #[derive(Clone)]
    struct Decay;
    const T: [f64; 4] = [0.0, 1.0, 2.0, 3.0];
    impl Operator for Decay {
        type Param = DVector<f64>;
        type Output = DVector<f64>;
        fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
            let r = T
                .iter()
                .map(|t| x[0] * (-x[1] * t).exp() - 2.0 * (-0.5 * t).exp());
            Ok(DVector::from_iterator(4, r))
        }
    }
    impl Jacobian for Decay {
        type Param = DVector<f64>;
        type Jacobian = DMatrix<f64>;
        fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
            Ok(DMatrix::from_fn(4, 2, |i, j| {
                let e = (-x[1] * T[i]).exp();
                if j == 0 {
                    e
                } else {
                    -x[0] * T[i] * e
                }
            }))
        }
    }

    #[test]
    fn both_solvers_converge_and_say_why() {
        for kind in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
            let x0 = DVector::from_column_slice(&[1.5, 0.4]);
            let out = solve(&Decay, x0, kind).unwrap();
            assert!(
                out.converged && out.stop_reason.is_convergence(),
                "{kind:?}: {out:?}"
            );
            assert!((out.x[0] - 2.0).abs() < 1e-12 && (out.x[1] - 0.5).abs() < 1e-12);
            assert!(out.residual_evaluations <= default_budget(2));
        }
    }

    #[test]
    fn a_spent_budget_is_not_convergence() {
        for kind in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
            let x0 = DVector::from_column_slice(&[1.5, 0.4]);
            let out = solve_within(&Decay, x0, kind, 2).unwrap();
            assert_eq!(out.stop_reason, StopReason::EvaluationBudget, "{kind:?}");
            assert!(!out.converged);
            assert_eq!(out.residual_evaluations, 2, "{kind:?}");
            assert_eq!(out.refinement_steps, 0);
        }
    }

    #[test]
    fn solver_kinds_have_the_names_the_reports_print() {
        // The JSON reports' `solver` values are the command line's `--solver` words.
        assert_eq!(SolverKind::LevenbergMarquardt.short_name(), "lm");
        assert_eq!(SolverKind::GaussNewton.short_name(), "gn");
        assert_eq!(SolverKind::LevenbergMarquardt.name(), "Levenberg-Marquardt");
        assert_eq!(SolverKind::GaussNewton.name(), "Gauss-Newton");
    }

    #[test]
    fn stop_reason_keys_are_snake_case_and_distinct() {
        let keys: Vec<&str> = StopReason::ALL.iter().map(|r| r.key()).collect();
        for (i, key) in keys.iter().enumerate() {
            assert!(
                key.chars().all(|c| c.is_ascii_lowercase() || c == '_'),
                "{key}"
            );
            assert!(!keys[..i].contains(key), "{key}");
            // The JSON report writes the reason by its serde name: the same key.
            assert_eq!(serde_json::to_value(StopReason::ALL[i]).unwrap(), *key);
        }
        let converging = StopReason::ALL.iter().filter(|r| r.is_convergence());
        assert_eq!(converging.count(), 5);
    }
}
