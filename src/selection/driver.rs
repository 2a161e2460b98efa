//! The driver, shared by all evaluation strategies: greedy construction, Fedorov exchange
//! sweeps and DETMAX excursions over an [`Engine`].

use super::gains::{accept_ln, gram_value};
use super::linalg::{log_det_spd, spd_inverse};
use super::pool::Pool;
use super::{Selection, SelectionError, SelectionOptions, EXCURSION_LENGTH};

/// How trial designs are evaluated; the greedy/exchange skeleton is in [`run`].
pub(super) trait Engine {
    /// The eligible candidate whose addition to `design` is best (ties: lowest index).
    fn greedy_pick(&mut self, design: &[usize], eligible: &[bool])
        -> Result<usize, SelectionError>;
    /// Candidate `j` has just been appended to `design` (engines without cached state: nothing).
    fn greedy_added(&mut self, _design: &[usize], _j: usize) {}
    /// Start of an exchange sweep: refactorise the information matrix of `design`.
    fn sweep_start(&mut self, design: &[usize]) -> Result<(), SelectionError>;
    /// The best improving swap (position in `design`, incoming candidate), scanning positions
    /// in `order` (by candidate index) and candidates by increasing index; `None` if no swap
    /// improves the criterion by more than [`ACCEPT`](super::ACCEPT).
    fn best_swap(
        &mut self,
        design: &[usize],
        order: &[usize],
        eligible: &[bool],
    ) -> Result<Option<(usize, usize)>, SelectionError>;
    /// The swap (`pos`, `j`) is about to be applied to `design`.
    fn swapped(&mut self, design: &[usize], pos: usize, j: usize);
    /// DETMAX excursion step up: the eligible candidate whose addition to the (nonsingular)
    /// `design` is best (ties: lowest index).
    fn best_addition(&mut self, design: &[usize], eligible: &[bool]) -> Option<usize>;
    /// DETMAX excursion step down: the position in `design` whose removal is least harmful,
    /// scanning positions in `order` (by candidate index).
    fn best_removal(&mut self, design: &[usize], order: &[usize]) -> Option<usize>;
}

pub(super) fn run(
    pool: &Pool,
    options: &SelectionOptions,
    engine: &mut dyn Engine,
) -> Result<Selection, SelectionError> {
    let count = options.count;
    let mut design: Vec<usize> = Vec::with_capacity(count);
    let mut copies = vec![0usize; pool.k];
    let mut eligible = vec![true; pool.k];
    for _ in 0..count {
        let j = engine.greedy_pick(&design, &eligible)?;
        design.push(j);
        copies[j] += 1;
        eligible[j] = options.allow_replicates;
        engine.greedy_added(&design, j);
    }
    let mut counts = Counts::default();
    while counts.sweeps < options.max_sweeps {
        counts.sweeps += 1;
        engine.sweep_start(&design)?;
        let mut improved = false;
        for _ in 0..count {
            let Some((pos, j)) = engine.best_swap(&design, &order(&design), &eligible)? else {
                break;
            };
            engine.swapped(&design, pos, j);
            let i = design[pos];
            copies[i] -= 1;
            copies[j] += 1;
            eligible[i] = options.allow_replicates || copies[i] == 0;
            eligible[j] = options.allow_replicates;
            design[pos] = j;
            counts.exchanges += 1;
            improved = true;
        }
        if improved {
            continue;
        }
        // No single swap improves: try DETMAX excursions, then resume the exchange.
        match excursion(pool, options, engine, &design, &eligible) {
            Some(better) => {
                design = better;
                copies.fill(0);
                for &j in &design {
                    copies[j] += 1;
                }
                for (j, e) in eligible.iter_mut().enumerate() {
                    *e = options.allow_replicates || copies[j] == 0;
                }
                counts.excursions += 1;
            }
            None => break,
        }
    }
    finish(pool, design, counts)
}

/// Positions of `design` ordered by candidate index (the tie-breaking order).
pub(super) fn order(design: &[usize]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..design.len()).collect();
    order.sort_by_key(|&pos| (design[pos], pos));
    order
}

#[derive(Default)]
struct Counts {
    sweeps: usize,
    exchanges: usize,
    excursions: usize,
}

/// DETMAX excursions of length 2..=[`EXCURSION_LENGTH`]: add the best L candidates one by one,
/// then remove the L least useful points one by one. Returns the first excursion that improves
/// the criterion by more than [`ACCEPT`](super::ACCEPT) (an excursion of length 1 is a swap,
/// already tried).
fn excursion(
    pool: &Pool,
    options: &SelectionOptions,
    engine: &mut dyn Engine,
    design: &[usize],
    eligible: &[bool],
) -> Option<Vec<usize>> {
    let current = gram_value(&pool.gram(design, false), options.criterion);
    if !current.is_finite() {
        return None;
    }
    for length in 2..=EXCURSION_LENGTH.min(design.len()) {
        let mut trial = design.to_vec();
        let mut trial_eligible = eligible.to_vec();
        for _ in 0..length {
            let j = engine.best_addition(&trial, &trial_eligible)?;
            trial.push(j);
            trial_eligible[j] = options.allow_replicates;
        }
        for _ in 0..length {
            let pos = engine.best_removal(&trial, &order(&trial))?;
            let i = trial.remove(pos);
            trial_eligible[i] = options.allow_replicates || !trial.contains(&i);
        }
        if gram_value(&pool.gram(&trial, false), options.criterion) > current + accept_ln() {
            return Some(trial);
        }
    }
    None
}

fn finish(
    pool: &Pool,
    mut design: Vec<usize>,
    counts: Counts,
) -> Result<Selection, SelectionError> {
    let m = pool.gram(&design, false);
    let log_det = log_det_spd(&m);
    let minv = match spd_inverse(&m) {
        Some(minv) if log_det.is_finite() => minv,
        _ => return Err(pool.singular(&design)),
    };
    let y = &minv * &pool.x;
    let leverage = pool.x.component_mul(&y).row_sum();
    let largest = (0..pool.k)
        .map(|j| (0..pool.b).map(|r| leverage[j * pool.b + r]).sum::<f64>())
        .fold(f64::NEG_INFINITY, f64::max);
    design.sort_unstable();
    Ok(Selection {
        certificate: design.len() as f64 * largest,
        indices: design,
        sweeps: counts.sweeps,
        exchanges: counts.exchanges,
        excursions: counts.excursions,
        log_det,
    })
}
