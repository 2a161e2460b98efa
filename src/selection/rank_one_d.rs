//! D criterion, one row per candidate: rank-one updates.

use nalgebra::{DMatrix, DVector, RowDVector};

use super::driver::{Engine, Step};
use super::gains::BestSwap;
use super::pool::{argmax, column_dots, Pool};
use super::running_inverse::RunningInverse;
use super::{SelectionError, ACCEPT};

pub(super) struct RankOneD<'a> {
    pool: &'a Pool,
    /// M⁻¹ of the current design.
    pub(super) inverse: RunningInverse,
    /// Greedy phase: cached d_j = c_jᵀM⁻¹c_j.
    d: DVector<f64>,
    /// Exchange phase: the swaps whose Δ was evaluated, the others ruled out by the leverage
    /// bound (a count for tests of the pruning).
    pub(super) evaluated: usize,
    /// Exchange phase: the candidates whose cross products with the design were formed, the
    /// others ruled out against every design point at once (a count for the same tests).
    pub(super) hopeful: usize,
}

impl<'a> RankOneD<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        // d_j = Σ_p c_jp² / ridge_p, the leverages under the ridge start
        let d = DVector::from_fn(pool.k, |j, _| {
            pool.x
                .column(j)
                .iter()
                .zip(pool.ridge.iter())
                .map(|(c, r)| c * c * (1.0 / r))
                .sum()
        });
        Self {
            pool,
            inverse: RunningInverse::ridge_start(pool),
            d,
            evaluated: 0,
            hopeful: 0,
        }
    }

    /// M⁻¹ ← (M + ccᵀ)⁻¹ (Sherman–Morrison); returns M⁻¹c (before the update) and d(c).
    fn add(&mut self, j: usize) -> (DVector<f64>, f64) {
        let minv = &mut self.inverse.minv;
        let c = self.pool.x.column(j);
        let u = &*minv * c;
        let d = c.dot(&u);
        minv.ger(-1.0 / (1.0 + d), &u, &u, 1.0);
        (u, d)
    }

    /// The leverages d_j = c_jᵀM⁻¹c_j of all candidates and the design's u_i = M⁻¹c_i (as
    /// columns), formed chunk by chunk.
    fn leverages_and_design(&self, design: &[usize]) -> (RowDVector<f64>, DMatrix<f64>) {
        let pool = self.pool;
        let mut d = RowDVector::zeros(pool.k);
        let mut u_design = DMatrix::zeros(pool.n, design.len());
        for range in pool.chunks() {
            let x = pool.columns(&range);
            let u = &self.inverse.minv * x;
            column_dots(&x, &u, &mut d.as_mut_slice()[range.start..]);
            for (pos, &i) in design.iter().enumerate() {
                if range.contains(&i) {
                    u_design.set_column(pos, &u.column(i - range.start));
                }
            }
        }
        (d, u_design)
    }

    /// M⁻¹ ← (M − ccᵀ)⁻¹ (Sherman–Morrison).
    fn remove(&mut self, i: usize) {
        let minv = &mut self.inverse.minv;
        let c = self.pool.x.column(i);
        let v = &*minv * c;
        let d = c.dot(&v);
        minv.ger(1.0 / (1.0 - d), &v, &v, 1.0);
    }
}

/// Whether the swap bound 1 + d_j − d_i falls short of `target` by more than rounding could
/// explain (a relative slack of 1e-6).
pub(super) fn below(dj: f64, di: f64, target: f64) -> bool {
    1.0 + dj - di < target - 1e-6 * (1.0 + dj.abs() + di.abs())
}

impl Engine for RankOneD<'_> {
    fn name(&self) -> &'static str {
        "rank-one D"
    }

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
        if self.inverse.refresh(self.pool, design) {
            self.d = self.pool.row_leverages(&self.inverse.minv).transpose();
        }
    }

    fn sweep_start(&mut self, minv: DMatrix<f64>) {
        self.inverse.minv = minv;
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let pool = self.pool;
        let (d, u_design) = self.leverages_and_design(step.design);
        // Δ_ij = (1 + d_j)(1 − d_i) + d_ij² ≤ 1 + d_j − d_i since d_ij² ≤ d_i d_j (Cauchy–Schwarz
        // in M⁻¹): a candidate whose leverage is below every design point's cannot improve.
        // (Not with the ridge: M⁻¹ is then too ill-conditioned to trust the bound.)
        let prune = !step.ridge;
        let floor = step
            .design
            .iter()
            .map(|&i| d[i])
            .fold(f64::INFINITY, f64::min);
        let hopeful: Vec<usize> = (0..pool.k)
            .filter(|&j| step.eligible[j] && !(prune && below(d[j], floor, 1.0 + ACCEPT)))
            .collect();
        self.hopeful += hopeful.len();
        let u_design_t = u_design.transpose();
        let mut best = BestSwap::above(1.0 + ACCEPT);
        for chunk in pool.column_groups(&hopeful) {
            let cross = &u_design_t * pool.gather(chunk); // d_ij, N × chunk (b = 1: X's column j)
            for (rank, &pos) in step.order.iter().enumerate() {
                let di = d[step.design[pos]];
                for (c, &j) in chunk.iter().enumerate() {
                    if prune && below(d[j], di, best.value()) {
                        continue;
                    }
                    let dij = cross[(pos, c)];
                    self.evaluated += 1;
                    best.offer((1.0 + d[j]) * (1.0 - di) + dij * dij, rank, (pos, j));
                }
            }
        }
        Ok(best.swap())
    }

    fn swapped(&mut self, design: &[usize], pos: usize, j: usize) {
        self.add(j);
        self.remove(design[pos]);
    }
}
