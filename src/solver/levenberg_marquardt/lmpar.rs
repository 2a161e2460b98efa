//! QR factorisation and the damped step of Levenberg–Marquardt (MINPACK `qrfac`, `qrsolv` and
//! `lmpar`).

use nalgebra::{DMatrix, DVector};

use crate::solver::column_dot::dot;

/// MINPACK's `p1`: the step bound's relative tolerance here, and the step-control factor of
/// the Levenberg–Marquardt iteration.
pub(super) const P1: f64 = 0.1;

/// Reusable buffers; `jq` holds `R` of `J P = Q R`, `damped` holds the upper-triangular `S` with
/// `SᵀS = RᵀR + λ (D P)²` (the R factor of `[R; √λ D P]`).
#[derive(Clone, Debug, Default)]
pub(super) struct Scratch {
    pub(super) jq: DMatrix<f64>,
    rhs: DVector<f64>,
    damped: DMatrix<f64>,
    damped_rhs: DVector<f64>,
    pub(super) perm: Vec<usize>,
    pub(super) col_norms: DVector<f64>,
    pub(super) qtr: DVector<f64>,
    pub(super) d_perm: DVector<f64>,
    pub(super) z: DVector<f64>,
    y: DVector<f64>,
    pub(super) step: DVector<f64>,
    /// `‖D p_GN‖` of the (truncated) Gauss–Newton step of the last [`Scratch::lm_step`]
    /// (infinite if that step is not finite).
    pub(super) gauss_newton_dnorm: f64,
}

/// Householder QR of `a` (`rows ≥ cols`) in place, applying the reflections to `b` too. With
/// `perm`, the remaining column of largest norm is moved forward first (MINPACK `qrfac`). On
/// return the leading `n × n` upper triangle of `a` is `R` and everything below it is zero.
fn householder_qr(a: &mut DMatrix<f64>, b: &mut DVector<f64>, mut perm: Option<&mut [usize]>) {
    let (m, n) = a.shape();
    // Column-major: column j is `data[j·m..(j + 1)·m]`.
    let data = a.as_mut_slice();
    let b = b.as_mut_slice();
    for k in 0..n.min(m) {
        if let Some(p) = perm.as_deref_mut() {
            let mut best = (k, -1.0);
            for j in k..n {
                let norm = dot(&data[j * m + k..(j + 1) * m], &data[j * m + k..(j + 1) * m]).sqrt();
                if norm > best.1 {
                    best = (j, norm);
                }
            }
            let best = best.0;
            if best != k {
                let (left, right) = data.split_at_mut(best * m);
                left[k * m..(k + 1) * m].swap_with_slice(&mut right[..m]);
            }
            p.swap(k, best);
        }
        let (left, right) = data.split_at_mut((k + 1) * m);
        let v = &mut left[k * m + k..];
        let norm = dot(v, v).sqrt();
        if norm == 0.0 {
            continue;
        }
        let alpha = if v[0] > 0.0 { -norm } else { norm };
        v[0] -= alpha; // Householder vector v = x − α e₁, stored in column k.
        let vtv = dot(v, v);
        for column in right.chunks_exact_mut(m) {
            let column = &mut column[k..];
            let s = 2.0 * dot(v, column) / vtv;
            for (x, vi) in column.iter_mut().zip(v.iter()) {
                *x -= s * vi;
            }
        }
        let tail = &mut b[k..m];
        let s = 2.0 * dot(v, tail) / vtv;
        for (x, vi) in tail.iter_mut().zip(v.iter()) {
            *x -= s * vi;
        }
        v[0] = alpha;
        v[1..].fill(0.0);
    }
}

impl Scratch {
    /// Factorise `J P = Q R` and form `Qᵀ r` (zero rows are appended when `m < n`), in the
    /// Jacobian's own storage (a large problem's Jacobian is tens of megabytes: no copy).
    pub(super) fn factorize(&mut self, jac: DMatrix<f64>, res: &DVector<f64>) {
        let (m, n) = jac.shape();
        // The buffers of the last iteration are reused (the same sizes at every iteration).
        zeroed(&mut self.col_norms, n);
        for (norm, column) in self.col_norms.iter_mut().zip(jac.column_iter()) {
            *norm = column.norm();
        }
        self.jq = if m >= n {
            jac
        } else {
            let mut padded = DMatrix::zeros(n, n);
            padded.view_mut((0, 0), (m, n)).copy_from(&jac);
            padded
        };
        zeroed(&mut self.rhs, m.max(n));
        self.rhs.rows_mut(0, m).copy_from(res);
        self.perm.clear();
        self.perm.extend(0..n);
        householder_qr(&mut self.jq, &mut self.rhs, Some(&mut self.perm));
        zeroed(&mut self.qtr, n);
        self.qtr.copy_from(&self.rhs.rows(0, n));
        for v in [&mut self.z, &mut self.y, &mut self.step, &mut self.d_perm] {
            zeroed(v, n);
        }
        self.gauss_newton_dnorm = f64::INFINITY;
        if self.damped.shape() == (n, n) {
            self.damped.fill(0.0);
        } else {
            self.damped = DMatrix::zeros(n, n);
        }
        zeroed(&mut self.damped_rhs, n);
    }

    /// `‖D p‖` for the permuted step `z`.
    fn dnorm_z(&self) -> f64 {
        self.z.component_mul(&self.d_perm).norm()
    }

    /// Gauss–Newton step `R z = Qᵀr` (MINPACK: components past the first zero `R_jj` are zero).
    fn gauss_newton(&mut self) {
        let n = self.qtr.len();
        let nsing = (0..n).find(|&j| self.jq[(j, j)] == 0.0).unwrap_or(n);
        self.z.fill(0.0);
        let mut head = self.z.rows_mut(0, nsing);
        head.copy_from(&self.qtr.rows(0, nsing));
        self.jq
            .view((0, 0), (nsing, nsing))
            .solve_upper_triangular_mut(&mut head);
    }

    /// Damped step from the R factor `S` of `[R; √λ D P]`, right-hand side `[Qᵀr; 0]`
    /// (MINPACK `qrsolv`).
    ///
    /// Each row `√λ d_j e_jᵀ` of the diagonal block is eliminated into `R` by Givens rotations,
    /// one column at a time. A rotation only combines two rows, so the tiny entries of `R` (a
    /// parameter whose Jacobian column is ~1e-47 relative to the others) and their right-hand
    /// side stay at their own scale; a Householder reflection of the whole `2n × n` column
    /// mixes them with √λ d_j and can cancel them (an exactly zero step was seen on NIST BoxBOD
    /// from start 1). Components
    /// past the first zero diagonal of `S` are set to zero, as for the Gauss–Newton step.
    /// Returns `false` if the triangular solve broke down.
    fn solve_damped(&mut self, sqrt_lambda: f64) -> bool {
        let n = self.qtr.len();
        self.damped.copy_from(&self.jq.view((0, 0), (n, n)));
        self.damped.fill_lower_triangle(0.0, 1);
        self.damped_rhs.copy_from(&self.qtr);
        for j in 0..n {
            let d = sqrt_lambda * self.d_perm[j];
            if d == 0.0 {
                continue;
            }
            // The row being eliminated (entries j.. only) and its right-hand side (zero).
            self.y.fill(0.0);
            self.y[j] = d;
            let mut extra = 0.0;
            for k in j..n {
                if self.y[k] == 0.0 {
                    continue;
                }
                let (cos, sin) = givens(self.damped[(k, k)], self.y[k]);
                for i in k..n {
                    let (a, b) = (self.damped[(k, i)], self.y[i]);
                    self.damped[(k, i)] = cos * a + sin * b;
                    self.y[i] = -sin * a + cos * b;
                }
                let (a, b) = (self.damped_rhs[k], extra);
                self.damped_rhs[k] = cos * a + sin * b;
                extra = -sin * a + cos * b;
            }
        }
        // Back substitution, each row's sum in increasing column order as MINPACK forms it.
        let nsing = (0..n).find(|&j| self.damped[(j, j)] == 0.0).unwrap_or(n);
        self.z.fill(0.0);
        for j in (0..nsing).rev() {
            let mut sum = 0.0;
            for i in j + 1..nsing {
                sum += self.damped[(j, i)] * self.z[i];
            }
            self.z[j] = (self.damped_rhs[j] - sum) / self.damped[(j, j)];
        }
        self.z.iter().all(|v| v.is_finite())
    }

    /// Moré's Newton correction for `φ(λ) = ‖D p(λ)‖ − Δ`: `((φ/Δ)/‖y‖)/‖y‖` with
    /// `R_λᵀ y = D (D p)/‖D p‖`, where `R_λ` is `R` (`damped == false`) or the damped factor.
    fn newton_correction(&mut self, fp: f64, delta: f64, dxnorm: f64, damped: bool) -> f64 {
        let n = self.qtr.len();
        for j in 0..n {
            self.y[j] = self.d_perm[j] * ((self.d_perm[j] * self.z[j]) / dxnorm);
        }
        // Solve R_λᵀ y = b in MINPACK's operation order: for the damped factor column by column
        // (each solved component subtracted from the rest), for R row by row (a sum in
        // increasing order, then one subtraction).
        let r = if damped { &self.damped } else { &self.jq };
        for j in 0..n {
            if damped {
                self.y[j] /= r[(j, j)];
                let t = self.y[j];
                for i in j + 1..n {
                    self.y[i] -= r[(j, i)] * t;
                }
            } else {
                let mut sum = 0.0;
                for i in 0..j {
                    sum += r[(i, j)] * self.y[i];
                }
                self.y[j] = (self.y[j] - sum) / r[(j, j)];
            }
        }
        if !self.y.iter().all(|v| v.is_finite()) {
            return f64::NAN;
        }
        let ynorm = self.y.norm();
        ((fp / delta) / ynorm) / ynorm
    }

    /// MINPACK `lmpar`: the step `p` (in `self.step`, to be subtracted from `x`) with
    /// `‖D p‖ ≈ Δ` unless the Gauss–Newton step fits. Returns `(λ, ‖D p‖)`, or `None` if the
    /// damped system broke down numerically.
    pub(super) fn lm_step(&mut self, delta: f64, lambda0: f64) -> Option<(f64, f64)> {
        let n = self.qtr.len();
        self.gauss_newton();
        let gn_ok = self.z.iter().all(|v| v.is_finite());
        let mut dxnorm = if gn_ok { self.dnorm_z() } else { f64::INFINITY };
        self.gauss_newton_dnorm = dxnorm;
        let mut fp = dxnorm - delta;
        let mut lambda = 0.0;
        if !gn_ok || fp > P1 * delta {
            // Moré's lower bound from the Gauss–Newton step, 0 when that step is not finite or
            // R is singular (MINPACK's `nsing < n`): the correction then divides by R's zero
            // diagonal entry, or starts from a non-finite step, and is not finite.
            let mut lower = self.newton_correction(fp, delta, dxnorm, false);
            if !lower.is_finite() {
                lower = 0.0;
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
                if !self.solve_damped(lambda.sqrt()) {
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

/// `v` as `n` zeros, in its own storage when it has that length.
fn zeroed(v: &mut DVector<f64>, n: usize) {
    if v.len() == n {
        v.fill(0.0);
    } else {
        *v = DVector::zeros(n);
    }
}

/// The rotation `(cos, sin)` that zeroes `b` against `a`: `−sin·a + cos·b = 0`, computed as
/// MINPACK does (from the cotangent or the tangent, whichever is at most one).
fn givens(a: f64, b: f64) -> (f64, f64) {
    if a.abs() < b.abs() {
        let cotan = a / b;
        let sin = 0.5 / (0.25 + 0.25 * cotan * cotan).sqrt();
        (sin * cotan, sin)
    } else {
        let tan = b / a;
        let cos = 0.5 / (0.25 + 0.25 * tan * tan).sqrt();
        (cos, cos * tan)
    }
}

#[cfg(test)]
mod tests {
    use super::householder_qr;
    use crate::solver::column_dot::{awkward, bits};
    use nalgebra::{DMatrix, DVector};

    /// The factorisation as first written, on nalgebra's column views: the reference the
    /// slice version must match bit for bit.
    fn on_views(a: &mut DMatrix<f64>, b: &mut DVector<f64>, p: &mut [usize]) {
        let (m, n) = a.shape();
        for k in 0..n.min(m) {
            let norms = (k..n).map(|j| (j, a.view((k, j), (m - k, 1)).norm()));
            let best = norms
                .fold((k, -1.0), |b, c| if c.1 > b.1 { c } else { b })
                .0;
            a.swap_columns(k, best);
            p.swap(k, best);
            let norm = a.view((k, k), (m - k, 1)).norm();
            if norm == 0.0 {
                continue;
            }
            let alpha = if a[(k, k)] > 0.0 { -norm } else { norm };
            a[(k, k)] -= alpha;
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

    /// The factorisation on slices is the one on column views, bit for bit: tall, square and
    /// wide shapes, a zero column and repeated columns (pivot ties).
    #[test]
    fn the_slice_factorisation_is_the_view_factorisation() {
        for (m, n, seed) in [
            (18, 6, 3),
            (25, 5, 4),
            (6, 6, 5),
            (9, 1, 6),
            (3, 5, 7),
            (40, 7, 8),
        ] {
            let mut j = DMatrix::from_vec(m, n, awkward(m * n, seed));
            if n > 2 {
                j.column_mut(1).fill(0.0);
                let first = j.column(0).into_owned();
                j.column_mut(n - 1).copy_from(&first);
            }
            let rhs = DVector::from_vec(awkward(m.max(n), seed + 100));
            let (mut a, mut b, mut p) = (j.clone(), rhs.clone(), (0..n).collect::<Vec<_>>());
            householder_qr(&mut a, &mut b, Some(&mut p));
            let (mut a0, mut b0, mut p0) = (j, rhs, (0..n).collect::<Vec<_>>());
            on_views(&mut a0, &mut b0, &mut p0);
            assert_eq!(p, p0, "{m}x{n}");
            assert_eq!(bits(a.as_slice()), bits(a0.as_slice()), "{m}x{n}");
            assert_eq!(bits(b.as_slice()), bits(b0.as_slice()), "{m}x{n}");
        }
    }

    /// MINPACK's `qrfac` pivoting: the remaining column of largest norm moves forward, the
    /// first of equal norms keeping its place; `R` and `Qᵀb` reproduce `J P` and `b`'s norm.
    #[test]
    fn the_qr_pivots_on_the_first_largest_column_and_factors_the_permuted_matrix() {
        // Columns of norms 1, 2, 2: the second one moves first; then the third (norm 2
        // against 1) comes second.
        let j = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0]);
        let b = DVector::from_column_slice(&[1.0, 2.0, 3.0]);
        let (mut a, mut qtb, mut perm) = (j.clone(), b.clone(), vec![0, 1, 2]);
        householder_qr(&mut a, &mut qtb, Some(&mut perm));
        assert_eq!(perm, vec![1, 2, 0]);
        let r = a.upper_triangle();
        let permuted = DMatrix::from_fn(3, 3, |i, k| j[(i, perm[k])]);
        // RᵀR = (J P)ᵀ(J P), since Q is orthogonal.
        assert!((r.transpose() * &r - permuted.transpose() * &permuted).amax() < 1e-14);
        assert!((qtb.norm() - b.norm()).abs() < 1e-14);
        // Equal norms throughout: no column moves.
        let (mut a, mut qtb, mut perm) = (DMatrix::identity(2, 2), DVector::zeros(2), vec![0, 1]);
        householder_qr(&mut a, &mut qtb, Some(&mut perm));
        assert_eq!(perm, vec![0, 1]);
    }
}

#[cfg(test)]
mod minpack_reference;
