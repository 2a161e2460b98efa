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
/// `Δ` shrinks if `ρ < 0.25`, grows if `ρ > 0.75`, and the step is accepted if `ρ ≥ 1e-4`.
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
/// precision, non-finite residuals/Jacobians and a breakdown of the damped step end with
/// [`TerminationReason::SolverExit`] and a readable message; the state then holds the last
/// accepted point.
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
        if !(ftol.is_finite() && ftol > 0.0) {
            return Err(invalid(
                "Levenberg-Marquardt: ftol must be positive and finite.",
            ));
        }
        self.ftol = ftol;
        Ok(self)
    }

    /// Step tolerance: converged when the trust-region radius satisfies
    /// `Δ ≤ xtol·(‖D x‖ + xtol)`. Must be positive and finite.
    pub fn with_xtol(mut self, xtol: f64) -> Result<Self, Error> {
        if !(xtol.is_finite() && xtol > 0.0) {
            return Err(invalid(
                "Levenberg-Marquardt: xtol must be positive and finite.",
            ));
        }
        self.xtol = xtol;
        Ok(self)
    }

    /// Gradient tolerance on MINPACK's scale-invariant max-cosine
    /// `max_j |(Jᵀr)_j| / (‖J e_j‖·‖r‖) ≤ gtol`. Must be non-negative and finite; `0` (the
    /// default) only stops on an exactly zero cosine.
    pub fn with_gtol(mut self, gtol: f64) -> Result<Self, Error> {
        if !(gtol.is_finite() && gtol >= 0.0) {
            return Err(invalid(
                "Levenberg-Marquardt: gtol must be non-negative and finite.",
            ));
        }
        self.gtol = gtol;
        Ok(self)
    }

    /// Initial trust-region radius factor: `Δ₀ = factor·‖D x₀‖` (or `factor` if that is zero).
    /// MINPACK recommends values in `[0.1, 100]`; default `100`. Must be positive and finite.
    pub fn with_initial_step_bound(mut self, factor: f64) -> Result<Self, Error> {
        if !(factor.is_finite() && factor > 0.0) {
            return Err(invalid(
                "Levenberg-Marquardt: initial step bound must be positive and finite.",
            ));
        }
        self.step_bound = factor;
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
            let norm_of = |a: &DMatrix<f64>, j: usize| a.view((k, j), (m - k, 1)).norm();
            let best = (k..n).fold(k, |b, j| if norm_of(a, j) > norm_of(a, b) { j } else { b });
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
            let r_trial = problem.apply(&x_trial)?;
            check_len(r_trial.len(), m, "residual vector")?;
            let fnorm1 = r_trial.norm();
            if !fnorm1.is_finite() {
                let msg = "residual vector contains NaN or infinity at a trial point.";
                break (Some(exit(msg)), 0.0);
            }
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
