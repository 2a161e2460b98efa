//! The rotation nearest a 3×3 matrix by Horn's quaternion method, generic over [`Scalar`] with
//! exact first derivatives.
//!
//! For `M = Σ_k b_k a_kᵀ` (measured points `b_k` against model points `a_k`, both centred), the
//! rotation `R` maximising `Σ_k b_k · R a_k = tr(Rᵀ M)` is `R(q)` of the unit quaternion `q`
//! maximising `qᵀ N(M) q`, where `N(M)` is Horn's symmetric 4×4 matrix (B. K. P. Horn, "Closed-
//! form solution of absolute orientation using unit quaternions", JOSA A 4(4), 1987): the
//! eigenvector of its largest eigenvalue. For three or more model points not on one line the
//! largest eigenvalue is simple, coplanar points included. For rotation matrices `R_k`,
//! `M = Σ_k R_k` gives their chordal mean.
//!
//! The eigenproblem is solved in `f64` (nalgebra's `SymmetricEigen`); the answer is lifted to the
//! scalar type by the first-order perturbation of a simple eigenvector,
//! `q = q₀ + (λ₀ I − N₀)⁺ (N − N₀) q₀`, the pseudo-inverse acting on the complement of `q₀`:
//! the value part is `q₀` unchanged, the derivative part is the exact derivative of the
//! eigenvector (of the derivative parts of `M`), so no iteration is differentiated.

use nalgebra::{Matrix3, Matrix4, SymmetricEigen, Vector4};

use crate::scalar::{lift, Scalar};

/// Horn's symmetric matrix of `m = Σ b aᵀ`: `qᵀ N q = tr(R(q)ᵀ m)` for a unit quaternion `q`
/// (`[w, x, y, z]`).
fn horn_matrix<T: Scalar>(m: &Matrix3<T>) -> Matrix4<T> {
    // Horn's S_ij = Σ a_i b_j is mᵀ.
    let s = |i: usize, j: usize| m[(j, i)];
    let (xx, xy, xz) = (s(0, 0), s(0, 1), s(0, 2));
    let (yx, yy, yz) = (s(1, 0), s(1, 1), s(1, 2));
    let (zx, zy, zz) = (s(2, 0), s(2, 1), s(2, 2));
    Matrix4::new(
        xx + yy + zz,
        yz - zy,
        zx - xz,
        xy - yx,
        yz - zy,
        xx - yy - zz,
        xy + yx,
        zx + xz,
        zx - xz,
        xy + yx,
        -xx + yy - zz,
        yz + zy,
        xy - yx,
        zx + xz,
        yz + zy,
        -xx - yy + zz,
    )
}

/// The rotation matrix of quaternion `q = [w, x, y, z]` (any non-zero norm: the homogeneous
/// form divided by `|q|²`).
pub(crate) fn quaternion_rotation<T: Scalar>(q: &Vector4<T>) -> Matrix3<T> {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    let two = lift::<T>(2.0);
    let n = w * w + x * x + y * y + z * z;
    Matrix3::new(
        w * w + x * x - y * y - z * z,
        two * (x * y - w * z),
        two * (x * z + w * y),
        two * (x * y + w * z),
        w * w - x * x + y * y - z * z,
        two * (y * z - w * x),
        two * (x * z - w * y),
        two * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    ) / n
}

/// The rotation `R` maximising `tr(Rᵀ m)` (see the module documentation), with the derivative
/// parts of `m` carried to it to first order.
pub(crate) fn nearest_rotation<T: Scalar>(m: &Matrix3<T>) -> Matrix3<T> {
    let n = horn_matrix(m);
    let n0 = n.map(|v| v.re());
    let eigen = SymmetricEigen::new(n0);
    let top = eigen.eigenvalues.imax();
    let lambda = eigen.eigenvalues[top];
    let q0 = eigen.eigenvectors.column(top).into_owned();
    // (λ₀ I − N₀)⁺ on the complement of q₀; an eigenvalue equal to λ₀ (a degenerate fit) is
    // left out, as the Moore–Penrose inverse leaves out a zero eigenvalue.
    let scale = eigen.eigenvalues.amax().max(f64::MIN_POSITIVE);
    let mut pseudo = Matrix4::<f64>::zeros();
    for j in (0..4).filter(|&j| j != top) {
        let gap = lambda - eigen.eigenvalues[j];
        if gap > 64.0 * f64::EPSILON * scale {
            let v = eigen.eigenvectors.column(j);
            pseudo += v * v.transpose() / gap;
        }
    }
    // The derivative parts of N alone (value parts exactly zero): the lift leaves q₀ as it is.
    let dn = n - n0.map(lift::<T>);
    let q0t = q0.map(lift::<T>);
    let q = q0t + pseudo.map(lift::<T>) * (dn * q0t);
    quaternion_rotation(&q)
}

#[cfg(test)]
mod tests;
