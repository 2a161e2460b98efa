//! The normal equations of a bordered problem, kept per group (an *arrowhead* `JᵀJ`), and their
//! damped solve by eliminating every group's block: a Schur complement on the shared block.
//!
//! With `J = [blkdiag(J₀ … J_{g−1}) | B]` (rows of group `k`: `[J_k | B_k]`) the normal matrix
//! `JᵀJ` has the diagonal blocks `A_k = J_kᵀJ_k`, the border `C_k = J_kᵀB_k` and the shared
//! corner `S = Σ B_kᵀB_k`; the gradient `Jᵀr` has the parts `g_k = J_kᵀr_k` and
//! `g_s = Σ B_kᵀr_k`. The damped system `(JᵀJ + λD²) p = Jᵀr` reads
//!
//! ```text
//! (A_k + λD_k²) p_k + C_k p_s = g_k                       (every group k)
//! Σ C_kᵀ p_k + (S + λD_s²) p_s = g_s
//! ```
//!
//! With the Cholesky factor `A_k + λD_k² = L_k L_kᵀ`, `Y_k = L_k⁻¹ C_k` and `y_k = L_k⁻¹ g_k`
//! (triangular solves, never an inverse), the shared step solves the reduced system
//! `(S + λD_s² − Σ Y_kᵀY_k) p_s = g_s − Σ Y_kᵀy_k` (again by Cholesky), and each group's step
//! is `p_k = L_k⁻ᵀ (y_k − Y_k p_s)`. The cost is linear in the number of groups.

use std::fmt;

use nalgebra::{DMatrix, DVector};

use crate::solver::bordered::{check_blocks, BorderedBlock, BorderedLayout, LayoutMismatch};
use crate::solver::column_dot::{add_gram, add_transpose_times, transpose_times};

/// A Cholesky pivot below this fraction of its matrix's diagonal entry means the column is a
/// combination of the previous ones to working precision: the matrix counts as singular.
const PIVOT_TOLERANCE: f64 = 16.0 * f64::EPSILON;

/// One group's part of the normal equations.
#[derive(Debug, Clone)]
struct GroupNormal {
    /// `A_k = J_kᵀJ_k`, `n_k × n_k`.
    own: DMatrix<f64>,
    /// `C_k = J_kᵀB_k`, `n_k × s`.
    coupling: DMatrix<f64>,
    /// `g_k = J_kᵀr_k`.
    gradient: DVector<f64>,
}

/// The normal equations `JᵀJ`, `Jᵀr` of a bordered problem at one point, kept per group.
#[derive(Debug, Clone)]
pub struct ArrowheadSystem {
    groups: Vec<GroupNormal>,
    /// `S = Σ B_kᵀB_k`, `s × s`.
    shared: DMatrix<f64>,
    /// `g_s = Σ B_kᵀr_k`.
    shared_gradient: DVector<f64>,
}

/// A damped block whose Cholesky factorisation failed or lost every digit of a pivot (the
/// damping is too small for a rank-deficient block).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SingularBlock {
    /// Group `k`'s own block `A_k + λD_k²`.
    Group(usize),
    /// The reduced shared system.
    Shared,
}

impl fmt::Display for SingularBlock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SingularBlock::Group(k) => write!(f, "group {k}'s damped block is singular"),
            SingularBlock::Shared => f.write_str("the reduced shared system is singular"),
        }
    }
}

impl std::error::Error for SingularBlock {}

/// `J p` for the bordered Jacobian of `blocks` (rows in group order).
///
/// # Panics
/// If `blocks` or `p` do not fit `layout` (see [`check_blocks`]).
pub fn jacobian_times(
    layout: &BorderedLayout,
    blocks: &[BorderedBlock],
    p: &DVector<f64>,
) -> DVector<f64> {
    let rows: usize = blocks.iter().map(|b| b.residuals.len()).sum();
    let shared = p.rows(layout.shared_offset(), layout.shared);
    let mut product = DVector::zeros(rows);
    let mut row = 0;
    for (k, block) in blocks.iter().enumerate() {
        let m = block.residuals.len();
        let own = p.rows(layout.offset(k), layout.own[k]);
        let mut part = product.rows_mut(row, m);
        part.gemv(1.0, &block.own, &own, 0.0);
        part.gemv(1.0, &block.shared, &shared, 1.0);
        row += m;
    }
    product
}

impl ArrowheadSystem {
    /// Forms `A_k`, `C_k`, `g_k`, `S` and `g_s` from every group's block.
    ///
    /// # Errors
    /// If the blocks do not fit `layout` ([`check_blocks`]).
    pub fn assemble(
        layout: &BorderedLayout,
        blocks: &[BorderedBlock],
    ) -> Result<Self, LayoutMismatch> {
        check_blocks(layout, blocks)?;
        let s = layout.shared;
        let mut shared = DMatrix::zeros(s, s);
        let mut shared_gradient = DVector::zeros(s);
        let groups = blocks
            .iter()
            .map(|block| {
                let (j, b, r) = (&block.own, &block.shared, &block.residuals);
                // nalgebra's products (gemm_tr, gemv_tr, tr_mul) on the columns as slices,
                // the symmetric ones computed on one side of the diagonal: the same bits.
                add_gram(&mut shared, b);
                add_transpose_times(&mut shared_gradient, b, r);
                let mut own = DMatrix::zeros(j.ncols(), j.ncols());
                add_gram(&mut own, j);
                let mut gradient = DVector::zeros(j.ncols());
                add_transpose_times(&mut gradient, j, r);
                GroupNormal {
                    own,
                    coupling: transpose_times(j, b),
                    gradient,
                }
            })
            .collect();
        Ok(Self {
            groups,
            shared,
            shared_gradient,
        })
    }

    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.groups.iter().map(|g| g.own.nrows()).sum::<usize>() + self.shared.nrows()
    }

    /// The gradient `Jᵀr`, in the order of `x`.
    pub fn gradient(&self) -> DVector<f64> {
        let parts = self.groups.iter().map(|g| &g.gradient);
        let values = parts.chain([&self.shared_gradient]).flat_map(|v| v.iter());
        DVector::from_iterator(self.unknowns(), values.copied())
    }

    /// The Euclidean norms of the Jacobian's columns, in the order of `x` (square roots of the
    /// diagonal of `JᵀJ`).
    pub fn column_norms(&self) -> DVector<f64> {
        let parts = self.groups.iter().map(|g| &g.own).chain([&self.shared]);
        let values = parts.flat_map(|a| a.diagonal().iter().copied().collect::<Vec<_>>());
        DVector::from_iterator(self.unknowns(), values.map(f64::sqrt))
    }

    /// Whether every entry is finite.
    pub fn is_finite(&self) -> bool {
        let finite = |m: &DMatrix<f64>| m.iter().all(|v| v.is_finite());
        let vector = |v: &DVector<f64>| v.iter().all(|v| v.is_finite());
        finite(&self.shared)
            && vector(&self.shared_gradient)
            && self
                .groups
                .iter()
                .all(|g| finite(&g.own) && finite(&g.coupling) && vector(&g.gradient))
    }

    /// The step `p` solving `(JᵀJ + λ D²) p = Jᵀr` (`D = diag(scale)`, in the order of `x`), by
    /// eliminating every group's block with its own Cholesky factor and solving the reduced
    /// shared system (module documentation). A group without own unknowns only contributes to
    /// the shared system; without shared unknowns every group's step is independent.
    ///
    /// # Errors
    /// [`SingularBlock`] if a damped block or the reduced system is not numerically positive
    /// definite (a rank-deficient block with `λ` too small, or `λ = 0`); never a NaN step from
    /// a singular block.
    ///
    /// # Panics
    /// If `scale` does not have one entry per unknown.
    pub fn damped_step(
        &self,
        lambda: f64,
        scale: &DVector<f64>,
    ) -> Result<DVector<f64>, SingularBlock> {
        assert_eq!(scale.len(), self.unknowns(), "one scale per unknown");
        let s = self.shared.nrows();
        let shared_scale = scale.rows(scale.len() - s, s);
        let mut reduced = self.shared.clone();
        for (i, d) in shared_scale.iter().enumerate() {
            reduced[(i, i)] += lambda * d * d;
        }
        let reference = reduced.diagonal();
        let mut rhs = self.shared_gradient.clone();
        // Per group: L_k, Y_k = L_k⁻¹C_k, y_k = L_k⁻¹g_k.
        let mut eliminated = Vec::with_capacity(self.groups.len());
        let mut offset = 0;
        for (k, group) in self.groups.iter().enumerate() {
            let n = group.own.nrows();
            let mut damped = group.own.clone();
            for i in 0..n {
                let d = scale[offset + i];
                damped[(i, i)] += lambda * d * d;
            }
            offset += n;
            let l = cholesky(damped).ok_or(SingularBlock::Group(k))?;
            let coupling = l
                .solve_lower_triangular(&group.coupling)
                .ok_or(SingularBlock::Group(k))?;
            let gradient = l
                .solve_lower_triangular(&group.gradient)
                .ok_or(SingularBlock::Group(k))?;
            reduced.gemm_tr(-1.0, &coupling, &coupling, 1.0);
            rhs.gemv_tr(-1.0, &coupling, &gradient, 1.0);
            eliminated.push((l, coupling, gradient));
        }
        let shared_step = if s == 0 {
            DVector::zeros(0)
        } else {
            let l = cholesky_against(reduced, &reference).ok_or(SingularBlock::Shared)?;
            let half = l
                .solve_lower_triangular(&rhs)
                .ok_or(SingularBlock::Shared)?;
            l.tr_solve_lower_triangular(&half)
                .ok_or(SingularBlock::Shared)?
        };
        let mut step = DVector::zeros(self.unknowns());
        let mut offset = 0;
        for (k, (l, coupling, mut gradient)) in eliminated.into_iter().enumerate() {
            let n = l.nrows();
            gradient.gemv(-1.0, &coupling, &shared_step, 1.0);
            let own = l
                .tr_solve_lower_triangular(&gradient)
                .ok_or(SingularBlock::Group(k))?;
            step.rows_mut(offset, n).copy_from(&own);
            offset += n;
        }
        step.rows_mut(offset, s).copy_from(&shared_step);
        Ok(step)
    }
}

/// The lower Cholesky factor of the symmetric `matrix` (lower triangle read), or `None` if it is
/// not numerically positive definite relative to its own diagonal.
fn cholesky(matrix: DMatrix<f64>) -> Option<DMatrix<f64>> {
    let reference = matrix.diagonal();
    cholesky_against(matrix, &reference)
}

/// The lower Cholesky factor of `matrix`, or `None` if a pivot `L_ii²` is not positive
/// (nalgebra's factorisation then fails) or is below [`PIVOT_TOLERANCE`] times `reference_i`
/// (the diagonal the matrix was formed from, so that a cancellation in forming it is caught
/// too).
fn cholesky_against(matrix: DMatrix<f64>, reference: &DVector<f64>) -> Option<DMatrix<f64>> {
    if matrix.nrows() == 0 {
        return Some(matrix);
    }
    if matrix.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let l = matrix.cholesky()?.unpack();
    let healthy = l
        .diagonal()
        .iter()
        .zip(reference.iter())
        .all(|(&pivot, &diagonal)| pivot * pivot >= PIVOT_TOLERANCE * diagonal);
    healthy.then_some(l)
}
