//! Criterion values and the gains of adding or removing a candidate, shared by the engines.

use nalgebra::DMatrix;

use super::linalg::{half_ln, ln_det_small, log_det_spd, min_eigenvalue, spd_inverse};
use super::pool::{argmax, Pool};
use super::{Criterion, ACCEPT};

/// The criterion (larger is better, log scale) of the information matrix `m`: ln det M (D),
/// −ln tr M⁻¹ (A), ln s_min = ½ ln λ_min(M) (E); −∞ when M is singular.
pub(super) fn gram_value(m: &DMatrix<f64>, criterion: Criterion) -> f64 {
    match criterion {
        Criterion::D => log_det_spd(m),
        Criterion::A => spd_inverse(m).map_or(f64::NEG_INFINITY, |inverse| -inverse.trace().ln()),
        Criterion::E => half_ln(min_eigenvalue(m.clone())),
    }
}

/// The DETMAX step up shared by the fast engines: the eligible candidate whose addition to the
/// nonsingular `design` is best by `criterion` (D: the gain from M⁻¹; A, E: each trial
/// information matrix re-evaluated).
pub(super) fn addition(
    pool: &Pool,
    design: &[usize],
    eligible: &[bool],
    criterion: Criterion,
) -> Option<usize> {
    match criterion {
        Criterion::D => d_addition(pool, &spd_inverse(&pool.gram(design, false))?, eligible),
        other => gram_addition(pool, design, eligible, other),
    }
}

/// The DETMAX step down shared by the fast engines: the position in `design` whose removal
/// keeps `criterion` best (D: from M⁻¹; A, E: each trial information matrix re-evaluated).
pub(super) fn removal(
    pool: &Pool,
    design: &[usize],
    order: &[usize],
    criterion: Criterion,
) -> Option<usize> {
    match criterion {
        Criterion::D => d_removal(
            pool,
            &spd_inverse(&pool.gram(design, false))?,
            design,
            order,
        ),
        other => gram_removal(pool, design, order, other),
    }
}

/// D gains of adding each eligible candidate: ln det(I_b + C_j M⁻¹ C_jᵀ) (ln(1 + d_j) for b = 1).
fn d_addition(pool: &Pool, minv: &DMatrix<f64>, eligible: &[bool]) -> Option<usize> {
    if pool.b == 1 {
        let d = pool.row_leverages(minv);
        argmax((0..pool.k).filter(|&j| eligible[j]).map(|j| (j, d[j])))
    } else {
        pool.best_block_gain(minv, eligible)
    }
}

/// The position whose removal keeps det M largest: max ln det(I_b − C_i M⁻¹ C_iᵀ).
fn d_removal(pool: &Pool, minv: &DMatrix<f64>, design: &[usize], order: &[usize]) -> Option<usize> {
    let b = pool.b;
    argmax(order.iter().map(|&pos| {
        let block = pool.block(design[pos]);
        let h = DMatrix::identity(b, b) - block.tr_mul(&(minv * block));
        (pos, ln_det_small(&h))
    }))
}

/// Best addition by re-evaluating the criterion of each trial information matrix.
fn gram_addition(
    pool: &Pool,
    design: &[usize],
    eligible: &[bool],
    criterion: Criterion,
) -> Option<usize> {
    let m = pool.gram(design, false);
    argmax((0..pool.k).filter(|&j| eligible[j]).map(|j| {
        let block = pool.block(j);
        (j, gram_value(&(&m + block * block.transpose()), criterion))
    }))
}

/// Best removal by re-evaluating the criterion of each trial information matrix.
fn gram_removal(
    pool: &Pool,
    design: &[usize],
    order: &[usize],
    criterion: Criterion,
) -> Option<usize> {
    let m = pool.gram(design, false);
    argmax(order.iter().map(|&pos| {
        let block = pool.block(design[pos]);
        (
            pos,
            gram_value(&(&m - block * block.transpose()), criterion),
        )
    }))
}

/// The best swap of a scan split into chunks of candidates: the largest value above a
/// threshold, ties going to the first in the order of the unsplit scan (position rank in the
/// tie-breaking order, then candidate index); NaN never wins.
pub(super) struct BestSwap {
    value: f64,
    key: Option<(usize, usize)>,
    swap: Option<(usize, usize)>,
}

impl BestSwap {
    /// No swap yet; a swap must exceed `threshold`.
    pub(super) fn above(threshold: f64) -> Self {
        Self {
            value: threshold,
            key: None,
            swap: None,
        }
    }

    /// Offers the swap `(pos, j)` of criterion ratio `value`, `pos` being of rank `rank` in
    /// the tie-breaking order.
    pub(super) fn offer(&mut self, value: f64, rank: usize, swap: (usize, usize)) {
        let key = (rank, swap.1);
        let earlier_tie = value >= self.value && self.key.is_some_and(|best| key < best);
        if value > self.value || earlier_tie {
            self.value = value;
            self.key = Some(key);
            self.swap = Some(swap);
        }
    }

    /// The value to beat: the best ratio offered so far, or the threshold.
    pub(super) fn value(&self) -> f64 {
        self.value
    }

    /// The best swap offered, if any exceeded the threshold.
    pub(super) fn swap(&self) -> Option<(usize, usize)> {
        self.swap
    }
}

/// ln(1 + ACCEPT): the improvement of a log-scale criterion a swap must exceed.
pub(super) fn accept_ln() -> f64 {
    ACCEPT.ln_1p()
}
