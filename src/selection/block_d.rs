//! D criterion, b > 1 rows per candidate: block determinant lemma and Woodbury updates.

use nalgebra::DMatrix;

use super::driver::Engine;
use super::gains::{d_addition, d_removal};
use super::linalg::{det_in_place, invert_in_place, spd_inverse};
use super::pool::Pool;
use super::{SelectionError, ACCEPT};

pub(super) struct BlockD<'a> {
    pool: &'a Pool,
    pub(super) minv: DMatrix<f64>,
    refreshed: bool,
}

impl<'a> BlockD<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        let minv = DMatrix::from_diagonal(&pool.ridge.map(|v| 1.0 / v));
        Self {
            pool,
            minv,
            refreshed: false,
        }
    }

    /// M⁻¹ ← (M + sign·C_jᵀC_j)⁻¹ by the Woodbury identity.
    fn update(&mut self, j: usize, sign: f64) {
        let b = self.pool.b;
        let block = self.pool.block(j);
        let p = &self.minv * block; // n × b
        let g = DMatrix::identity(b, b) * sign + block.tr_mul(&p);
        if let Some(g_inverse) = g.try_inverse() {
            self.minv -= &p * g_inverse * p.transpose();
        }
    }
}

impl Engine for BlockD<'_> {
    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let y = &self.minv * &self.pool.x;
        self.pool
            .best_block_gain(&y, eligible)
            .ok_or_else(|| self.pool.exhausted(design.len()))
    }

    fn greedy_added(&mut self, design: &[usize], j: usize) {
        self.update(j, 1.0);
        if !self.refreshed && design.len() * self.pool.b >= self.pool.n {
            self.refreshed = true;
            if let Some(minv) = spd_inverse(&self.pool.gram(design, true)) {
                self.minv = minv;
            }
        }
    }

    fn sweep_start(&mut self, design: &[usize]) -> Result<(), SelectionError> {
        self.minv = self.pool.exchange_inverse(design)?.0;
        Ok(())
    }

    fn best_swap(
        &mut self,
        design: &[usize],
        order: &[usize],
        eligible: &[bool],
    ) -> Result<Option<(usize, usize)>, SelectionError> {
        let (b, k) = (self.pool.b, self.pool.k);
        let bb = b * b;
        let x = &self.pool.x;
        let y = &self.minv * x; // n × K b
                                // Per candidate: D_j = C_j M⁻¹ C_jᵀ, det G_j and G_j⁻¹ with G_j = I + D_j (row-major).
        let mut d_blocks = vec![0.0; k * bb];
        let mut g_inverse = vec![0.0; k * bb];
        let mut g_det = vec![0.0; k];
        let mut g = vec![0.0; bb];
        for j in 0..k {
            self.pool
                .block_product(&y, j, &mut d_blocks[j * bb..(j + 1) * bb]);
            if !eligible[j] {
                continue;
            }
            g.copy_from_slice(&d_blocks[j * bb..(j + 1) * bb]);
            for r in 0..b {
                g[r * b + r] += 1.0;
            }
            g_det[j] = invert_in_place(&mut g, b, &mut g_inverse[j * bb..(j + 1) * bb]);
        }
        let mut y_design = DMatrix::zeros(self.pool.n, design.len() * b);
        for (pos, &i) in design.iter().enumerate() {
            y_design
                .columns_mut(pos * b, b)
                .copy_from(&y.columns(i * b, b));
        }
        let cross = y_design.transpose() * x; // D_ij blocks, N b × K b
        let mut e = vec![0.0; bb];
        let mut f = vec![0.0; bb];
        let mut t = vec![0.0; bb];
        let mut best = (1.0 + ACCEPT, None);
        for &pos in order {
            let di = &d_blocks[design[pos] * bb..(design[pos] + 1) * bb];
            if b == 2 {
                // The traditional two-leg design: the same formula with 2 × 2 blocks written out.
                let (d00, d01, d10, d11) = (di[0], di[1], di[2], di[3]);
                let (r0, r1) = (pos * 2, pos * 2 + 1);
                for j in (0..k).filter(|&j| eligible[j]) {
                    let gi = &g_inverse[j * 4..j * 4 + 4];
                    let (e00, e01) = (cross[(r0, 2 * j)], cross[(r0, 2 * j + 1)]);
                    let (e10, e11) = (cross[(r1, 2 * j)], cross[(r1, 2 * j + 1)]);
                    let (f00, f01) = (e00 * gi[0] + e01 * gi[2], e00 * gi[1] + e01 * gi[3]);
                    let (f10, f11) = (e10 * gi[0] + e11 * gi[2], e10 * gi[1] + e11 * gi[3]);
                    let t00 = 1.0 - d00 + f00 * e00 + f01 * e01;
                    let t01 = -d01 + f00 * e10 + f01 * e11;
                    let t10 = -d10 + f10 * e00 + f11 * e01;
                    let t11 = 1.0 - d11 + f10 * e10 + f11 * e11;
                    let delta = g_det[j] * (t00 * t11 - t01 * t10);
                    if delta > best.0 {
                        best = (delta, Some((pos, j)));
                    }
                }
                continue;
            }
            for j in (0..k).filter(|&j| eligible[j]) {
                // Δ = det(I + D_j) · det(I − D_i + D_ij (I + D_j)⁻¹ D_ijᵀ)
                let gi = &g_inverse[j * bb..(j + 1) * bb];
                for r in 0..b {
                    for s in 0..b {
                        e[r * b + s] = cross[(pos * b + r, j * b + s)];
                    }
                }
                for r in 0..b {
                    for s in 0..b {
                        f[r * b + s] = (0..b).map(|q| e[r * b + q] * gi[q * b + s]).sum();
                    }
                }
                for r in 0..b {
                    for s in 0..b {
                        let efe: f64 = (0..b).map(|q| f[r * b + q] * e[s * b + q]).sum();
                        let identity = if r == s { 1.0 } else { 0.0 };
                        t[r * b + s] = identity - di[r * b + s] + efe;
                    }
                }
                let delta = g_det[j] * det_in_place(&mut t, b);
                if delta > best.0 {
                    best = (delta, Some((pos, j)));
                }
            }
        }
        Ok(best.1)
    }

    fn swapped(&mut self, design: &[usize], pos: usize, j: usize) {
        self.update(j, 1.0);
        self.update(design[pos], -1.0);
    }

    fn best_addition(&mut self, design: &[usize], eligible: &[bool]) -> Option<usize> {
        d_addition(
            self.pool,
            &spd_inverse(&self.pool.gram(design, false))?,
            eligible,
        )
    }

    fn best_removal(&mut self, design: &[usize], order: &[usize]) -> Option<usize> {
        d_removal(
            self.pool,
            &spd_inverse(&self.pool.gram(design, false))?,
            design,
            order,
        )
    }
}
