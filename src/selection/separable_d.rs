//! D criterion, b > 1 rows per candidate, separable pools: row r of every candidate is
//! non-zero only in columns of its own (the stacked traditional design, one row per leg), so
//! M is block-diagonal and each gain is a product of one rank-one factor per row position.

use nalgebra::{DMatrix, DMatrixView};

use super::driver::{Engine, Step};
use super::gains::BestSwap;
use super::linalg::spd_inverse;
use super::pool::{argmax, column_dots, Pool};
use super::running_inverse::{Change, RunningInverse};
use super::{Criterion, SelectionError, ACCEPT};

/// The column supports of the b row positions (row r's: the columns where row r of some
/// candidate is non-zero, increasing) if they are pairwise disjoint, `None` otherwise. Read
/// from the numbers alone; stops at the first column two row positions share.
pub(super) fn row_supports(pool: &Pool) -> Option<Vec<Vec<usize>>> {
    let mut owner: Vec<Option<usize>> = vec![None; pool.n];
    for j in 0..pool.k {
        for r in 0..pool.b {
            for (p, &v) in pool.x.column(j * pool.b + r).iter().enumerate() {
                if v == 0.0 {
                    continue;
                }
                match owner[p] {
                    None => owner[p] = Some(r),
                    Some(other) if other != r => return None,
                    Some(_) => {}
                }
            }
        }
    }
    Some(
        (0..pool.b)
            .map(|r| (0..pool.n).filter(|&p| owner[p] == Some(r)).collect())
            .collect(),
    )
}

/// The D engine of a separable pool. With S_r the support of row position r, M = CᵀC is
/// block-diagonal with blocks M_r on S_r, det M = Π_r det M_r, and with the rank-one values
/// d_r(j) = x_rjᵀM_r⁻¹x_rj, d_r(i, j) = x_riᵀM_r⁻¹x_rj of row r of candidates i and j:
/// the gain of adding j is Π_r (1 + d_r(j)), the ratio of swapping design point i for j is
/// Π_r [(1 + d_r(j))(1 − d_r(i)) + d_r(i, j)²], and each M_r⁻¹ follows by Sherman–Morrison.
/// These are [`BlockD`](super::block_d::BlockD)'s block determinants and Woodbury updates
/// when D_j = C_jM⁻¹C_jᵀ is diagonal, at about 1/b² of the cost of its cross products.
pub(super) struct SeparableD<'a> {
    pool: &'a Pool,
    /// Per row position r: its support S_r.
    pub(super) supports: Vec<Vec<usize>>,
    /// Per row position r: row r of every candidate on S_r (|S_r| × K, column j: candidate j).
    rows: Vec<DMatrix<f64>>,
    /// Per row position r: M_r⁻¹ of the current design (with the ridge in the greedy phase).
    pub(super) blocks: Vec<DMatrix<f64>>,
    /// The dense M⁻¹ of the ridge start and of its one refresh in the greedy phase, from
    /// which `blocks` are taken; not updated in between.
    start: RunningInverse,
}

impl<'a> SeparableD<'a> {
    /// The engine for `pool`, or `None` if the pool is not separable ([`row_supports`]).
    pub(super) fn new(pool: &'a Pool) -> Option<Self> {
        let supports = row_supports(pool)?;
        let rows = supports
            .iter()
            .enumerate()
            .map(|(r, support)| {
                DMatrix::from_fn(support.len(), pool.k, |q, j| {
                    pool.x[(support[q], j * pool.b + r)]
                })
            })
            .collect();
        let start = RunningInverse::ridge_start(pool);
        let mut engine = Self {
            pool,
            supports,
            rows,
            blocks: Vec::new(),
            start,
        };
        engine.blocks = engine.diagonal_blocks(&engine.start.minv);
        Some(engine)
    }

    /// The diagonal blocks M_r⁻¹ of a (block-diagonal) dense M⁻¹.
    fn diagonal_blocks(&self, minv: &DMatrix<f64>) -> Vec<DMatrix<f64>> {
        self.supports
            .iter()
            .map(|support| minv.select_rows(support).select_columns(support))
            .collect()
    }

    /// d_r(j) of every candidate j under the blocks `blocks` (entry r·K + j), formed chunk by
    /// chunk.
    fn leverages(&self, blocks: &[DMatrix<f64>]) -> Vec<f64> {
        let k = self.pool.k;
        let mut d = vec![0.0; self.pool.b * k];
        for (r, (rows, minv)) in self.rows.iter().zip(blocks).enumerate() {
            for range in self.pool.chunks() {
                let x = rows.columns(range.start, range.len());
                let y = minv * x;
                column_dots(&x, &y, &mut d[r * k + range.start..]);
            }
        }
        d
    }

    /// The eligible candidate of largest gain Π_r (1 + d_r(j)) (ties: lowest index).
    fn best_gain(&self, d: &[f64], eligible: &[bool]) -> Option<usize> {
        let k = self.pool.k;
        argmax(
            (0..k)
                .filter(|&j| eligible[j])
                .map(|j| (j, (0..self.pool.b).map(|r| 1.0 + d[r * k + j]).product())),
        )
    }

    /// M_r⁻¹ ← (M_r ± x_rj x_rjᵀ)⁻¹ for every row position (Sherman–Morrison:
    /// M⁻¹ ∓ u uᵀ/(1 ± xᵀu) with u = M⁻¹x).
    fn update(&mut self, j: usize, change: Change) {
        for (minv, rows) in self.blocks.iter_mut().zip(&self.rows) {
            let x = rows.column(j);
            let u = &*minv * x;
            let denominator = 1.0 + change.signed(x.dot(&u));
            if denominator != 0.0 {
                minv.ger(-change.signed(1.0) / denominator, &u, &u, 1.0);
            }
        }
    }
}

impl Engine for SeparableD<'_> {
    fn name(&self) -> &'static str {
        "separable D"
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let d = self.leverages(&self.blocks);
        self.best_gain(&d, eligible)
            .ok_or_else(|| self.pool.exhausted(design.len()))
    }

    fn greedy_added(&mut self, design: &[usize], j: usize) {
        self.update(j, Change::Add);
        if self.start.refresh(self.pool, design) {
            self.blocks = self.diagonal_blocks(&self.start.minv);
        }
    }

    fn sweep_start(&mut self, minv: DMatrix<f64>) {
        self.blocks = self.diagonal_blocks(&minv);
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let (k, count) = (self.pool.k, step.design.len());
        let d = self.leverages(&self.blocks);
        // Per row position: (M_r⁻¹ x_ri)ᵀ of the design points, as rows (N × |S_r|).
        let u_t: Vec<DMatrix<f64>> = self
            .rows
            .iter()
            .zip(&self.blocks)
            .map(|(rows, minv)| (minv * rows.select_columns(step.design)).transpose())
            .collect();
        let mut best = BestSwap::above(1.0 + ACCEPT);
        for range in self.pool.chunks() {
            // Δ_ij = Π_r [(1 + d_r(j))(1 − d_r(i)) + d_r(i, j)²], N × chunk.
            let mut ratio = DMatrix::from_element(count, range.len(), 1.0);
            for (r, (rows, u_t)) in self.rows.iter().zip(&u_t).enumerate() {
                let x: DMatrixView<'_, f64> = rows.columns(range.start, range.len());
                let cross = u_t * x; // d_r(i, j), N × chunk
                let d = &d[r * k..(r + 1) * k];
                for (c, j) in range.clone().enumerate() {
                    let gain = 1.0 + d[j];
                    for (pos, &i) in step.design.iter().enumerate() {
                        let e = cross[(pos, c)];
                        ratio[(pos, c)] *= gain * (1.0 - d[i]) + e * e;
                    }
                }
            }
            for (rank, &pos) in step.order.iter().enumerate() {
                for (c, j) in range.clone().enumerate() {
                    if step.eligible[j] {
                        best.offer(ratio[(pos, c)], rank, (pos, j));
                    }
                }
            }
        }
        Ok(best.swap())
    }

    fn swapped(&mut self, design: &[usize], pos: usize, j: usize) {
        self.update(j, Change::Add);
        self.update(design[pos], Change::Remove);
    }

    fn best_addition(
        &mut self,
        (pool, criterion): (&Pool, Criterion),
        design: &[usize],
        eligible: &[bool],
    ) -> Option<usize> {
        // The engine of the D criterion only (`select_columns` hands it no other).
        debug_assert_eq!(criterion, Criterion::D);
        let blocks = self.diagonal_blocks(&spd_inverse(&pool.gram(design, false))?);
        self.best_gain(&self.leverages(&blocks), eligible)
    }
}
