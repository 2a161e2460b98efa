//! A criterion (minimise tr M⁻¹): Woodbury trial traces, M⁻¹ recomputed every step; while
//! the design is singular, the D gain and then trial traces from scratch.

use nalgebra::DMatrix;

use super::driver::{Engine, Step};
use super::gains::accept_ln;
use super::linalg::{ln_det_small, spd_inverse};
use super::pool::{argmax, Pool};
use super::SelectionError;

pub(super) struct AOptimal<'a> {
    pub(super) pool: &'a Pool,
}

impl Engine for AOptimal<'_> {
    fn name(&self) -> &'static str {
        "A"
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let (pool, b) = (self.pool, self.pool.b);
        let m = pool.gram(design, true);
        let minv = spd_inverse(&m).ok_or_else(|| pool.singular(design))?;
        let rows = design.len() * b;
        let picked = if rows + b < pool.n {
            // The trial design is singular: its tr M⁻¹ is the ridge's, all round-off. The D
            // gain instead, as for E.
            pool.best_block_gain(&minv, eligible)
        } else if rows < pool.n {
            // The trial may have full rank but M is the ridge's: tr M⁻¹ − (its reduction)
            // would cancel to round-off. Each trial's trace from its own inverse.
            let score = |j: usize| {
                let block = pool.block(j);
                spd_inverse(&(&m + block * block.transpose()))
                    .map_or(f64::NEG_INFINITY, |inverse| -inverse.trace().ln())
            };
            argmax((0..pool.k).filter(|&j| eligible[j]).map(|j| (j, score(j))))
        } else {
            // tr (M + CᵀC)⁻¹ = tr M⁻¹ − tr(G⁻¹ PᵀP), P = M⁻¹Cᵀ, G = I + C P: the largest
            // reduction gives the smallest trace.
            let y = &minv * &pool.x;
            let reduction = |j: usize| {
                let p = y.columns(j * b, b);
                let g = DMatrix::identity(b, b) + pool.block(j).tr_mul(&p);
                g.try_inverse().map_or(f64::NEG_INFINITY, |g_inverse| {
                    (g_inverse * p.tr_mul(&p)).trace()
                })
            };
            argmax(
                (0..pool.k)
                    .filter(|&j| eligible[j])
                    .map(|j| (j, reduction(j))),
            )
        };
        picked.ok_or_else(|| pool.exhausted(design.len()))
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let (pool, design, eligible) = (self.pool, step.design, step.eligible);
        let b = pool.b;
        let minv =
            spd_inverse(&pool.gram(design, step.ridge)).ok_or_else(|| pool.singular(design))?;
        let current = -minv.trace().ln();
        let y = &minv * &pool.x;
        let x_design = pool.design_columns(design);
        let mut scores = DMatrix::from_element(design.len(), pool.k, f64::NEG_INFINITY);
        for j in (0..pool.k).filter(|&j| eligible[j]) {
            let p = y.columns(j * b, b).into_owned();
            let g = DMatrix::identity(b, b) + pool.block(j).tr_mul(&p);
            let Some(g_inverse) = g.try_inverse() else {
                continue;
            };
            let minv_j = &minv - &p * g_inverse * p.transpose();
            let trace_j = minv_j.trace();
            let q_all = &minv_j * &x_design;
            for pos in 0..design.len() {
                // removing C_i: tr (M_j − C_iᵀC_i)⁻¹ = tr M_j⁻¹ + tr(H⁻¹ QᵀQ), H = I − C_i Q
                let q = q_all.columns(pos * b, b);
                let h = DMatrix::identity(b, b) - x_design.columns(pos * b, b).tr_mul(&q);
                if !ln_det_small(&h).is_finite() {
                    continue;
                }
                let Some(h_inverse) = h.try_inverse() else {
                    continue;
                };
                let after = trace_j + (h_inverse * q.tr_mul(&q)).trace();
                if after > 0.0 {
                    scores[(pos, j)] = -after.ln();
                }
            }
        }
        let mut best = (current + accept_ln(), None);
        for &pos in step.order {
            for j in 0..pool.k {
                if scores[(pos, j)] > best.0 {
                    best = (scores[(pos, j)], Some((pos, j)));
                }
            }
        }
        Ok(best.1)
    }
}
