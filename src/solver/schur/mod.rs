//! Levenberg–Marquardt for bordered block-diagonal least squares, each step solved by the Schur
//! complement on the shared unknowns ([`arrowhead`]), as an argmin [`Solver`].

use argmin::core::{
    ArgminError, Error, IterState, Operator, Problem, Solver, State, TerminationReason, KV,
};
use nalgebra::DVector;

use super::bordered::{BorderedLayout, BorderedLeastSquares};
use super::settings::{self, Tolerances, Trial};
use super::stop::StopReason;

pub mod arrowhead;
#[cfg(test)]
mod tests;

use arrowhead::ArrowheadSystem;

/// The argmin state of [`SchurLevenbergMarquardt`]: parameters, residuals and cost `½‖r‖²` of
/// the last accepted point (no Jacobian is stored).
pub type SchurState = IterState<DVector<f64>, (), (), (), DVector<f64>, f64>;

/// Smallest step accepted (ratio of actual to predicted reduction).
const ACCEPT: f64 = 1e-4;

/// Relative length of a Gauss–Newton step below which the point counts as stationary (√ε).
const NEGLIGIBLE_GAUSS_NEWTON_STEP: f64 = 1.490_116_119_384_765_6e-8;

/// Floor of the damping factor: below it `λD²` is invisible against any block, and a
/// multiplicative update could otherwise underflow to zero and never recover.
const MIN_DAMPING: f64 = f64::EPSILON * f64::EPSILON;

/// # Levenberg–Marquardt by Schur complement
///
/// Minimises `cost(x) = ½‖r(x)‖²` for a problem whose Jacobian is bordered block-diagonal
/// ([`BorderedLeastSquares`]): unknowns `x = [own₀ | … | own_{g−1} | shared]`, every group's
/// rows depending only on its own unknowns and the shared ones.
///
/// **One iteration** (one `next_iter`) evaluates the blocks once
/// ([`BorderedLeastSquares::bordered`], counted as `bordered_count`), forms each group's
/// normal blocks `A_k = J_kᵀJ_k`, `C_k = J_kᵀB_k`, `g_k = J_kᵀr_k` and the shared
/// `S = Σ B_kᵀB_k` ([`ArrowheadSystem`]), then tries damped steps `p` solving
/// `(JᵀJ + λD²) p = Jᵀr` until one is accepted or a stopping test fires. Each trial step
/// eliminates every group by the Cholesky factor of its own damped block `A_k + λD_k²` (never
/// an explicit inverse), solves the reduced shared system
/// `(S + λD_s² − Σ C_kᵀ(A_k + λD_k²)⁻¹C_k) p_s = g_s − Σ C_kᵀ(A_k + λD_k²)⁻¹g_k` and
/// back-substitutes `p_k = (A_k + λD_k²)⁻¹(g_k − C_k p_s)`; the trial point `x − p` costs one
/// residual evaluation ([`Operator::apply`]). The cost of a step is linear in the number of
/// groups.
///
/// **Scaling:** `D = diag(running maximum of the Jacobian's column norms)` (a zero column
/// counts as 1), as MINPACK: the iterates do not depend on the units of the parameters.
///
/// **Damping (Nielsen's update).** `λ₀` is the initial damping factor (default `1e-3`: `D²`
/// already carries the scale of `JᵀJ`'s diagonal). The gain ratio `ρ` of actual to predicted
/// reduction, with the predicted reduction `½(‖Jp‖² + 2λ‖Dp‖²)` of the linear model, decides:
/// a step with `ρ ≥ 1e-4` is accepted and `λ ← λ·max(⅓, 1 − (2ρ − 1)³)`, `ν ← 2`; otherwise
/// it is rejected and `λ ← λ·ν`, `ν ← 2ν`. `λ` never falls below `ε²`. A trial point where the
/// residuals cannot be evaluated (the problem returns an error, e.g. a pose out of reach) or are
/// not finite is a rejected step, not an error. A damped block whose Cholesky factorisation
/// fails or loses every digit of a pivot (a rank-deficient group with too little damping) is
/// treated the same way without a residual evaluation: `λ` grows until every damped block is
/// numerically positive definite, so a rank-deficient group never produces a NaN step; the
/// step along its null space stays damped.
///
/// ## Stopping tests
///
/// The same [`StopReason`] values with the same meanings as
/// [`LevenbergMarquardt`](super::levenberg_marquardt::LevenbergMarquardt), available from
/// [`SchurLevenbergMarquardt::stop_reason`]; a convergence ends with
/// [`TerminationReason::SolverConverged`], any other stop with
/// [`TerminationReason::SolverExit`], and the state holds the last accepted point. After each
/// trial step `p` (relative reductions are relative to the current cost):
/// - [`StopReason::ZeroResidual`]: `½‖r‖² ≤ f64::MIN_POSITIVE`, or a progress stop below at a
///   cost at most ε times the starting cost;
/// - [`StopReason::CostReduction`]: the actual and predicted relative reductions are at most
///   `ftol` (and `ρ ≤ 2`);
/// - [`StopReason::StepSize`]: `‖D p‖ ≤ xtol·(‖D x‖ + xtol)` (the damped step plays the part of
///   the trust region), or a step that comes out exactly zero;
/// - [`StopReason::ToleranceTooSmall`]: the same tests with ε in place of the tolerances, or a
///   rejected step predicting a relative reduction of at most ε whose actual change is within
///   √ε (the round-off of the computed cost: nothing further is resolvable);
/// - [`StopReason::Gradient`]: MINPACK's scale-invariant `max_j |cos(J e_j, r)|` at most `gtol`
///   (checked before the steps) or ε;
/// - [`StopReason::NonFinite`]: the Jacobian blocks or the damping are not finite;
/// - [`StopReason::EvaluationBudget`]: `max_evaluations` residual evaluations spent (the
///   starting point included).
///
/// The cost-reduction, step and machine-precision tests only say that progress stopped: they
/// are a convergence only at a *stationary* point — the gradient cosine is at most the
/// stationarity tolerance, or the undamped Gauss–Newton step is negligible,
/// `‖D p_GN‖ ≤ √ε (‖D x‖ + √ε)` — and otherwise [`StopReason::Stalled`].
///
/// ## Requirements on the optimization problem
///
/// [`Operator`] (the residuals, the groups' rows concatenated in group order, identical to the
/// blocks' residuals) and [`BorderedLeastSquares`] (layout and blocks).
///
/// ## Reference
///
/// K. Madsen, H. B. Nielsen, O. Tingleff (2004). Methods for Non-Linear Least Squares
/// Problems, 2nd ed. Informatics and Mathematical Modelling, Technical University of Denmark
/// (the damping update, section 3.2).
#[derive(Clone, Debug)]
pub struct SchurLevenbergMarquardt {
    tolerances: Tolerances,
    initial_damping: f64,
    evaluations: u64,
    initial_cost: f64,
    layout: BorderedLayout,
    /// Scaling `D`; empty before the first iteration.
    diag: DVector<f64>,
    lambda: f64,
    nu: f64,
    stop: Option<StopReason>,
}

/// The solver's name in its messages.
const NAME: &str = "Schur Levenberg-Marquardt";

fn violated(text: String) -> Error {
    ArgminError::ConditionViolated { text }.into()
}

fn exit(text: &str) -> TerminationReason {
    settings::exit(NAME, text)
}

fn termination(reason: StopReason) -> TerminationReason {
    settings::termination(NAME, reason)
}

impl SchurLevenbergMarquardt {
    /// A solver with MINPACK's tolerances `ftol = xtol = 1.49e-8` (≈ √ε), `gtol = 0`, the
    /// stationarity tolerance
    /// [`STATIONARITY_TOLERANCE`](super::levenberg_marquardt::STATIONARITY_TOLERANCE), initial damping `1e-3` and no
    /// evaluation budget.
    pub fn new() -> Self {
        Self {
            tolerances: Tolerances::MINPACK,
            initial_damping: 1e-3,
            evaluations: 0,
            initial_cost: 0.0,
            layout: BorderedLayout {
                own: Vec::new(),
                shared: 0,
            },
            diag: DVector::zeros(0),
            lambda: 0.0,
            nu: 2.0,
            stop: None,
        }
    }

    settings::tolerance_builders!(NAME);

    /// Initial damping factor `λ₀` relative to `D²` (positive, finite; default `1e-3`).
    pub fn with_initial_damping(mut self, lambda: f64) -> Result<Self, Error> {
        self.initial_damping = settings::validated(NAME, lambda, "initial damping", false)?;
        Ok(self)
    }

    /// Why the last run stopped, or `None` while it runs (or if argmin stopped it).
    pub fn stop_reason(&self) -> Option<StopReason> {
        self.stop
    }

    /// Residual evaluations of the last run, the starting point included.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Rejects the current damping: `λ ← λ·ν`, `ν ← 2ν`.
    fn raise_damping(&mut self) {
        self.lambda *= self.nu;
        self.nu *= 2.0;
    }
}

impl Default for SchurLevenbergMarquardt {
    fn default() -> Self {
        Self::new()
    }
}

fn take<T>(v: Option<T>, what: &str) -> Result<T, Error> {
    settings::take(NAME, v, what)
}

/// MINPACK's `max_j |g_j| / (‖J e_j‖·‖r‖)` over the non-zero columns: a zero column has
/// `g_j = 0` and `0/0 = NaN`, which `f64::max` ignores (it returns the other operand), as in
/// [`LevenbergMarquardt`](super::levenberg_marquardt::LevenbergMarquardt).
fn gradient_measure(gradient: &DVector<f64>, norms: &DVector<f64>, rnorm: f64) -> f64 {
    gradient
        .iter()
        .zip(norms.iter())
        .map(|(g, c)| (g / (c * rnorm)).abs())
        .fold(0.0, f64::max)
}

impl<O> Solver<O, SchurState> for SchurLevenbergMarquardt
where
    O: Operator<Param = DVector<f64>, Output = DVector<f64>> + BorderedLeastSquares,
{
    fn name(&self) -> &str {
        "Schur Levenberg-Marquardt"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        mut state: SchurState,
    ) -> Result<(SchurState, Option<KV>), Error> {
        let x = take(state.take_param(), "parameter vector")?;
        let layout = problem
            .problem
            .as_ref()
            .ok_or_else(|| {
                Error::from(ArgminError::NotInitialized {
                    text: "Schur Levenberg-Marquardt: no problem to solve.".to_string(),
                })
            })?
            .layout();
        if x.len() != layout.unknowns() {
            return Err(violated(format!(
                "Schur Levenberg-Marquardt: parameter vector has length {}, the layout has {} \
                 unknowns.",
                x.len(),
                layout.unknowns()
            )));
        }
        if x.is_empty() {
            return Err(settings::invalid(&format!(
                "{NAME}: parameter vector must not be empty."
            )));
        }
        self.layout = layout;
        (self.diag, self.lambda, self.nu) = (DVector::zeros(0), self.initial_damping, 2.0);
        self.stop = None;
        let r = problem.apply(&x)?;
        self.evaluations = 1;
        let cost = 0.5 * r.norm_squared();
        self.initial_cost = cost;
        let state = state.param(x).residuals(r).cost(cost);
        let reason = if !cost.is_finite() {
            StopReason::NonFinite
        } else if cost <= f64::MIN_POSITIVE {
            StopReason::ZeroResidual
        } else if self.evaluations >= self.tolerances.max_evaluations {
            StopReason::EvaluationBudget
        } else {
            return Ok((state, None));
        };
        self.stop = Some(reason);
        let termination = if reason == StopReason::NonFinite {
            exit("residual vector contains NaN or infinity at the initial point.")
        } else {
            termination(reason)
        };
        Ok((state.terminate_with(termination), None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        mut state: SchurState,
    ) -> Result<(SchurState, Option<KV>), Error> {
        let mut x = take(state.take_param(), "parameter vector")?;
        let mut r = take(state.take_residuals(), "residual vector")?;
        let mut fnorm = r.norm();
        let blocks = problem.problem("bordered_count", |p| p.bordered(&x))?;
        let system = ArrowheadSystem::assemble(&self.layout, &blocks)
            .map_err(|e| violated(format!("Schur Levenberg-Marquardt: {e}.")))?;
        let rows: usize = blocks.iter().map(|b| b.residuals.len()).sum();
        if rows != r.len() {
            return Err(violated(format!(
                "Schur Levenberg-Marquardt: the blocks have {rows} rows, the residual vector {}.",
                r.len()
            )));
        }
        if !system.is_finite() {
            self.stop = Some(StopReason::NonFinite);
            let reason = exit("Jacobian blocks contain NaN or infinity.");
            return Ok((state.param(x).residuals(r).terminate_with(reason), None));
        }
        let norms = system.column_norms();
        let gnorm = gradient_measure(&system.gradient(), &norms, fnorm);
        if self.diag.len() == norms.len() {
            self.diag.zip_apply(&norms, |d, c| *d = d.max(c));
        } else {
            self.diag = norms.map(|c| if c > 0.0 { c } else { 1.0 });
        }
        let mut xnorm = x.component_mul(&self.diag).norm();
        if gnorm <= self.tolerances.gtol {
            self.stop = Some(StopReason::Gradient);
            let state = state.param(x).residuals(r);
            return Ok((
                state.terminate_with(TerminationReason::SolverConverged),
                None,
            ));
        }
        // Stationarity of the iteration's point, computed at most once and only when a
        // progress test fires.
        let mut stationary: Option<bool> = None;
        let (xnorm0, tolerance) = (xnorm, self.tolerances.stationarity);
        let mut is_stationary = |diag: &DVector<f64>| {
            *stationary.get_or_insert_with(|| {
                let g = NEGLIGIBLE_GAUSS_NEWTON_STEP;
                gnorm <= tolerance
                    || system
                        .damped_step(0.0, diag)
                        .is_ok_and(|p| p.component_mul(diag).norm() <= g * (xnorm0 + g))
            })
        };
        let eps = f64::EPSILON;
        let mut trials: u64 = 0;
        let (stop, ratio) = loop {
            trials += 1;
            if !(self.lambda.is_finite() && self.nu.is_finite()) {
                self.stop = Some(StopReason::NonFinite);
                break (Some(exit("damping factor overflow.")), 0.0);
            }
            let step = match system.damped_step(self.lambda, &self.diag) {
                Ok(step) if step.iter().all(|v| v.is_finite()) => step,
                // Too little damping for a rank-deficient block (or an overflowing step):
                // more damping, no residual evaluation.
                _ => {
                    self.raise_damping();
                    continue;
                }
            };
            if step.iter().all(|&v| v == 0.0) {
                let reason = if is_stationary(&self.diag) {
                    StopReason::StepSize
                } else {
                    StopReason::Stalled
                };
                self.stop = Some(reason);
                break (Some(termination(reason)), 0.0);
            }
            let pnorm = step.component_mul(&self.diag).norm();
            let x_trial = &x - &step;
            self.evaluations += 1;
            let (r_trial, fnorm1) = match problem.apply(&x_trial) {
                Ok(r_trial) if r_trial.len() == r.len() => {
                    let norm = r_trial.norm();
                    let norm = if norm.is_finite() {
                        norm
                    } else {
                        f64::INFINITY
                    };
                    (r_trial, norm)
                }
                Ok(r_trial) => {
                    return Err(violated(format!(
                        "Schur Levenberg-Marquardt: residual vector has length {}, expected {}.",
                        r_trial.len(),
                        r.len()
                    )))
                }
                Err(_) => (r.clone(), f64::INFINITY),
            };
            // Relative actual and predicted reductions of the cost.
            let actred = if 0.1 * fnorm1 < fnorm {
                1.0 - (fnorm1 / fnorm).powi(2)
            } else {
                -1.0
            };
            let jp = arrowhead::jacobian_times(&self.layout, &blocks, &step).norm();
            let prered = (jp / fnorm).powi(2) + 2.0 * self.lambda * (pnorm / fnorm).powi(2);
            let ratio = if prered != 0.0 { actred / prered } else { 0.0 };
            let accepted = ratio >= ACCEPT;
            if accepted {
                let factor = 1.0 - (2.0 * ratio - 1.0).powi(3);
                self.lambda = (self.lambda * factor.max(1.0 / 3.0)).max(MIN_DAMPING);
                self.nu = 2.0;
                (x, r, fnorm) = (x_trial, r_trial, fnorm1);
                xnorm = x.component_mul(&self.diag).norm();
            } else {
                self.raise_damping();
            }
            let tol = &self.tolerances;
            let trial = Trial {
                cost: 0.5 * fnorm * fnorm,
                initial_cost: self.initial_cost,
                actred,
                prered,
                ratio,
                step_converged: pnorm <= tol.xtol * (xnorm + tol.xtol),
                step_at_precision: pnorm <= eps * xnorm,
                gradient_cosine: gnorm,
                non_finite: !ratio.is_finite(),
                budget_spent: self.evaluations >= tol.max_evaluations,
            };
            let reason = trial.verdict(tol.ftol, || is_stationary(&self.diag));
            if let Some(reason) = reason {
                self.stop = Some(reason);
                break (Some(termination(reason)), ratio);
            }
            if accepted {
                break (None, ratio);
            }
        };
        let cost = 0.5 * fnorm * fnorm;
        let kv = argmin::kv!("lambda" => self.lambda; "ratio" => ratio; "trials" => trials;);
        let state = state.param(x).residuals(r).cost(cost);
        let state = match stop {
            Some(reason) => state.terminate_with(reason),
            None => state,
        };
        Ok((state, Some(kv)))
    }
}
