//! E criterion (maximise s_min): eigenvalues of the trial M, pruned by a Rayleigh bound.

use super::driver::{Engine, Step};
use super::gains::accept_ln;
use super::linalg::{half_ln, min_eigenvalue, spd_inverse};
use super::pool::{argmax, Pool};
use super::SelectionError;

pub(super) struct EOptimal<'a> {
    pool: &'a Pool,
    /// Trial designs whose s_min `best_swap` computed: the swaps the Rayleigh bound did not
    /// rule out.
    pub(super) evaluated: usize,
}

impl<'a> EOptimal<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        EOptimal { pool, evaluated: 0 }
    }
}

impl Engine for EOptimal<'_> {
    fn name(&self) -> &'static str {
        "E"
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let (pool, design) = (self.pool, step.design);
        let m = pool.gram(design, step.ridge);
        let current = half_ln(min_eigenvalue(m.clone()));
        let mut best = (current + accept_ln(), None);
        for &pos in step.order {
            let removed = pool.block(design[pos]);
            let reduced = &m - removed * removed.transpose();
            let eigen = reduced.clone().symmetric_eigen();
            let (first, lambda) = eigen.eigenvalues.iter().copied().enumerate().fold(
                (0, f64::INFINITY),
                |acc, (k, v)| if v < acc.1 { (k, v) } else { acc },
            );
            let v = eigen.eigenvectors.column(first);
            for j in (0..pool.k).filter(|&j| step.eligible[j]) {
                let block = pool.block(j);
                // λ_min(A + CᵀC) ≤ v₁ᵀ(A + CᵀC)v₁ = λ₁(A) + |C v₁|²: skip hopeless swaps
                let bound = lambda + block.tr_mul(&v).norm_squared();
                if half_ln(bound) + 1e-9 <= best.0 {
                    continue;
                }
                self.evaluated += 1;
                let score = half_ln(min_eigenvalue(&reduced + block * block.transpose()));
                if score > best.0 {
                    best = (score, Some((pos, j)));
                }
            }
        }
        Ok(best.1)
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let pool = self.pool;
        let m = pool.gram(design, true);
        let picked = if (design.len() + 1) * pool.b < pool.n {
            // s_min of the trial design is still zero: use the D gain.
            let minv = spd_inverse(&m).ok_or_else(|| pool.singular(design))?;
            pool.best_block_gain(&minv, eligible)
        } else {
            let score = |j: usize| {
                let block = pool.block(j);
                half_ln(min_eigenvalue(&m + block * block.transpose()))
            };
            argmax((0..pool.k).filter(|&j| eligible[j]).map(|j| (j, score(j))))
        };
        picked.ok_or_else(|| pool.exhausted(design.len()))
    }
}
