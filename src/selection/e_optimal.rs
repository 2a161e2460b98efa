//! E criterion (maximise s_min = √λ_min(M)): the eigenvalues of a trial M are computed only
//! for the trials that an upper bound from the eigenvectors of the common part does not rule
//! out, scanned from the largest bound down.
//!
//! Every trial information matrix of a scan is A + C_jC_jᵀ for one symmetric A (the greedy
//! design's M, the design's M, or M less a design point) and the n × b block C_j of a
//! candidate. With A = V Λ Vᵀ (λ₁ ≤ λ₂ ≤ …), Rayleigh–Ritz on the span of v₁, v₂ gives
//! λ_min(A + CCᵀ) ≤ λ_min(Λ₂ + WWᵀ), W = [v₁ v₂]ᵀC (a 2 × 2 eigenvalue in closed form), and
//! a rank-b update moves at most b eigenvalues up, so λ_min(A + CCᵀ) ≤ λ_{b+1}(A). A swap
//! also removes a design point, which lowers every eigenvalue: the bound of A = M holds for
//! the swaps of every position. A trial whose bound (plus the rounding slack of
//! [`Bounds::slack`]) is below the value to beat cannot win; the scan stops at the first such
//! bound. The trials that are evaluated are evaluated as before (the eigenvalues of the trial
//! M), so the choice is the one of evaluating every trial (ties: lowest index).

use nalgebra::DMatrix;

use super::driver::{Engine, Step};
use super::gains::{accept_ln, BestSwap};
use super::linalg::{half_ln, min_eigenvalue, spd_inverse};
use super::pool::Pool;
use super::{Criterion, SelectionError};

pub(super) struct EOptimal<'a> {
    pool: &'a Pool,
    /// |C_j|² (squared Frobenius norm) of every candidate: the size of its trials' rounding.
    sizes: Vec<f64>,
    /// The largest of `sizes`.
    largest: f64,
    /// Trial designs of the scans (greedy steps, swaps and excursion additions): every
    /// eligible candidate of a greedy step or an addition, every (position, candidate) of a
    /// swap scan.
    pub(super) trials: usize,
    /// The trial designs whose s_min the engine computed: those the bounds did not rule out.
    pub(super) evaluated: usize,
}

impl<'a> EOptimal<'a> {
    pub(super) fn new(pool: &'a Pool) -> Self {
        let sizes: Vec<f64> = (0..pool.k).map(|j| pool.block(j).norm_squared()).collect();
        let largest = sizes.iter().copied().fold(0.0, f64::max);
        EOptimal {
            pool,
            sizes,
            largest,
            trials: 0,
            evaluated: 0,
        }
    }

    /// The candidates `among` whose upper bound on λ_min(A + C_jC_jᵀ) does not rule them out
    /// against `value` (½ ln λ), with their bounds, largest bound first (ties: lowest index).
    fn ranked(&self, bounds: &Bounds, among: &[usize], value: f64) -> Vec<(f64, usize)> {
        let mut ranked = Vec::new();
        for &j in among {
            let bound = bounds.of(self.pool, j);
            if !ruled_out(bound, bounds.slack(self.sizes[j]), value) {
                ranked.push((bound, j));
            }
        }
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        ranked
    }

    /// The eligible candidate j whose trial `base` + C_jC_jᵀ has the largest ½ ln λ_min
    /// (ties: lowest index; the first eligible one if every trial is singular).
    fn best_trial(&mut self, base: &DMatrix<f64>, eligible: &[bool]) -> Option<usize> {
        let pool = self.pool;
        let bounds = Bounds::new(base, pool.b);
        let among: Vec<usize> = (0..pool.k).filter(|&j| eligible[j]).collect();
        self.trials += among.len();
        let mut best: Option<(usize, f64)> = None;
        for (bound, j) in self.ranked(&bounds, &among, f64::NEG_INFINITY) {
            let slack = bounds.slack(self.sizes[j]);
            if best.is_some_and(|(_, value)| ruled_out(bound, slack, value)) {
                break;
            }
            self.evaluated += 1;
            let block = pool.block(j);
            let value = half_ln(min_eigenvalue(base + block * block.transpose()));
            if best.is_none_or(|(k, b)| value > b || value >= b && j < k) {
                best = Some((j, value));
            }
        }
        best.map(|(j, _)| j)
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
        let mut best = BestSwap::above(current + accept_ln());
        // Rayleigh–Ritz on M's v₁, v₂ bounds every swap (i, j) from two numbers a candidate:
        // λ_min(M − C_iC_iᵀ + C_jC_jᵀ) ≤ λ_min(Λ₂ − W_iW_iᵀ + W_jW_jᵀ). A swap this rules out
        // costs O(1); the others are bounded again on the position's own eigenvectors.
        let whole = Bounds::new(&m, pool.b);
        let eligible: Vec<usize> = (0..pool.k).filter(|&j| step.eligible[j]).collect();
        let projected: Vec<[f64; 3]> = (0..pool.k)
            .map(|j| {
                if step.eligible[j] || design.contains(&j) {
                    whole.projected(pool, j)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        // Each position's bounds first; the positions of largest λ_{b+1} scanned first, so
        // that a good swap is found early and rules out more (the order of the scan does not
        // change the swap chosen: ties go by the tie-breaking order's rank, then index).
        let mut positions: Vec<(usize, DMatrix<f64>, Bounds)> = step
            .order
            .iter()
            .enumerate()
            .map(|(rank, &pos)| {
                let removed = pool.block(design[pos]);
                let reduced = &m - removed * removed.transpose();
                let bounds = Bounds::new(&reduced, pool.b);
                (rank, reduced, bounds)
            })
            .collect();
        positions.sort_by(|p, q| q.2.cap.total_cmp(&p.2.cap).then(p.0.cmp(&q.0)));
        self.trials += positions.len() * eligible.len();
        for (rank, reduced, bounds) in &positions {
            let pos = step.order[*rank];
            if ruled_out(bounds.cap, bounds.slack(self.largest), best.value()) {
                continue;
            }
            let removed = projected[design[pos]];
            let among: Vec<usize> = eligible
                .iter()
                .copied()
                .filter(|&j| {
                    let bound = whole.ritz(projected[j], removed);
                    !ruled_out(bound, whole.slack(self.sizes[j]), best.value())
                })
                .collect();
            for (bound, j) in self.ranked(bounds, &among, best.value()) {
                if ruled_out(bound, bounds.slack(self.sizes[j]), best.value()) {
                    break;
                }
                self.evaluated += 1;
                let block = pool.block(j);
                let score = half_ln(min_eigenvalue(reduced + block * block.transpose()));
                best.offer(score, *rank, (pos, j));
            }
        }
        Ok(best.swap())
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
            self.best_trial(&m, eligible)
        };
        picked.ok_or_else(|| pool.exhausted(design.len()))
    }

    fn best_addition(
        &mut self,
        _: (&Pool, Criterion),
        design: &[usize],
        eligible: &[bool],
    ) -> Option<usize> {
        let m = self.pool.gram(design, false);
        self.best_trial(&m, eligible)
    }
}

/// Whether a trial whose λ_min is at most `bound` (up to `slack`) scores below `value`
/// (½ ln λ) by more than rounding: then it cannot win, nor tie. Nothing is ruled out by a
/// value of −∞, where every trial could tie.
fn ruled_out(bound: f64, slack: f64, value: f64) -> bool {
    let to_beat = (2.0 * value).exp();
    value > f64::NEG_INFINITY && bound + slack < to_beat * (1.0 - 1e-9)
}

/// Upper bounds on λ_min(A + CCᵀ) over the candidate blocks C of one scan, from the two
/// smallest eigenpairs of A and its (b+1)-th smallest eigenvalue.
pub(super) struct Bounds {
    /// λ₁, λ₂ of A (λ₂ = +∞ when n = 1).
    lambda: [f64; 2],
    /// v₁ and v₂ (zero when n = 1).
    v: [Vec<f64>; 2],
    /// λ_{b+1}(A), or +∞ when b ≥ n.
    pub(super) cap: f64,
    /// The largest |λ| of A: the scale of the rounding errors of the trial eigenvalues.
    scale: f64,
}

impl Bounds {
    pub(super) fn new(a: &DMatrix<f64>, b: usize) -> Self {
        let n = a.nrows();
        let eigen = a.clone().symmetric_eigen();
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&p, &q| eigen.eigenvalues[p].total_cmp(&eigen.eigenvalues[q]));
        let value = |k: usize| {
            order
                .get(k)
                .map_or(f64::INFINITY, |&p| eigen.eigenvalues[p])
        };
        let vector = |k: usize| {
            order.get(k).map_or(vec![0.0; n], |&p| {
                eigen.eigenvectors.column(p).iter().copied().collect()
            })
        };
        Self {
            lambda: [value(0), value(1)],
            v: [vector(0), vector(1)],
            cap: value(b),
            scale: eigen.eigenvalues.amax(),
        }
    }

    /// min(λ_{b+1}(A), λ_min([v₁ v₂]ᵀ(A + CCᵀ)[v₁ v₂])) for the block C of candidate `j`.
    pub(super) fn of(&self, pool: &Pool, j: usize) -> f64 {
        self.ritz(self.projected(pool, j), [0.0; 3]).min(self.cap)
    }

    /// WWᵀ of candidate j's block C, W = [v₁ v₂]ᵀC: its entries (1, 1), (1, 2), (2, 2).
    pub(super) fn projected(&self, pool: &Pool, j: usize) -> [f64; 3] {
        let n = pool.n;
        let block = &pool.x.as_slice()[j * pool.b * n..(j + 1) * pool.b * n];
        let mut q = [0.0; 3];
        for row in block.chunks_exact(n) {
            let w1 = dot(&self.v[0], row);
            let w2 = dot(&self.v[1], row);
            q[0] += w1 * w1;
            q[1] += w1 * w2;
            q[2] += w2 * w2;
        }
        q
    }

    /// λ_min([v₁ v₂]ᵀ(A + C_jC_jᵀ − C_iC_iᵀ)[v₁ v₂]) from the candidates' [`Self::projected`]
    /// `add` (j) and `remove` (i): an upper bound on λ_min(A − C_iC_iᵀ + C_jC_jᵀ).
    pub(super) fn ritz(&self, add: [f64; 3], remove: [f64; 3]) -> f64 {
        let a = self.lambda[0] + add[0] - remove[0];
        if !self.lambda[1].is_finite() {
            return a;
        }
        let d = self.lambda[1] + add[2] - remove[2];
        let off = add[1] - remove[1];
        // The smaller eigenvalue of [[a, off], [off, d]].
        0.5 * (a + d) - (0.5 * (a - d)).hypot(off)
    }

    /// How far a computed trial λ_min may exceed the computed bound by rounding, for a block
    /// of squared Frobenius norm `size`: a generous multiple of n·ε times the size of the
    /// trial matrix (the eigenvalues of a symmetric matrix are computed to about n·ε times
    /// its norm, the eigenvectors orthonormal to about n·ε).
    pub(super) fn slack(&self, size: f64) -> f64 {
        let n = self.v[0].len() as f64;
        1e3 * n * f64::EPSILON * (self.scale + size)
    }
}

/// The dot product of two slices of the same length.
fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}
