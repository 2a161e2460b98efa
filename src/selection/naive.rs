//! Naive reference: every trial design evaluated from scratch.

use nalgebra::DMatrix;

use super::driver::Engine;
use super::gains::{accept_ln, argmax};
use super::linalg::{log_det_spd, spd_inverse};
use super::pool::Pool;
use super::{Criterion, SelectionError};
use crate::identify::observability::{indices, sorted_singular_values};

pub(super) struct Naive<'a> {
    pub(super) pool: &'a Pool,
    pub(super) criterion: Criterion,
    pub(super) ridge: bool,
}

impl Naive<'_> {
    /// The criterion (larger is better, log scale) of `design`, from scratch.
    fn score(&self, design: &[usize], ridge: bool, criterion: Criterion) -> f64 {
        let pool = self.pool;
        match criterion {
            Criterion::D => log_det_spd(&pool.gram(design, ridge)),
            Criterion::A => match spd_inverse(&pool.gram(design, ridge)) {
                Some(inverse) => -inverse.trace().ln(),
                None => f64::NEG_INFINITY,
            },
            Criterion::E => {
                // Stack the rows (and the ridge as pseudo-rows), then s_min = O3.
                let extra = if ridge { pool.n } else { 0 };
                let rows = design.len() * pool.b;
                let mut c = DMatrix::zeros(rows + extra, pool.n);
                c.rows_mut(0, rows)
                    .copy_from(&pool.design_columns(design).transpose());
                for p in 0..extra {
                    c[(rows + p, p)] = pool.ridge[p].sqrt();
                }
                let m = c.nrows();
                let s_min = indices(&sorted_singular_values(c), m, pool.n)[2];
                if s_min > 0.0 {
                    s_min.ln()
                } else {
                    f64::NEG_INFINITY
                }
            }
        }
    }
}

impl Engine for Naive<'_> {
    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let pool = self.pool;
        let criterion = match self.criterion {
            Criterion::E if (design.len() + 1) * pool.b < pool.n => Criterion::D,
            other => other,
        };
        let mut trial = design.to_vec();
        trial.push(0);
        let last = design.len();
        let mut scores = Vec::with_capacity(pool.k);
        for j in (0..pool.k).filter(|&j| eligible[j]) {
            trial[last] = j;
            scores.push((j, self.score(&trial, true, criterion)));
        }
        argmax(scores.into_iter()).ok_or_else(|| pool.exhausted(design.len()))
    }

    fn sweep_start(&mut self, design: &[usize]) -> Result<(), SelectionError> {
        self.ridge = self.pool.exchange_inverse(design)?.1;
        Ok(())
    }

    fn best_swap(
        &mut self,
        design: &[usize],
        order: &[usize],
        eligible: &[bool],
    ) -> Result<Option<(usize, usize)>, SelectionError> {
        let current = self.score(design, self.ridge, self.criterion);
        let mut best = (current + accept_ln(), None);
        let mut trial = design.to_vec();
        for &pos in order {
            for j in (0..self.pool.k).filter(|&j| eligible[j]) {
                trial[pos] = j;
                let score = self.score(&trial, self.ridge, self.criterion);
                if score > best.0 {
                    best = (score, Some((pos, j)));
                }
            }
            trial[pos] = design[pos];
        }
        Ok(best.1)
    }

    fn swapped(&mut self, _design: &[usize], _pos: usize, _j: usize) {}

    fn best_addition(&mut self, design: &[usize], eligible: &[bool]) -> Option<usize> {
        let mut trial = design.to_vec();
        trial.push(0);
        let last = design.len();
        let mut scores = Vec::with_capacity(self.pool.k);
        for j in (0..self.pool.k).filter(|&j| eligible[j]) {
            trial[last] = j;
            scores.push((j, self.score(&trial, false, self.criterion)));
        }
        argmax(scores.into_iter())
    }

    fn best_removal(&mut self, design: &[usize], order: &[usize]) -> Option<usize> {
        let scores: Vec<(usize, f64)> = order
            .iter()
            .map(|&pos| {
                let mut trial = design.to_vec();
                trial.remove(pos);
                (pos, self.score(&trial, false, self.criterion))
            })
            .collect();
        argmax(scores.into_iter())
    }
}
