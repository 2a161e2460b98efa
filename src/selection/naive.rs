//! Naive reference: every trial design evaluated from scratch.

use nalgebra::DMatrix;

use super::driver::{Engine, Step};
use super::gains::accept_ln;
use super::linalg::{log_det_spd, spd_inverse};
use super::pool::{argmax, Pool};
use super::{Criterion, SelectionError};
use crate::identify::observability::{indices, sorted_singular_values};

pub(super) struct Naive<'a> {
    pub(super) pool: &'a Pool,
    pub(super) criterion: Criterion,
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
                // A singular value is never negative: ln gives −∞ for a singular design.
                indices(&sorted_singular_values(c), m, pool.n)[2].ln()
            }
        }
    }
}

impl Naive<'_> {
    /// The eligible candidate whose addition to `design` scores best from scratch (ties:
    /// lowest index).
    fn best_extension(
        &self,
        design: &[usize],
        eligible: &[bool],
        ridge: bool,
        criterion: Criterion,
    ) -> Option<usize> {
        let mut trial = design.to_vec();
        trial.push(0);
        let last = design.len();
        let mut scores = Vec::with_capacity(self.pool.k);
        for j in (0..self.pool.k).filter(|&j| eligible[j]) {
            trial[last] = j;
            scores.push((j, self.score(&trial, ridge, criterion)));
        }
        argmax(scores.into_iter())
    }
}

impl Engine for Naive<'_> {
    fn name(&self) -> &'static str {
        "naive"
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        let criterion = match self.criterion {
            // A singular trial design: s_min is zero and tr M⁻¹ the ridge's, D's gain instead.
            Criterion::E | Criterion::A if (design.len() + 1) * self.pool.b < self.pool.n => {
                Criterion::D
            }
            other => other,
        };
        self.best_extension(design, eligible, true, criterion)
            .ok_or_else(|| self.pool.exhausted(design.len()))
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        let design = step.design;
        let current = self.score(design, step.ridge, self.criterion);
        let mut best = (current + accept_ln(), None);
        let mut trial = design.to_vec();
        for &pos in step.order {
            for j in (0..self.pool.k).filter(|&j| step.eligible[j]) {
                trial[pos] = j;
                let score = self.score(&trial, step.ridge, self.criterion);
                if score > best.0 {
                    best = (score, Some((pos, j)));
                }
            }
            trial[pos] = design[pos];
        }
        Ok(best.1)
    }

    fn best_addition(
        &mut self,
        _: (&Pool, Criterion),
        design: &[usize],
        eligible: &[bool],
    ) -> Option<usize> {
        self.best_extension(design, eligible, false, self.criterion)
    }

    fn best_removal(
        &mut self,
        _: (&Pool, Criterion),
        design: &[usize],
        order: &[usize],
    ) -> Option<usize> {
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
