//! Levenberg–Marquardt least-squares solver implemented as an argmin [`Solver`].

use argmin::core::{
    ArgminError, Error, IterState, Jacobian, Operator, Problem, Solver, State, TerminationReason,
    KV,
};
use nalgebra::{DMatrix, DVector};

use super::settings::{self, Tolerances, Trial};
use super::stop::StopReason;

mod lmpar;
#[cfg(test)]
mod tests;

use lmpar::{Scratch, P1};

type LmState = IterState<DVector<f64>, (), DMatrix<f64>, (), DVector<f64>, f64>;

const P25: f64 = 0.25;
const P75: f64 = 0.75;
const P0001: f64 = 1.0e-4;

/// # Levenberg–Marquardt
///
/// Moré's trust-region Levenberg–Marquardt method, following MINPACK `lmder`, for
/// minimising `cost(x) = ½‖r(x)‖²`.
///
/// Each iteration evaluates the Jacobian `J` once, factorises `J P = Q R` (Householder QR with
/// column pivoting) and uses Marquardt scaling `D = diag(running max of the column norms of J)`,
/// which makes the method invariant to the units of the parameters. The damped step solves
/// `min ‖J p − r‖² + λ‖D p‖²` by eliminating `√λ·D` into `R` with Givens rotations (MINPACK
/// `qrsolv`; never an explicit inverse); `λ` comes from a few of Moré's secular-equation
/// iterations so that `‖D p‖ ≈ Δ`.
/// Every trial step `x − p` is checked by the ratio `ρ` of actual to predicted reduction:
/// `Δ` shrinks if `ρ ≤ 0.25`, grows if `ρ ≥ 0.75`, and the step is accepted if `ρ ≥ 1e-4`.
///
/// **One iteration** (one `next_iter`) = one Jacobian evaluation followed by as many trial
/// steps (residual evaluations) as needed until one is accepted or a stopping test fires, i.e.
/// one pass of MINPACK's outer loop. argmin counts evaluations when
/// `state.counting(true)` is configured.
///
/// **Cost convention:** the state's cost is `½‖r‖²`, *not* `‖r‖` as in argmin's Gauss–Newton.
/// The Moré–Garbow–Hillstrom tables report `f = ‖r‖² = 2·cost`.
///
/// The state keeps the parameters, residuals and cost of the last accepted point. The Jacobian
/// is not stored; evaluate it at the final parameters if you need it (e.g. for a covariance).
///
/// ## Stopping tests
///
/// Every stop sets a typed [`StopReason`], available from [`LevenbergMarquardt::stop_reason`].
/// A convergence ([`StopReason::is_convergence`]) ends with
/// [`TerminationReason::SolverConverged`]; every other stop ends with
/// [`TerminationReason::SolverExit`] and a readable message, and the state holds the last
/// accepted point.
///
/// The cost-reduction and step tests (and their machine-precision variants, which include a
/// rejected step predicting a relative reduction of at most ε whose actual change is within
/// √ε: the round-off of the computed cost) only say that progress stopped. They count as convergence only at a *stationary* point, where one of:
/// - MINPACK's scale-invariant gradient measure `max_j |cos(J e_j, r)|` is at most the
///   stationarity tolerance (default [`STATIONARITY_TOLERANCE`]);
/// - the full Gauss–Newton step is negligible, `‖D p_GN‖ ≤ √ε (‖D x‖ + √ε)` (the point is a
///   fixed point of Gauss–Newton; this covers residuals at round-off level, whose direction,
///   and so the cosine, is noise);
/// - the cost is at most ε times the starting cost (an exact fit: [`StopReason::ZeroResidual`]).
///
/// Otherwise the stop is [`StopReason::Stalled`]: for example a parameter driven to where the
/// model no longer depends on it (its Jacobian column ~1e-37 of the others) makes every trial
/// step predict a negligible reduction while the residual still lies largely along that column
/// (cosine ~0.6) and the Gauss–Newton step is astronomically long. A step that comes out exactly
/// zero is also [`StopReason::Stalled`].
///
/// The run stops with [`StopReason::EvaluationBudget`] once the residual has been evaluated
/// `max_evaluations` times (the starting point included) without convergence.
///
/// A trial point where the residuals cannot be evaluated (the problem returns an error, e.g. a
/// pose out of reach, or a non-finite residual) is a rejected step: the trust region shrinks
/// and the iterate stays where it was.
///
/// ## Requirements on the optimization problem
///
/// The optimization problem is required to implement [`Operator`] (residuals `r(x)`, length
/// `m`) and [`Jacobian`] (`J = ∂r/∂x`, `m × n`). `m < n` is allowed.
///
/// ## Reference
///
/// Jorge J. Moré (1978). The Levenberg-Marquardt algorithm: implementation and theory.
/// In: G. A. Watson (ed.), Numerical Analysis, Lecture Notes in Mathematics 630, Springer.
///
/// K. Madsen, H. B. Nielsen, O. Tingleff (2004). Methods for Non-Linear Least Squares
/// Problems, 2nd ed. Informatics and Mathematical Modelling, Technical University of Denmark.
#[derive(Clone, Debug)]
pub struct LevenbergMarquardt {
    tolerances: Tolerances,
    step_bound: f64,
    evaluations: u64,
    initial_cost: f64,
    /// Scaling `D` (running max of the column norms of `J`); empty before the first iteration.
    diag: DVector<f64>,
    delta: f64,
    lambda: f64,
    xnorm: f64,
    accepted_any: bool,
    stop: Option<StopReason>,
    scratch: Scratch,
}

pub use super::settings::STATIONARITY_TOLERANCE;

/// Relative length of a Gauss–Newton step below which the point counts as stationary (√ε).
const NEGLIGIBLE_GAUSS_NEWTON_STEP: f64 = 1.490_116_119_384_765_6e-8;

/// The solver's name in its messages.
const NAME: &str = "Levenberg-Marquardt";

fn exit(text: &str) -> TerminationReason {
    settings::exit(NAME, text)
}

fn termination(reason: StopReason) -> TerminationReason {
    settings::termination(NAME, reason)
}

impl LevenbergMarquardt {
    /// Construct a solver with MINPACK defaults: `ftol = xtol = 1.49e-8` (≈ √ε),
    /// `gtol = 0` (gradient test only fires on an exactly orthogonal residual) and an initial
    /// step bound factor of `100`.
    pub fn new() -> Self {
        LevenbergMarquardt {
            tolerances: Tolerances::MINPACK,
            step_bound: 100.0,
            evaluations: 0,
            initial_cost: 0.0,
            diag: DVector::zeros(0),
            delta: 0.0,
            lambda: 0.0,
            xnorm: 0.0,
            accepted_any: false,
            stop: None,
            scratch: Scratch::default(),
        }
    }

    settings::tolerance_builders!(NAME);

    /// Initial trust-region radius factor: `Δ₀ = factor·‖D x₀‖` (or `factor` if that is zero).
    /// MINPACK recommends values in `[0.1, 100]`; default `100`. Must be positive and finite.
    pub fn with_initial_step_bound(mut self, factor: f64) -> Result<Self, Error> {
        self.step_bound = settings::validated(NAME, factor, "initial step bound", false)?;
        Ok(self)
    }

    /// Why the last run stopped, or `None` while it runs (or if argmin stopped it, for
    /// example at `max_iters`). Complements argmin's [`TerminationReason`], which carries no
    /// detail.
    pub fn stop_reason(&self) -> Option<StopReason> {
        self.stop
    }

    /// Residual evaluations of the last run, the starting point included.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        Self::new()
    }
}

fn take<T>(v: Option<T>, what: &str) -> Result<T, Error> {
    settings::take(NAME, v, what)
}

fn check_len(len: usize, expected: usize, what: &str) -> Result<(), Error> {
    if len == expected {
        return Ok(());
    }
    Err(ArgminError::ConditionViolated {
        text: format!("Levenberg-Marquardt: {what} has length {len}, expected {expected}."),
    }
    .into())
}

impl<O> Solver<O, LmState> for LevenbergMarquardt
where
    O: Operator<Param = DVector<f64>, Output = DVector<f64>>
        + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>,
{
    fn name(&self) -> &str {
        "Levenberg-Marquardt"
    }

    fn init(
        &mut self,
        problem: &mut Problem<O>,
        mut state: LmState,
    ) -> Result<(LmState, Option<KV>), Error> {
        let x = take(state.take_param(), "parameter vector")?;
        if x.is_empty() {
            return Err(settings::invalid(&format!(
                "{NAME}: parameter vector must not be empty."
            )));
        }
        (self.diag, self.delta, self.lambda, self.xnorm) = (DVector::zeros(0), 0.0, 0.0, 0.0);
        (self.accepted_any, self.stop) = (false, None);
        let r = problem.apply(&x)?;
        self.evaluations = 1;
        let cost = 0.5 * r.norm_squared();
        self.initial_cost = cost;
        let state = state.param(x).residuals(r).cost(cost);
        if !cost.is_finite() {
            self.stop = Some(StopReason::NonFinite);
            let msg = "residual vector contains NaN or infinity at the initial point.";
            return Ok((state.terminate_with(exit(msg)), None));
        }
        if cost <= f64::MIN_POSITIVE {
            self.stop = Some(StopReason::ZeroResidual);
            return Ok((
                state.terminate_with(TerminationReason::SolverConverged),
                None,
            ));
        }
        if self.evaluations >= self.tolerances.max_evaluations {
            self.stop = Some(StopReason::EvaluationBudget);
            return Ok((
                state.terminate_with(termination(StopReason::EvaluationBudget)),
                None,
            ));
        }
        Ok((state, None))
    }

    fn next_iter(
        &mut self,
        problem: &mut Problem<O>,
        mut state: LmState,
    ) -> Result<(LmState, Option<KV>), Error> {
        let mut x = take(state.take_param(), "parameter vector")?;
        let mut r = take(state.take_residuals(), "residual vector")?;
        let (m, n) = (r.len(), x.len());
        let mut fnorm = r.norm();
        // The last iteration's factorisation is not needed again: freed before the new
        // Jacobian is built (a large problem's is tens of megabytes).
        self.scratch.jq = DMatrix::zeros(0, 0);
        let jac = problem.jacobian(&x)?;
        check_len(jac.nrows(), m, "Jacobian row count")?;
        check_len(jac.ncols(), n, "Jacobian column count")?;
        if jac.iter().any(|v| !v.is_finite()) {
            self.stop = Some(StopReason::NonFinite);
            let reason = exit("Jacobian contains NaN or infinity.");
            return Ok((state.param(x).residuals(r).terminate_with(reason), None));
        }
        let s = &mut self.scratch;
        s.factorize(jac, &r);
        // Gradient test: max_j |(Jᵀr)_j| / (‖J e_j‖‖r‖) ≤ gtol (MINPACK's max-cosine; Jᵀr = P Rᵀ Qᵀr).
        let mut gnorm: f64 = 0.0;
        // A zero column gives g = 0 and 0/0 = NaN, which `f64::max` ignores (it returns the
        // other operand): such a column has no cosine, as in MINPACK.
        for j in 0..n {
            let cn = s.col_norms[s.perm[j]];
            let g = s.jq.view((0, j), (j + 1, 1)).dot(&s.qtr.rows(0, j + 1));
            gnorm = gnorm.max((g / (cn * fnorm)).abs());
        }
        if self.diag.len() == n {
            self.diag.zip_apply(&s.col_norms, |d, c| *d = d.max(c));
        } else {
            self.diag = s.col_norms.map(|c| if c > 0.0 { c } else { 1.0 });
            self.xnorm = x.component_mul(&self.diag).norm();
            let f = self.step_bound;
            self.delta = if self.xnorm > 0.0 { f * self.xnorm } else { f };
        }
        if gnorm <= self.tolerances.gtol {
            self.stop = Some(StopReason::Gradient);
            let state = state.param(x).residuals(r);
            return Ok((
                state.terminate_with(TerminationReason::SolverConverged),
                None,
            ));
        }
        for j in 0..n {
            s.d_perm[j] = self.diag[s.perm[j]];
        }
        let mut trials: u64 = 0;
        let (stop, ratio) = loop {
            trials += 1;
            let Some((lambda, pnorm)) = s.lm_step(self.delta, self.lambda) else {
                self.stop = Some(StopReason::NonFinite);
                break (
                    Some(exit("damped step is not finite (damping overflow).")),
                    0.0,
                );
            };
            let g = NEGLIGIBLE_GAUSS_NEWTON_STEP;
            let stationary = gnorm <= self.tolerances.stationarity
                || s.gauss_newton_dnorm <= g * (self.xnorm + g);
            if s.step.iter().all(|&v| v == 0.0) {
                // A zero step cannot make progress: a convergence only at a stationary point,
                // otherwise a numerical breakdown.
                let reason = if stationary {
                    StopReason::StepSize
                } else {
                    StopReason::Stalled
                };
                self.stop = Some(reason);
                break (Some(termination(reason)), 0.0);
            }
            self.lambda = lambda;
            if !self.accepted_any {
                self.delta = self.delta.min(pnorm);
            }
            let x_trial = &x - &s.step;
            // A trial point outside the model's domain (an error, e.g. a pose a leg cannot reach
            // with these parameters, or a non-finite residual) is a rejected step: the trust
            // region shrinks as for a step that increased the cost.
            self.evaluations += 1;
            let (r_trial, fnorm1) = match problem.apply(&x_trial) {
                Ok(r_trial) => {
                    check_len(r_trial.len(), m, "residual vector")?;
                    let norm = r_trial.norm();
                    (
                        r_trial,
                        if norm.is_finite() {
                            norm
                        } else {
                            f64::INFINITY
                        },
                    )
                }
                Err(_) => (r.clone(), f64::INFINITY),
            };
            // Actual and predicted relative reductions, both relative to the current cost.
            let actred = if P1 * fnorm1 < fnorm {
                1.0 - (fnorm1 / fnorm).powi(2)
            } else {
                -1.0
            };
            let jp = (0..n).map(|i| {
                s.jq.view((i, i), (1, n - i))
                    .dot(&s.z.rows(i, n - i).transpose())
            });
            let t1 = (jp.map(|v| v * v).sum::<f64>().sqrt() / fnorm).powi(2);
            let t2 = (lambda.sqrt() * pnorm / fnorm).powi(2);
            let (prered, dirder) = (t1 + 2.0 * t2, -(t1 + t2));
            let ratio = if prered != 0.0 { actred / prered } else { 0.0 };
            if !ratio.is_finite() {
                self.stop = Some(StopReason::NonFinite);
                break (Some(exit("reduction ratio is not finite.")), 0.0);
            }
            if ratio <= P25 {
                // MINPACK's factor, kept within [0.1, 0.5].
                let t = if P1 * fnorm1 >= fnorm {
                    P1
                } else if actred >= 0.0 {
                    0.5
                } else {
                    (0.5 * dirder / (dirder + 0.5 * actred)).max(P1)
                };
                self.delta = t * self.delta.min(pnorm / P1);
                self.lambda /= t;
            } else if self.lambda == 0.0 || ratio >= P75 {
                self.delta = pnorm / 0.5;
                self.lambda *= 0.5;
            }
            let accepted = ratio >= P0001;
            if accepted {
                (x, r, fnorm, self.accepted_any) = (x_trial, r_trial, fnorm1, true);
                self.xnorm = x.component_mul(&self.diag).norm();
            }
            let tol = &self.tolerances;
            let trial = Trial {
                cost: 0.5 * fnorm * fnorm,
                initial_cost: self.initial_cost,
                actred,
                prered,
                ratio,
                // xtol: Δ ≤ xtol·(‖D x‖ + xtol)
                step_converged: self.delta <= tol.xtol * (self.xnorm + tol.xtol),
                step_at_precision: self.delta <= f64::EPSILON * self.xnorm,
                gradient_cosine: gnorm,
                // (A trust region shrunk to Δ ≤ 0 is a step-size stop first: Δ ≤ xtol·(‖D x‖ +
                // xtol) then holds for any xtol ≥ 0.)
                non_finite: !(self.delta.is_finite() && self.lambda.is_finite()),
                budget_spent: self.evaluations >= tol.max_evaluations,
            };
            let reason = trial.verdict(tol.ftol, || stationary);
            if let Some(reason) = reason {
                self.stop = Some(reason);
                break (Some(termination(reason)), ratio);
            }
            if accepted {
                break (None, ratio);
            }
        };
        let cost = 0.5 * fnorm * fnorm;
        let kv = argmin::kv!(
            "lambda" => self.lambda; "delta" => self.delta; "ratio" => ratio; "trials" => trials;
        );
        let state = state.param(x).residuals(r).cost(cost);
        let state = match stop {
            Some(reason) => state.terminate_with(reason),
            None => state,
        };
        Ok((state, Some(kv)))
    }
}
