//! Levenberg–Marquardt least-squares solver implemented as an argmin [`Solver`].

use argmin::core::{
    ArgminError, Error, IterState, Jacobian, Operator, Problem, Solver, State, TerminationReason,
    KV,
};
use nalgebra::{DMatrix, DVector};

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

/// Reusable buffers; `jq` holds `R` of `J P = Q R`, `aug` holds `R_λ` of `[R; √λ D P]`.
#[derive(Clone, Debug, Default)]
struct Scratch {
    jq: DMatrix<f64>,
    rhs: DVector<f64>,
    aug: DMatrix<f64>,
    aug_rhs: DVector<f64>,
    perm: Vec<usize>,
    col_norms: DVector<f64>,
    qtr: DVector<f64>,
    d_perm: DVector<f64>,
    z: DVector<f64>,
    y: DVector<f64>,
    step: DVector<f64>,
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

/// Householder QR of `a` (`rows ≥ cols`) in place, applying the reflections to `b` too. With
/// `perm`, the remaining column of largest norm is moved forward first (MINPACK `qrfac`). On
/// return the leading `n × n` upper triangle of `a` is `R` and everything below it is zero.
fn householder_qr(a: &mut DMatrix<f64>, b: &mut DVector<f64>, mut perm: Option<&mut [usize]>) {
    let (m, n) = a.shape();
    for k in 0..n.min(m) {
        if let Some(p) = perm.as_deref_mut() {
            let norms = (k..n).map(|j| (j, a.view((k, j), (m - k, 1)).norm()));
            let best = norms
                .fold((k, -1.0), |b, c| if c.1 > b.1 { c } else { b })
                .0;
            a.swap_columns(k, best);
            p.swap(k, best);
        }
        let norm = a.view((k, k), (m - k, 1)).norm();
        if norm == 0.0 {
            continue;
        }
        let alpha = if a[(k, k)] > 0.0 { -norm } else { norm };
        a[(k, k)] -= alpha; // Householder vector v = x − α e₁, stored in column k.
        let vtv = a.view((k, k), (m - k, 1)).norm_squared();
        for j in k + 1..n {
            let s = 2.0 * a.view((k, k), (m - k, 1)).dot(&a.view((k, j), (m - k, 1))) / vtv;
            for i in k..m {
                a[(i, j)] -= s * a[(i, k)];
            }
        }
        let s = 2.0 * a.view((k, k), (m - k, 1)).dot(&b.rows(k, m - k)) / vtv;
        for i in k..m {
            b[i] -= s * a[(i, k)];
        }
        a[(k, k)] = alpha;
        a.view_mut((k + 1, k), (m - k - 1, 1)).fill(0.0);
    }
}

impl Scratch {
    /// Factorise `J P = Q R` and form `Qᵀ r` (zero rows are appended when `m < n`).
    fn factorize(&mut self, jac: &DMatrix<f64>, res: &DVector<f64>) {
        let (m, n) = jac.shape();
        self.jq = DMatrix::zeros(m.max(n), n);
        self.jq.view_mut((0, 0), (m, n)).copy_from(jac);
        self.rhs = DVector::zeros(m.max(n));
        self.rhs.rows_mut(0, m).copy_from(res);
        self.perm = (0..n).collect();
        self.col_norms = DVector::from_iterator(n, jac.column_iter().map(|c| c.norm()));
        householder_qr(&mut self.jq, &mut self.rhs, Some(&mut self.perm));
        self.qtr = self.rhs.rows(0, n).into_owned();
        for v in [&mut self.z, &mut self.y, &mut self.step, &mut self.d_perm] {
            *v = DVector::zeros(n);
        }
        self.aug = DMatrix::zeros(2 * n, n);
        self.aug_rhs = DVector::zeros(2 * n);
    }

    /// `‖D p‖` for the permuted step `z`.
    fn dnorm_z(&self) -> f64 {
        self.z.component_mul(&self.d_perm).norm()
    }

    /// Gauss–Newton step `R z = Qᵀr` (MINPACK: components past the first zero `R_jj` are zero).
    fn gauss_newton(&mut self) -> usize {
        let n = self.qtr.len();
        let nsing = (0..n).find(|&j| self.jq[(j, j)] == 0.0).unwrap_or(n);
        self.z.fill(0.0);
        let mut head = self.z.rows_mut(0, nsing);
        head.copy_from(&self.qtr.rows(0, nsing));
        self.jq
            .view((0, 0), (nsing, nsing))
            .solve_upper_triangular_mut(&mut head);
        nsing
    }

    /// Damped step from the QR factorisation of `[R; √λ D P]`, right-hand side `[Qᵀr; 0]`.
    fn solve_augmented(&mut self, sqrt_lambda: f64) -> bool {
        let n = self.qtr.len();
        self.aug.fill(0.0);
        self.aug
            .view_mut((0, 0), (n, n))
            .copy_from(&self.jq.view((0, 0), (n, n)));
        for j in 0..n {
            self.aug[(n + j, j)] = sqrt_lambda * self.d_perm[j];
        }
        self.aug_rhs.fill(0.0);
        self.aug_rhs.rows_mut(0, n).copy_from(&self.qtr);
        householder_qr(&mut self.aug, &mut self.aug_rhs, None);
        self.z.copy_from(&self.aug_rhs.rows(0, n));
        self.aug
            .view((0, 0), (n, n))
            .solve_upper_triangular_mut(&mut self.z)
    }

    /// Moré's Newton correction for `φ(λ) = ‖D p(λ)‖ − Δ`: `((φ/Δ)/‖y‖)/‖y‖` with
    /// `R_λᵀ y = D (D p)/‖D p‖`, where `R_λ` is `R` (`damped == false`) or the damped factor.
    fn newton_correction(&mut self, fp: f64, delta: f64, dxnorm: f64, damped: bool) -> f64 {
        let n = self.qtr.len();
        for j in 0..n {
            self.y[j] = self.d_perm[j] * (self.d_perm[j] * self.z[j]) / dxnorm;
        }
        let r = if damped { &self.aug } else { &self.jq };
        if !r
            .view((0, 0), (n, n))
            .tr_solve_upper_triangular_mut(&mut self.y)
        {
            return f64::NAN;
        }
        let ynorm = self.y.norm();
        ((fp / delta) / ynorm) / ynorm
    }

    /// MINPACK `lmpar`: the step `p` (in `self.step`, to be subtracted from `x`) with
    /// `‖D p‖ ≈ Δ` unless the Gauss–Newton step fits. Returns `(λ, ‖D p‖)`, or `None` if the
    /// damped system broke down numerically.
    fn lm_step(&mut self, delta: f64, lambda0: f64) -> Option<(f64, f64)> {
        let n = self.qtr.len();
        let nsing = self.gauss_newton();
        let gn_ok = self.z.iter().all(|v| v.is_finite());
        let mut dxnorm = if gn_ok { self.dnorm_z() } else { f64::INFINITY };
        let mut fp = dxnorm - delta;
        let mut lambda = 0.0;
        if !gn_ok || fp > P1 * delta {
            let mut lower = 0.0;
            if gn_ok && nsing == n {
                lower = self.newton_correction(fp, delta, dxnorm, false);
                if !lower.is_finite() {
                    lower = 0.0;
                }
            }
            // Upper bound ‖D⁻¹ Jᵀ r‖ / Δ.
            for j in 0..n {
                let g = self
                    .jq
                    .view((0, j), (j + 1, 1))
                    .dot(&self.qtr.rows(0, j + 1));
                self.y[j] = g / self.d_perm[j];
            }
            let gnorm = self.y.norm();
            let mut upper = gnorm / delta;
            if upper == 0.0 {
                upper = f64::MIN_POSITIVE / delta.min(P1);
            }
            lambda = lambda0.max(lower).min(upper);
            if lambda == 0.0 && gn_ok {
                lambda = gnorm / dxnorm;
            }
            for iter in 1..=10 {
                if lambda == 0.0 {
                    lambda = f64::MIN_POSITIVE.max(1e-3 * upper);
                }
                if !self.solve_augmented(lambda.sqrt()) {
                    return None;
                }
                dxnorm = self.dnorm_z();
                let fp_old = fp;
                fp = dxnorm - delta;
                if !fp.is_finite() {
                    return None;
                }
                if fp.abs() <= P1 * delta
                    || (lower == 0.0 && fp <= fp_old && fp_old < 0.0)
                    || iter == 10
                {
                    break;
                }
                let correction = self.newton_correction(fp, delta, dxnorm, true);
                if fp > 0.0 {
                    lower = lower.max(lambda);
                } else {
                    upper = upper.min(lambda);
                }
                lambda = lower.max(lambda + correction);
                if !lambda.is_finite() {
                    return None;
                }
            }
        }
        for j in 0..n {
            self.step[self.perm[j]] = self.z[j];
        }
        Some((lambda, dxnorm))
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

#[cfg(test)]
mod tests {
    use super::super::mgh::{max_rel_diff, reference, run, tight, TestProblem};
    use super::*;
    use argmin::core::Executor;

    const S: [f64; 7] = [0.038, 0.194, 0.425, 0.626, 1.253, 2.5, 3.74];
    const RATE: [f64; 7] = [0.05, 0.127, 0.094, 0.2122, 0.2729, 0.2665, 0.3317];

    /// Michaelis–Menten fit `rate = Vmax·S/(Km + S)` from argmin's Gauss–Newton example.
    fn michaelis_menten() -> TestProblem {
        let res = |x: &[f64]| {
            (0..7)
                .map(|i| RATE[i] - x[0] * S[i] / (x[1] + S[i]))
                .collect()
        };
        let jac = |x: &[f64]| {
            let row = |s: &f64| [-s / (x[1] + s), x[0] * s / (x[1] + s).powi(2)];
            S.iter().flat_map(row).collect()
        };
        TestProblem {
            m: 7,
            n: 2,
            x0: &[0.9, 0.2],
            res,
            jac,
        }
    }

    /// `y = a·exp(−b t) + c` on 12 points with a deterministic ±0.01 perturbation.
    fn exp_decay() -> TestProblem {
        fn data(i: usize) -> (f64, f64) {
            let t = 0.5 * i as f64;
            (
                t,
                3.0 * (-0.7 * t).exp() + 0.5 + 0.01 * (1.7 * i as f64).sin(),
            )
        }
        let res = |x: &[f64]| {
            let r = |(t, y): (f64, f64)| x[0] * (-x[1] * t).exp() + x[2] - y;
            (0..12).map(|i| r(data(i))).collect()
        };
        let jac = |x: &[f64]| {
            let row = |i: usize| {
                let t = 0.5 * i as f64;
                let e = (-x[1] * t).exp();
                [e, -x[0] * t * e, 1.0]
            };
            (0..12).flat_map(row).collect()
        };
        TestProblem {
            m: 12,
            n: 3,
            x0: &[1.0, 1.0, 0.0],
            res,
            jac,
        }
    }

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
            (ok.ftol, ok.xtol, ok.gtol, ok.step_bound),
            (1e-3, 1e-4, 0.0, 0.1)
        );
        let d = LevenbergMarquardt::default();
        assert_eq!(
            (d.ftol, d.xtol, d.gtol, d.step_bound),
            (1.49012e-8, 1.49012e-8, 0.0, 100.0)
        );
    }

    #[test]
    fn send_sync_clone() {
        fn assert_traits<T: Send + Sync + Clone + std::fmt::Debug>() {}
        assert_traits::<LevenbergMarquardt>();
    }

    #[test]
    fn michaelis_menten_known_answer() {
        let p = michaelis_menten();
        let out = run(p, tight()).unwrap();
        let (x_ref, c_ref, _) = reference(p);
        assert_eq!(out.reason, TerminationReason::SolverConverged);
        // Published optimum Vmax ≈ 0.362, Km ≈ 0.556 (three digits).
        assert!(
            (out.x[0] - 0.362).abs() < 5e-4 && (out.x[1] - 0.556).abs() < 5e-4,
            "{}",
            out.x
        );
        // Cost is ½‖r‖², not argmin Gauss–Newton's ‖r‖.
        let r = p.apply(&out.x).unwrap();
        assert!((out.cost - 0.5 * r.norm_squared()).abs() <= 1e-15 * out.cost);
        assert!(
            (out.cost - c_ref).abs() <= 1e-9 * c_ref,
            "{} vs {c_ref}",
            out.cost
        );
        assert!(max_rel_diff(&out.x, &x_ref) <= 1e-9, "{} vs {x_ref}", out.x);
    }

    #[test]
    fn agrees_with_levenberg_marquardt_crate() {
        for p in [michaelis_menten(), exp_decay()] {
            let out = run(p, tight()).unwrap();
            let (x_ref, c_ref, evals) = reference(p);
            let dx = max_rel_diff(&out.x, &x_ref);
            eprintln!(
                "x = {:?}: dx {dx:.1e}, r-evals {} vs {evals}",
                out.x.as_slice(),
                out.evals.0
            );
            assert!(dx <= 1e-10, "dx = {dx:e}");
            assert!((out.cost - c_ref).abs() <= 1e-12 * c_ref);
        }
    }

    #[test]
    fn underdetermined_with_unused_parameter() {
        // m = 1 < n = 3 and x₂ does not enter r, so J has a zero column.
        let res = |x: &[f64]| vec![x[0] * x[0] + x[1] * x[1] - 1.0];
        let jac = |x: &[f64]| vec![2.0 * x[0], 2.0 * x[1], 0.0];
        let p = TestProblem {
            m: 1,
            n: 3,
            x0: &[2.0, 1.0, 5.0],
            res,
            jac,
        };
        let out = run(p, LevenbergMarquardt::new()).unwrap();
        assert_eq!(out.reason, TerminationReason::SolverConverged);
        assert!(out.cost < 1e-20, "{}", out.cost);
        assert!((out.x[2] - 5.0).abs() <= 1e-15, "{}", out.x);
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

    fn run_trap(t: Trap, x0: [f64; 2]) -> Result<(LmState, LevenbergMarquardt), Error> {
        let res = Executor::new(t, LevenbergMarquardt::new())
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
        assert!(solver.converged_by().is_some());
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
        let (state, _) = run_trap(t, [-3.0, 5.0]).unwrap();
        let x = state.get_param().unwrap();
        assert!(state.get_cost().is_finite() && x[0] <= -2.5, "{x:?}");
        assert!(
            x[0] > -2.5 - 1e-6,
            "moved up to the edge of the domain: {x:?}"
        );
        let start_cost = 0.5 * (16.0 + 4.0 + 1600.0);
        assert!(state.get_cost() < start_cost, "cost {}", state.get_cost());
        assert!(state.get_termination_reason().is_some());
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
        let res = Executor::new(Unreachable, LevenbergMarquardt::new())
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
        assert_eq!(
            solver.converged_by(),
            Some("zero residual: cost <= f64::MIN_POSITIVE")
        );
        assert_eq!(state.get_iter(), 0);
        // Residual of length 1 but a 3×2 Jacobian: a usage error, reported as `Err`.
        let err = run_trap(t, [2.0, 7.0]).unwrap_err();
        assert!(
            err.to_string()
                .contains("Jacobian row count has length 3, expected 1"),
            "{err}"
        );
    }
}
