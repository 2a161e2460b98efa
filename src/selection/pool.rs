//! The candidate pool: validated candidates stored transposed, their information matrices
//! and the block products the D engines share.

use std::ops::Range;

use nalgebra::{DMatrix, DMatrixView, DVector, RowDVector};

use super::linalg::{det_in_place, spd_inverse};
use super::{SelectionError, SelectionOptions, RIDGE};
use crate::identify::observability::{sorted_singular_values, RANK_TOLERANCE};

/// About this many candidates at a time enter a product with M⁻¹ (see [`Pool::chunks`]): the
/// products' memory stays a few hundred kilobytes whatever the size of the pool.
pub(super) const CHUNK: usize = 2048;

/// nalgebra forms a product with a dimension of at most 5 without matrixmultiply.
const SMALL_PRODUCT: usize = 6;

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
        let mut x = DMatrix::zeros(n, candidates.len() * b);
        for (j, c) in candidates.iter().enumerate() {
            for r in 0..b {
                x.column_mut(j * b + r).copy_from(&c.row(r).transpose());
            }
        }
        Self::checked(x, b, options)
    }

    /// The pool of the candidates whose rows are the columns of `x` (column j·b + r is row r
    /// of candidate j), with the checks of [`Self::new`] in the same order.
    pub(super) fn from_columns(
        x: DMatrix<f64>,
        b: usize,
        options: &SelectionOptions,
    ) -> Result<Self, SelectionError> {
        let n = x.nrows();
        if x.ncols() == 0 {
            return Err(SelectionError::TooFewCandidates {
                available: 0,
                requested: options.count,
            });
        }
        if b == 0 || n == 0 {
            return Err(SelectionError::Empty { rows: b, cols: n });
        }
        if !x.ncols().is_multiple_of(b) {
            return Err(SelectionError::ShapeMismatch {
                index: x.ncols() / b,
                rows: x.ncols() % b,
                cols: n,
                expected_rows: b,
                expected_cols: n,
            });
        }
        if let Some(column) = x
            .column_iter()
            .position(|c| c.iter().any(|v| !v.is_finite()))
        {
            return Err(SelectionError::NonFinite { index: column / b });
        }
        Self::checked(x, b, options)
    }

    /// The pool of validated, finite candidates `x` of `b` rows: the remaining checks (enough
    /// rows and candidates, full rank) and the ridge.
    fn checked(
        x: DMatrix<f64>,
        b: usize,
        options: &SelectionOptions,
    ) -> Result<Self, SelectionError> {
        let (n, k) = (x.nrows(), x.ncols() / b);
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
        let sums = DVector::from_fn(n, |p, _| x.row(p).norm_squared());
        let rank = scaled_rank(&x, &sums);
        if rank < n {
            return Err(SelectionError::RankDeficient { rank, n });
        }
        let ridge = sums * (RIDGE / k as f64);
        Ok(Self { k, b, n, x, ridge })
    }

    /// M⁻¹ of the ridge alone, diag(1/ridge): the start of the greedy construction.
    pub(super) fn ridge_inverse(&self) -> DMatrix<f64> {
        DMatrix::from_diagonal(&self.ridge.map(|v| 1.0 / v))
    }

    /// The candidate ranges in which products with X are formed: about [`CHUNK`] candidates
    /// each, all of nearly the same size (none small enough for nalgebra to switch to its
    /// small-matrix product, so each entry is the one the whole product would give).
    pub(super) fn chunks(&self) -> impl Iterator<Item = Range<usize>> {
        even_ranges(self.k)
    }

    /// The columns of X (rows of the candidates) of the candidates `range`.
    pub(super) fn columns(&self, range: &Range<usize>) -> DMatrixView<'_, f64> {
        self.x.columns(range.start * self.b, range.len() * self.b)
    }

    /// The candidates `indices` in groups for products with X: split as [`Self::chunks`]
    /// splits the pool, so that each group's product gives the entries the whole product
    /// would.
    pub(super) fn column_groups<'i>(&self, indices: &'i [usize]) -> Vec<&'i [usize]> {
        even_ranges(indices.len())
            .map(|range| &indices[range])
            .filter(|group| !group.is_empty())
            .collect()
    }

    /// The columns `columns` of X (candidates' rows: candidates themselves when b = 1), side
    /// by side; padded with copies of the first to at least min(6, K) columns, since nalgebra
    /// forms products of fewer than 6 columns another way (rounding differently) than the
    /// whole-pool product.
    pub(super) fn gather(&self, columns: &[usize]) -> DMatrix<f64> {
        let width = columns.len().max(SMALL_PRODUCT.min(self.k));
        DMatrix::from_fn(self.n, width, |p, c| {
            self.x[(p, columns.get(c).copied().unwrap_or(columns[0]))]
        })
    }

    /// x_rᵀM⁻¹x_r of every row r of every candidate (column r of X), formed chunk by chunk.
    pub(super) fn row_leverages(&self, minv: &DMatrix<f64>) -> RowDVector<f64> {
        let mut leverages = RowDVector::zeros(self.k * self.b);
        for range in self.chunks() {
            let x = self.columns(&range);
            let y = minv * x;
            column_dots(
                &x,
                &y,
                &mut leverages.as_mut_slice()[range.start * self.b..],
            );
        }
        leverages
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

    /// C_j M⁻¹ C_jᵀ (row-major b × b, into `out`) from Y = M⁻¹ X_chunk, the product with
    /// the columns of the candidates from `start` on.
    pub(super) fn block_product(&self, y: &DMatrix<f64>, start: usize, j: usize, out: &mut [f64]) {
        let b = self.b;
        for r in 0..b {
            for s in 0..b {
                out[r * b + s] = self.x.column(j * b + r).dot(&y.column((j - start) * b + s));
            }
        }
    }

    /// The best eligible addition by the D gain det(I_b + C_j M⁻¹ C_jᵀ) (ties: lowest index).
    pub(super) fn best_block_gain(&self, minv: &DMatrix<f64>, eligible: &[bool]) -> Option<usize> {
        let b = self.b;
        let mut g = vec![0.0; b * b];
        let mut gains = Vec::with_capacity(self.k);
        for range in self.chunks() {
            let y = minv * self.columns(&range);
            for j in range.clone().filter(|&j| eligible[j]) {
                self.block_product(&y, range.start, j, &mut g);
                for r in 0..b {
                    g[r * b + r] += 1.0;
                }
                gains.push((j, det_in_place(&mut g, b)));
            }
        }
        argmax(gains.into_iter())
    }
}

/// `0..len` split into ⌈len / [`CHUNK`]⌉ consecutive ranges (at least one), whose lengths
/// differ by at most one.
fn even_ranges(len: usize) -> impl Iterator<Item = Range<usize>> {
    let parts = len.div_ceil(CHUNK).max(1);
    let (width, extra) = (len / parts, len % parts);
    (0..parts).map(move |p| {
        let start = p * width + p.min(extra);
        start..start + width + usize::from(p < extra)
    })
}

/// The dot products of the columns of `x` and `y` into `out`, each summed from the first row
/// down (the sums of `x.component_mul(y).row_sum()`, without its temporaries).
pub(super) fn column_dots(x: &DMatrixView<'_, f64>, y: &DMatrix<f64>, out: &mut [f64]) {
    for ((xc, yc), out) in x.column_iter().zip(y.column_iter()).zip(out) {
        *out = xc
            .iter()
            .zip(yc.iter())
            .fold(0.0, |sum, (a, b)| sum + a * b);
    }
}

/// Rows of the pool [`scaled_rank`] reduces at once.
const QR_ROWS: usize = 4096;

/// Numerical rank of the rows stored as columns of `x`, each parameter scaled to unit norm
/// (`sums`: the parameters' sums of squares; a zero parameter stays zero). The rows are
/// reduced, [`QR_ROWS`] at a time, to the n × n triangular factor R of their QR factorisation
/// (the same singular values), so that no copy of a large pool is made.
fn scaled_rank(x: &DMatrix<f64>, sums: &DVector<f64>) -> usize {
    let scaled = |columns: nalgebra::DMatrixView<'_, f64>| {
        let mut rows = columns.transpose();
        for (p, mut column) in rows.column_iter_mut().enumerate() {
            if sums[p] > 0.0 {
                column /= sums[p].sqrt();
            }
        }
        rows
    };
    let mut r = DMatrix::zeros(0, x.nrows());
    for start in (0..x.ncols()).step_by(QR_ROWS) {
        let chunk = scaled(x.columns(start, QR_ROWS.min(x.ncols() - start)));
        let mut stacked = DMatrix::zeros(r.nrows() + chunk.nrows(), x.nrows());
        stacked.rows_mut(0, r.nrows()).copy_from(&r);
        stacked.rows_mut(r.nrows(), chunk.nrows()).copy_from(&chunk);
        r = stacked.qr().r();
    }
    let values = sorted_singular_values(r);
    let largest = values.first().copied().unwrap_or(0.0);
    values
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * largest)
        .count()
}

/// The first eligible index of largest score (strictly larger replaces: ties to the lowest).
pub(super) fn argmax(scores: impl Iterator<Item = (usize, f64)>) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (j, score) in scores {
        if best.is_none_or(|(_, b)| score > b) {
            best = Some((j, score));
        }
    }
    best.map(|(j, _)| j)
}
