//! The candidate pool: validated candidates stored transposed, their information matrices
//! and the block products the D engines share.

use nalgebra::{DMatrix, DVector};

use super::gains::argmax;
use super::linalg::{det_in_place, spd_inverse};
use super::{SelectionError, SelectionOptions, RIDGE};
use crate::identify::observability::{sorted_singular_values, RANK_TOLERANCE};

/// Validated candidates, stored transposed: column j·b + r of `x` is row r of candidate j.
pub(super) struct Pool {
    pub(super) k: usize,
    pub(super) b: usize,
    pub(super) n: usize,
    pub(super) x: DMatrix<f64>,
    pub(super) ridge: DVector<f64>,
}

impl Pool {
    /// The error when no eligible candidate is left to grow a design of `size` poses.
    pub(super) fn exhausted(&self, size: usize) -> SelectionError {
        SelectionError::TooFewCandidates {
            available: self.k,
            requested: size + 1,
        }
    }

    pub(super) fn new(
        candidates: &[DMatrix<f64>],
        options: &SelectionOptions,
    ) -> Result<Self, SelectionError> {
        let k = candidates.len();
        let first = candidates.first().ok_or(SelectionError::TooFewCandidates {
            available: 0,
            requested: options.count,
        })?;
        let (b, n) = first.shape();
        if b == 0 || n == 0 {
            return Err(SelectionError::Empty { rows: b, cols: n });
        }
        for (index, c) in candidates.iter().enumerate() {
            if c.shape() != (b, n) {
                return Err(SelectionError::ShapeMismatch {
                    index,
                    rows: c.nrows(),
                    cols: c.ncols(),
                    expected_rows: b,
                    expected_cols: n,
                });
            }
            if c.iter().any(|v| !v.is_finite()) {
                return Err(SelectionError::NonFinite { index });
            }
        }
        let rows = options.count.saturating_mul(b);
        if rows < n {
            return Err(SelectionError::TooFewRows {
                poses: options.count,
                rows,
                n,
            });
        }
        if !options.allow_replicates && k < options.count {
            return Err(SelectionError::TooFewCandidates {
                available: k,
                requested: options.count,
            });
        }
        let mut x = DMatrix::zeros(n, k * b);
        for (j, c) in candidates.iter().enumerate() {
            for r in 0..b {
                x.column_mut(j * b + r).copy_from(&c.row(r).transpose());
            }
        }
        let sums = DVector::from_fn(n, |p, _| x.row(p).norm_squared());
        let rank = scaled_rank(&x, &sums);
        if rank < n {
            return Err(SelectionError::RankDeficient { rank, n });
        }
        let ridge = sums * (RIDGE / k as f64);
        Ok(Self { k, b, n, x, ridge })
    }

    /// The n × b block of candidate j (its rows as columns).
    pub(super) fn block(&self, j: usize) -> nalgebra::DMatrixView<'_, f64> {
        self.x.columns(j * self.b, self.b)
    }

    /// Σ_{j ∈ design} C_jᵀC_j (+ the ridge), formed from scratch.
    pub(super) fn gram(&self, design: &[usize], ridge: bool) -> DMatrix<f64> {
        let mut m = if ridge {
            DMatrix::from_diagonal(&self.ridge)
        } else {
            DMatrix::zeros(self.n, self.n)
        };
        for &j in design {
            for r in 0..self.b {
                let row = self.x.column(j * self.b + r);
                m.ger(1.0, &row, &row, 1.0);
            }
        }
        m
    }

    /// The n × (|design|·b) matrix of the design's rows (as columns).
    pub(super) fn design_columns(&self, design: &[usize]) -> DMatrix<f64> {
        let mut xs = DMatrix::zeros(self.n, design.len() * self.b);
        for (pos, &j) in design.iter().enumerate() {
            xs.columns_mut(pos * self.b, self.b)
                .copy_from(&self.block(j));
        }
        xs
    }

    pub(super) fn singular(&self, design: &[usize]) -> SelectionError {
        let xs = self.design_columns(design);
        let sums = DVector::from_fn(self.n, |p, _| xs.row(p).norm_squared());
        SelectionError::SingularDesign {
            rank: scaled_rank(&xs, &sums),
            n: self.n,
        }
    }

    /// The inverse of M = C_SᵀC_S for an exchange sweep, and whether the ridge had to be
    /// added because C_SᵀC_S is numerically singular.
    pub(super) fn exchange_inverse(
        &self,
        design: &[usize],
    ) -> Result<(DMatrix<f64>, bool), SelectionError> {
        if let Some(inverse) = spd_inverse(&self.gram(design, false)) {
            return Ok((inverse, false));
        }
        spd_inverse(&self.gram(design, true))
            .map(|inverse| (inverse, true))
            .ok_or_else(|| self.singular(design))
    }

    /// C_j M⁻¹ C_jᵀ (row-major b × b, into `out`) from Y = M⁻¹ X.
    pub(super) fn block_product(&self, y: &DMatrix<f64>, j: usize, out: &mut [f64]) {
        let b = self.b;
        for r in 0..b {
            for s in 0..b {
                out[r * b + s] = self.x.column(j * b + r).dot(&y.column(j * b + s));
            }
        }
    }

    /// The best eligible addition by the D gain det(I_b + C_j M⁻¹ C_jᵀ), from Y = M⁻¹ X
    /// (ties: lowest index).
    pub(super) fn best_block_gain(&self, y: &DMatrix<f64>, eligible: &[bool]) -> Option<usize> {
        let b = self.b;
        let mut g = vec![0.0; b * b];
        argmax((0..self.k).filter(|&j| eligible[j]).map(|j| {
            self.block_product(y, j, &mut g);
            for r in 0..b {
                g[r * b + r] += 1.0;
            }
            (j, det_in_place(&mut g, b))
        }))
    }
}

/// Numerical rank of the rows stored as columns of `x`, each parameter scaled to unit norm.
fn scaled_rank(x: &DMatrix<f64>, sums: &DVector<f64>) -> usize {
    let mut scaled = x.transpose();
    for (p, mut column) in scaled.column_iter_mut().enumerate() {
        if sums[p] > 0.0 {
            column /= sums[p].sqrt();
        }
    }
    let values = sorted_singular_values(scaled);
    let largest = values.first().copied().unwrap_or(0.0);
    values
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * largest)
        .count()
}
