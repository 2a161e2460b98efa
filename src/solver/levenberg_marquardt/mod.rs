//! Levenberg–Marquardt least-squares solver implemented as an argmin [`Solver`].

use argmin::core::{
    ArgminError, Error, IterState, Jacobian, Operator, Problem, Solver, State, TerminationReason,
    KV,
};
use nalgebra::{DMatrix, DVector};

mod lmpar;
#[cfg(test)]
mod tests;

use lmpar::Scratch;

type LmState = IterState<DVector<f64>, (), DMatrix<f64>, (), DVector<f64>, f64>;

const P1: f64 = 0.1;
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
/// `min ‖J p − r‖² + λ‖D p‖²` through a QR factorisation of `[R; √λ·D]` (never an explicit
/// inverse); `λ` comes from a few of Moré's secular-equation iterations so that `‖D p‖ ≈ Δ`.
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
/// Convergence ends with [`TerminationReason::SolverConverged`]; which test fired is available
/// from [`LevenbergMarquardt::converged_by`]. Tolerances too small to be met at machine
/// precision, a non-finite Jacobian or starting residual, and a breakdown of the damped step
/// end with
/// [`TerminationReason::SolverExit`] and a readable message; the state then holds the last
/// accepted point. A trial point where the residuals cannot be evaluated (the problem returns an
/// error, e.g. a pose out of reach, or a non-finite residual) is a rejected step: the trust
/// region shrinks and the iterate stays where it was.
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
    ftol: f64,
    xtol: f64,
    gtol: f64,
    step_bound: f64,
    /// Scaling `D` (running max of the column norms of `J`); empty before the first iteration.
    diag: DVector<f64>,
    delta: f64,
    lambda: f64,
    xnorm: f64,
    accepted_any: bool,
    converged_by: Option<&'static str>,
    scratch: Scratch,
}

fn invalid(text: &str) -> Error {
    ArgminError::InvalidParameter {
        text: text.to_string(),
    }
    .into()
}

/// `value` if it is finite and positive (or zero, with `allow_zero`); otherwise an
/// `InvalidParameter` error "Levenberg-Marquardt: {what} must be positive and finite.".
fn validated(value: f64, what: &str, allow_zero: bool) -> Result<f64, Error> {
    if value.is_finite() && (value > 0.0 || (allow_zero && value >= 0.0)) {
        return Ok(value);
    }
    let rule = if allow_zero {
        "non-negative"
    } else {
        "positive"
    };
    Err(invalid(&format!(
        "Levenberg-Marquardt: {what} must be {rule} and finite."
    )))
}

fn exit(text: &str) -> TerminationReason {
    TerminationReason::SolverExit(format!("Levenberg-Marquardt: {text}"))
}

impl LevenbergMarquardt {
    /// Construct a solver with MINPACK defaults: `ftol = xtol = 1.49e-8` (≈ √ε),
    /// `gtol = 0` (gradient test only fires on an exactly orthogonal residual) and an initial
    /// step bound factor of `100`.
    pub fn new() -> Self {
        LevenbergMarquardt {
            ftol: 1.49012e-8,
            xtol: 1.49012e-8,
            gtol: 0.0,
            step_bound: 100.0,
            diag: DVector::zeros(0),
            delta: 0.0,
            lambda: 0.0,
            xnorm: 0.0,
            accepted_any: false,
            converged_by: None,
            scratch: Scratch::default(),
        }
    }

    /// Relative cost-reduction tolerance: converged when both the actual and the predicted
    /// relative reduction of the cost in a step are at most `ftol`. Must be positive and finite.
    pub fn with_ftol(mut self, ftol: f64) -> Result<Self, Error> {
        self.ftol = validated(ftol, "ftol", false)?;
        Ok(self)
    }

    /// Step tolerance: converged when the trust-region radius satisfies
    /// `Δ ≤ xtol·(‖D x‖ + xtol)`. Must be positive and finite.
    pub fn with_xtol(mut self, xtol: f64) -> Result<Self, Error> {
        self.xtol = validated(xtol, "xtol", false)?;
        Ok(self)
    }

    /// Gradient tolerance on MINPACK's scale-invariant max-cosine
    /// `max_j |(Jᵀr)_j| / (‖J e_j‖·‖r‖) ≤ gtol`. Must be non-negative and finite; `0` (the
    /// default) only stops on an exactly zero cosine.
    pub fn with_gtol(mut self, gtol: f64) -> Result<Self, Error> {
        self.gtol = validated(gtol, "gtol", true)?;
        Ok(self)
    }

    /// Initial trust-region radius factor: `Δ₀ = factor·‖D x₀‖` (or `factor` if that is zero).
    /// MINPACK recommends values in `[0.1, 100]`; default `100`. Must be positive and finite.
    pub fn with_initial_step_bound(mut self, factor: f64) -> Result<Self, Error> {
        self.step_bound = validated(factor, "initial step bound", false)?;
        Ok(self)
    }

    /// Which convergence test stopped the last run (with its formula), or `None` if the run
    /// has not converged (yet). Complements [`TerminationReason::SolverConverged`], which
    /// carries no detail.
    pub fn converged_by(&self) -> Option<&'static str> {
        self.converged_by
    }
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        Self::new()
    }
}

fn take<T>(v: Option<T>, what: &str) -> Result<T, Error> {
    v.ok_or_else(|| {
        ArgminError::NotInitialized {
            text: format!("Levenberg-Marquardt: {what} not set; provide an initial parameter vector via `Executor::configure`."),
        }
        .into()
    })
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
            return Err(invalid(
                "Levenberg-Marquardt: parameter vector must not be empty.",
            ));
        }
        (self.diag, self.delta, self.lambda, self.xnorm) = (DVector::zeros(0), 0.0, 0.0, 0.0);
        (self.accepted_any, self.converged_by) = (false, None);
        let r = problem.apply(&x)?;
        let cost = 0.5 * r.norm_squared();
        let state = state.param(x).residuals(r).cost(cost);
        if !cost.is_finite() {
            let msg = "residual vector contains NaN or infinity at the initial point.";
            return Ok((state.terminate_with(exit(msg)), None));
        }
        if cost <= f64::MIN_POSITIVE {
            self.converged_by = Some("zero residual: cost <= f64::MIN_POSITIVE");
            return Ok((
                state.terminate_with(TerminationReason::SolverConverged),
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
        let jac = problem.jacobian(&x)?;
        check_len(jac.nrows(), m, "Jacobian row count")?;
        check_len(jac.ncols(), n, "Jacobian column count")?;
        if jac.iter().any(|v| !v.is_finite()) {
            let reason = exit("Jacobian contains NaN or infinity.");
            return Ok((state.param(x).residuals(r).terminate_with(reason), None));
        }
        let s = &mut self.scratch;
        s.factorize(&jac, &r);
        // Gradient test: max_j |(Jᵀr)_j| / (‖J e_j‖‖r‖) ≤ gtol (MINPACK's max-cosine; Jᵀr = P Rᵀ Qᵀr).
        let mut gnorm: f64 = 0.0;
        for j in 0..n {
            let cn = s.col_norms[s.perm[j]];
            if cn > 0.0 {
                let g = s.jq.view((0, j), (j + 1, 1)).dot(&s.qtr.rows(0, j + 1));
                gnorm = gnorm.max((g / (cn * fnorm)).abs());
            }
        }
        if self.diag.len() == n {
            self.diag.zip_apply(&s.col_norms, |d, c| *d = d.max(c));
        } else {
            self.diag = s.col_norms.map(|c| if c > 0.0 { c } else { 1.0 });
            self.xnorm = x.component_mul(&self.diag).norm();
            let f = self.step_bound;
            self.delta = if self.xnorm > 0.0 { f * self.xnorm } else { f };
        }
        if gnorm <= self.gtol {
            self.converged_by = Some("gtol: max_j |cos(J e_j, r)| <= gtol");
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
                break (
                    Some(exit("damped step is not finite (damping overflow).")),
                    0.0,
                );
            };
            self.lambda = lambda;
            if !self.accepted_any {
                self.delta = self.delta.min(pnorm);
            }
            let x_trial = &x - &s.step;
            // A trial point outside the model's domain (an error, e.g. a pose a leg cannot reach
            // with these parameters, or a non-finite residual) is a rejected step: the trust
            // region shrinks as for a step that increased the cost.
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
                break (Some(exit("reduction ratio is not finite.")), 0.0);
            }
            if ratio <= P25 {
                let mut t = if actred >= 0.0 {
                    0.5
                } else {
                    0.5 * dirder / (dirder + 0.5 * actred)
                };
                if P1 * fnorm1 >= fnorm || t < P1 {
                    t = P1;
                }
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
            // zero residual: cost = ½‖r‖² ≤ f64::MIN_POSITIVE
            let zero = 0.5 * fnorm * fnorm <= f64::MIN_POSITIVE;
            // ftol: |actred| ≤ ftol and prered ≤ ftol (and ρ ≤ 2)
            let f_conv = actred.abs() <= self.ftol && prered <= self.ftol && 0.5 * ratio <= 1.0;
            // xtol: Δ ≤ xtol·(‖D x‖ + xtol)
            let x_conv = self.delta <= self.xtol * (self.xnorm + self.xtol);
            self.converged_by = match (zero, f_conv, x_conv) {
                (true, _, _) => Some("zero residual: cost <= f64::MIN_POSITIVE"),
                (_, true, true) => Some("ftol and xtol: relative cost reduction and step size"),
                (_, true, false) => {
                    Some("ftol: actual and predicted relative cost reduction <= ftol")
                }
                (_, false, true) => Some("xtol: trust-region radius <= xtol * (||D x|| + xtol)"),
                _ => None,
            };
            if self.converged_by.is_some() {
                break (Some(TerminationReason::SolverConverged), ratio);
            }
            let eps = f64::EPSILON;
            let stop = if actred.abs() <= eps && prered <= eps && 0.5 * ratio <= 1.0 {
                Some(exit(
                    "ftol is too small; no further reduction in the cost is possible.",
                ))
            } else if self.delta <= eps * self.xnorm {
                Some(exit(
                    "xtol is too small; no further improvement in x is possible.",
                ))
            } else if gnorm <= eps {
                Some(exit(
                    "gtol is too small; r is orthogonal to the columns of J to machine precision.",
                ))
            } else if !(self.delta.is_finite() && self.delta > 0.0 && self.lambda.is_finite()) {
                Some(exit(
                    "trust-region radius or damping parameter left the finite positive range.",
                ))
            } else {
                None
            };
            if stop.is_some() || accepted {
                break (stop, ratio);
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
