//! D criterion, b > 1 rows per candidate: block determinant lemma and Woodbury updates.

use nalgebra::{DMatrix, DMatrixView};

use super::driver::{Engine, Step};
use super::gains::BestSwap;
use super::linalg::{det_in_place, invert_in_place};
use super::pool::Pool;
use super::running_inverse::{Change, RunningInverse};
use super::{SelectionError, ACCEPT};

pub(super) struct BlockD<'a> {
    pool: &'a Pool,
    /// M⁻¹ of the current design.
    pub(super) inverse: RunningInverse,
}

impl<'a> BlockD<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        Self {
            pool,
            inverse: RunningInverse::ridge_start(pool),
        }
    }

    /// M⁻¹ ← (M ± C_jᵀC_j)⁻¹ by the Woodbury identity: M⁻¹ − P (±I + C_j P)⁻¹ Pᵀ with
    /// P = M⁻¹C_jᵀ (±I is its own inverse).
    fn update(&mut self, j: usize, change: Change) {
        let b = self.pool.b;
        let block = self.pool.block(j);
        let p = &self.inverse.minv * block; // n × b
        let mut g = block.tr_mul(&p);
        for i in 0..b {
            g[(i, i)] += change.signed(1.0);
        }
        if let Some(g_inverse) = g.try_inverse() {
            self.inverse.minv -= &p * g_inverse * p.transpose();
        }
    }
}

impl Engine for BlockD<'_> {
    fn name(&self) -> &'static str {
        "block D"
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        self.pool
            .best_block_gain(&self.inverse.minv, eligible)
            .ok_or_else(|| self.pool.exhausted(design.len()))
    }

    fn greedy_added(&mut self, design: &[usize], j: usize) {
        self.update(j, Change::Add);
        self.inverse.refresh(self.pool, design);
    }

    fn sweep_start(&mut self, minv: DMatrix<f64>) {
        self.inverse.minv = minv;
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let pool = self.pool;
        let (b, bb) = (pool.b, pool.b * pool.b);
        // Pass 1, per candidate: D_j = C_j M⁻¹ C_jᵀ, det G_j and G_j⁻¹ with G_j = I + D_j
        // (row-major); and the design's columns of Y = M⁻¹X.
        let mut d_blocks = vec![0.0; pool.k * bb];
        let mut g_inverse = vec![0.0; pool.k * bb];
        let mut g_det = vec![0.0; pool.k];
        let mut g = vec![0.0; bb];
        let mut y_design = DMatrix::zeros(pool.n, step.design.len() * b);
        for range in pool.chunks() {
            let y = &self.inverse.minv * pool.columns(&range);
            for j in range.clone() {
                let dj = &mut d_blocks[j * bb..(j + 1) * bb];
                pool.block_product(&y, range.start, j, dj);
                if !step.eligible[j] {
                    continue;
                }
                g.copy_from_slice(dj);
                for r in 0..b {
                    g[r * b + r] += 1.0;
                }
                g_det[j] = invert_in_place(&mut g, b, &mut g_inverse[j * bb..(j + 1) * bb]);
            }
            for (pos, &i) in step.design.iter().enumerate() {
                if range.contains(&i) {
                    y_design
                        .columns_mut(pos * b, b)
                        .copy_from(&y.columns((i - range.start) * b, b));
                }
            }
        }
        // Pass 2: Δ = det(I + D_j) · det(I − D_i + D_ij (I + D_j)⁻¹ D_ijᵀ).
        let y_design_t = y_design.transpose();
        let mut scratch = vec![0.0; 3 * bb];
        let mut best = BestSwap::above(1.0 + ACCEPT);
        for range in pool.chunks() {
            let cross = &y_design_t * pool.columns(&range); // D_ij blocks, N b × chunk b
            for (rank, &pos) in step.order.iter().enumerate() {
                let i = step.design[pos];
                let di = &d_blocks[i * bb..(i + 1) * bb];
                for j in range.clone().filter(|&j| step.eligible[j]) {
                    let e = cross.view((pos * b, (j - range.start) * b), (b, b));
                    let gi = &g_inverse[j * bb..(j + 1) * bb];
                    let ratio = if b == 2 {
                        ratio_2x2(di, gi, &e)
                    } else {
                        ratio(di, gi, &e, &mut scratch)
                    };
                    best.offer(g_det[j] * ratio, rank, (pos, j));
                }
            }
        }
        Ok(best.swap())
    }

    fn swapped(&mut self, design: &[usize], pos: usize, j: usize) {
        self.update(j, Change::Add);
        self.update(design[pos], Change::Remove);
    }
}

/// det(I − D_i + E G⁻¹ Eᵀ) for 2 × 2 blocks written out (the traditional two-leg design):
/// `di` = D_i and `gi` = G⁻¹ row-major, `e` = D_ij.
pub(super) fn ratio_2x2(di: &[f64], gi: &[f64], e: &DMatrixView<'_, f64>) -> f64 {
    let (d00, d01, d10, d11) = (di[0], di[1], di[2], di[3]);
    let (e00, e01, e10, e11) = (e[(0, 0)], e[(0, 1)], e[(1, 0)], e[(1, 1)]);
    let (f00, f01) = (e00 * gi[0] + e01 * gi[2], e00 * gi[1] + e01 * gi[3]);
    let (f10, f11) = (e10 * gi[0] + e11 * gi[2], e10 * gi[1] + e11 * gi[3]);
    let t00 = 1.0 - d00 + f00 * e00 + f01 * e01;
    let t01 = -d01 + f00 * e10 + f01 * e11;
    let t10 = -d10 + f10 * e00 + f11 * e01;
    let t11 = 1.0 - d11 + f10 * e10 + f11 * e11;
    t00 * t11 - t01 * t10
}

/// det(I − D_i + E G⁻¹ Eᵀ) for b × b blocks: `di` = D_i and `gi` = G⁻¹ row-major, `e` = D_ij;
/// `scratch` holds 3 b² numbers.
pub(super) fn ratio(di: &[f64], gi: &[f64], e: &DMatrixView<'_, f64>, scratch: &mut [f64]) -> f64 {
    let b = e.nrows();
    let (e_rows, rest) = scratch.split_at_mut(b * b);
    let (f, t) = rest.split_at_mut(b * b);
    for r in 0..b {
        for s in 0..b {
            e_rows[r * b + s] = e[(r, s)];
        }
    }
    for r in 0..b {
        for s in 0..b {
            f[r * b + s] = (0..b).map(|q| e_rows[r * b + q] * gi[q * b + s]).sum();
        }
    }
    for r in 0..b {
        for s in 0..b {
            let efe: f64 = (0..b).map(|q| f[r * b + q] * e_rows[s * b + q]).sum();
            let identity = if r == s { 1.0 } else { 0.0 };
            t[r * b + s] = identity - di[r * b + s] + efe;
        }
    }
    det_in_place(t, b)
}
