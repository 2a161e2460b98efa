//! D criterion, one row per candidate: rank-one updates.

use nalgebra::{DMatrix, DVector};

use super::driver::Engine;
use super::gains::{argmax, d_addition, d_removal};
use super::linalg::spd_inverse;
use super::pool::Pool;
use super::{SelectionError, ACCEPT};

pub(super) struct RankOneD<'a> {
    pool: &'a Pool,
    /// M⁻¹ of the current design (with the ridge during the greedy phase).
    pub(super) minv: DMatrix<f64>,
    /// Greedy phase: cached d_j = c_jᵀM⁻¹c_j.
    d: DVector<f64>,
    /// Whether M⁻¹ and d were recomputed once the design reached n rows.
    refreshed: bool,
}

impl<'a> RankOneD<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        let inverse_ridge = pool.ridge.map(|v| 1.0 / v);
        let minv = DMatrix::from_diagonal(&inverse_ridge);
        let d = DVector::from_fn(pool.k, |j, _| {
            pool.x
                .column(j)
                .iter()
                .zip(inverse_ridge.iter())
                .map(|(c, w)| c * c * w)
                .sum()
        });
        Self {
            pool,
            minv,
            d,
            refreshed: false,
        }
    }

    /// M⁻¹ ← (M + ccᵀ)⁻¹ (Sherman–Morrison); returns M⁻¹c (before the update) and d(c).
    fn add(&mut self, j: usize) -> (DVector<f64>, f64) {
        let c = self.pool.x.column(j);
        let u = &self.minv * c;
        let d = c.dot(&u);
        self.minv.ger(-1.0 / (1.0 + d), &u, &u, 1.0);
        (u, d)
    }

    /// M⁻¹ ← (M − ccᵀ)⁻¹ (Sherman–Morrison).
    fn remove(&mut self, i: usize) {
        let c = self.pool.x.column(i);
        let v = &self.minv * c;
        let d = c.dot(&v);
        self.minv.ger(1.0 / (1.0 - d), &v, &v, 1.0);
    }
}

impl Engine for RankOneD<'_> {
    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        argmax(
            (0..self.pool.k)
                .filter(|&j| eligible[j])
                .map(|j| (j, self.d[j])),
        )
        .ok_or_else(|| self.pool.exhausted(design.len()))
    }

    fn greedy_added(&mut self, design: &[usize], j: usize) {
        let (u, d) = self.add(j);
        // d_l ← d_l − (c_lᵀM⁻¹c_j)² / (1 + d_j), O(K n)
        let w = self.pool.x.tr_mul(&u);
        let scale = 1.0 / (1.0 + d);
        self.d.zip_apply(&w, |dl, wl| *dl -= wl * wl * scale);
        if !self.refreshed && design.len() >= self.pool.n {
            // The ridge's large entries have cancelled: recompute M⁻¹ and d from scratch.
            self.refreshed = true;
            if let Some(minv) = spd_inverse(&self.pool.gram(design, true)) {
                let y = &minv * &self.pool.x;
                self.d = self.pool.x.component_mul(&y).row_sum().transpose();
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
        let x = &self.pool.x;
        let u = &self.minv * x;
        let d = x.component_mul(&u).row_sum();
        let mut u_design = DMatrix::zeros(self.pool.n, design.len());
        for (pos, &i) in design.iter().enumerate() {
            u_design.set_column(pos, &u.column(i));
        }
        let cross = u_design.transpose() * x; // d_ij, N × K
        let mut best = (1.0 + ACCEPT, None);
        for &pos in order {
            let di = d[design[pos]];
            for (j, &ok) in eligible.iter().enumerate() {
                if !ok {
                    continue;
                }
                let dij = cross[(pos, j)];
                let delta = (1.0 + d[j]) * (1.0 - di) + dij * dij;
                if delta > best.0 {
                    best = (delta, Some((pos, j)));
                }
            }
        }
        Ok(best.1)
    }

    fn swapped(&mut self, design: &[usize], pos: usize, j: usize) {
        self.add(j);
        self.remove(design[pos]);
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
