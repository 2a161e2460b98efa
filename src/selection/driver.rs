//! The driver, shared by all evaluation strategies: greedy construction, Fedorov exchange
//! sweeps and DETMAX excursions over an [`Engine`], with a progress bar per phase on a
//! terminal and, when a phase promises to last longer than [`ANNOUNCED_AFTER`], a line saying
//! how long.

use std::collections::HashSet;
use std::time::{Duration, Instant};

use nalgebra::DMatrix;

use super::gains::{accept_ln, addition, gram_value, removal};
use super::linalg::{log_det_spd, spd_inverse};
use super::pool::Pool;
use super::{Criterion, Selection, SelectionError, SelectionOptions, EXCURSION_LENGTH};
use crate::progress::{duration_text, Progress};

/// A phase of the selection that promises to last longer than this says so, with its cost,
/// before going on (on a terminal, as the progress bars).
pub(super) const ANNOUNCED_AFTER: Duration = Duration::from_secs(5);

/// The time the first steps of a phase must take before their rate is trusted for the cost.
const SAMPLE_TIME: Duration = Duration::from_millis(500);

/// One step of an exchange sweep: the current design and what may enter it.
pub(super) struct Step<'s> {
    /// The current design (candidate indices; a swap names a position in it).
    pub(super) design: &'s [usize],
    /// Positions of `design` ordered by candidate index (the tie-breaking order).
    pub(super) order: &'s [usize],
    /// Which candidates may enter the design.
    pub(super) eligible: &'s [bool],
    /// Whether the design's information matrix was numerically singular at the start of the
    /// sweep, so that trial designs are evaluated with the ridge added.
    pub(super) ridge: bool,
}

/// How trial designs are evaluated; the greedy/exchange skeleton is in [`run`]. Engines that
/// keep no state between steps (A, E, the naive reference) use the default methods.
pub(super) trait Engine {
    /// The engine's name, as [`Selection::engine`] reports it.
    fn name(&self) -> &'static str;
    /// The eligible candidate whose addition to `design` is best (ties: lowest index).
    fn greedy_pick(&mut self, design: &[usize], eligible: &[bool])
        -> Result<usize, SelectionError>;
    /// Candidate `j` has just been appended to `design` (engines without cached state: nothing).
    fn greedy_added(&mut self, _design: &[usize], _j: usize) {}
    /// Start of an exchange sweep, with M⁻¹ of the design (of M plus the ridge if M is
    /// numerically singular); engines without cached state ignore it.
    fn sweep_start(&mut self, _minv: DMatrix<f64>) {}
    /// The best improving swap (position in the design, incoming candidate), scanning
    /// positions in `step.order` and candidates by increasing index; `None` if no swap
    /// improves the criterion by more than [`ACCEPT`](super::ACCEPT).
    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError>;
    /// The swap (`pos`, `j`) is about to be applied to `design` (engines without cached
    /// state: nothing).
    fn swapped(&mut self, _design: &[usize], _pos: usize, _j: usize) {}
    /// DETMAX excursion step up: the eligible candidate of `pool` whose addition to the
    /// (nonsingular) `design` is best by `criterion` (ties: lowest index).
    fn best_addition(
        &mut self,
        (pool, criterion): (&Pool, Criterion),
        design: &[usize],
        eligible: &[bool],
    ) -> Option<usize> {
        addition(pool, design, eligible, criterion)
    }
    /// DETMAX excursion step down: the position in `design` whose removal is least harmful by
    /// `criterion`, scanning positions in `order` (by candidate index).
    fn best_removal(
        &mut self,
        (pool, criterion): (&Pool, Criterion),
        design: &[usize],
        order: &[usize],
    ) -> Option<usize> {
        removal(pool, design, order, criterion)
    }
}

pub(super) fn run(
    pool: &Pool,
    options: &SelectionOptions,
    engine: &mut dyn Engine,
) -> Result<Selection, SelectionError> {
    let count = options.count;
    let label = format!(
        "selecting {count} of {} candidates ({})",
        pool.k,
        engine.name()
    );
    let mut design: Vec<usize> = Vec::with_capacity(count);
    let mut copies = vec![0usize; pool.k];
    let mut eligible = vec![true; pool.k];
    let mut greedy = Phase::new(format!("{label}: greedy"), count, "steps");
    for _ in 0..count {
        let j = engine.greedy_pick(&design, &eligible)?;
        design.push(j);
        copies[j] += 1;
        eligible[j] = options.allow_replicates;
        engine.greedy_added(&design, j);
        greedy.step();
    }
    drop(greedy);
    let mut counts = Counts::default();
    // Every design the exchange has been at: each step strictly improves the criterion, so a
    // design seen before can only come back by round-off (a swap and its undoing both
    // computed above the acceptance), and the exchange then stops where it is.
    let mut visited = HashSet::from([sorted(&design)]);
    while counts.sweeps < options.max_sweeps {
        counts.sweeps += 1;
        let (minv, ridge) = pool.exchange_inverse(&design)?;
        engine.sweep_start(minv);
        let mut improved = false;
        let mut sweep = Phase::new(
            format!("{label}: exchange sweep {}", counts.sweeps),
            count,
            "steps at most",
        );
        for _ in 0..count {
            let step = Step {
                design: &design,
                order: &order(&design),
                eligible: &eligible,
                ridge,
            };
            let Some((pos, j)) = engine.best_swap(&step)? else {
                break;
            };
            let mut next = design.clone();
            next[pos] = j;
            if !visited.insert(sorted(&next)) {
                break;
            }
            engine.swapped(&design, pos, j);
            let i = design[pos];
            copies[i] -= 1;
            copies[j] += 1;
            eligible[i] = options.allow_replicates || copies[i] == 0;
            eligible[j] = options.allow_replicates;
            design[pos] = j;
            counts.exchanges += 1;
            improved = true;
            sweep.step();
        }
        drop(sweep);
        if improved {
            continue;
        }
        // No single swap improves: try DETMAX excursions, then resume the exchange.
        match excursion(pool, options, engine, &design, &eligible) {
            Some(better) if visited.insert(sorted(&better)) => {
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
            _ => break,
        }
    }
    finish(pool, design, counts, engine.name())
}

/// The candidates of `design` in increasing order (a design as a set, for [`run`]'s record of
/// the designs visited).
fn sorted(design: &[usize]) -> Vec<usize> {
    let mut sorted = design.to_vec();
    sorted.sort_unstable();
    sorted
}

/// Positions of `design` ordered by candidate index (the tie-breaking order).
pub(super) fn order(design: &[usize]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..design.len()).collect();
    order.sort_by_key(|&pos| (design[pos], pos));
    order
}

/// A phase of at most `total` steps: its progress bar, and its cost said once when its
/// first steps promise more than [`ANNOUNCED_AFTER`] ([`cost_line`]).
struct Phase {
    progress: Progress,
    label: String,
    what: &'static str,
    total: usize,
    done: usize,
    started: Instant,
    said: bool,
}

impl Phase {
    fn new(label: String, total: usize, what: &'static str) -> Self {
        Self {
            progress: Progress::new(total as u64, &label),
            label,
            what,
            total,
            done: 0,
            started: Instant::now(),
            said: false,
        }
    }

    /// One step done.
    fn step(&mut self) {
        self.progress.advance(1);
        self.done += 1;
        let elapsed = self.started.elapsed();
        if !self.said && elapsed >= SAMPLE_TIME {
            self.said = true;
            if let Some(line) = cost_line(&self.label, (self.total, self.what), self.done, elapsed)
            {
                self.progress.say(&line);
            }
        }
    }
}

/// What a phase of `total` steps (called `what`) will cost, from its first `done` having
/// taken `elapsed`, when that is more than [`ANNOUNCED_AFTER`]: `selecting 100 of 15625
/// candidates (E): greedy: 100 steps will take about 1 min 40 s (1.0 s each, timed on the
/// first 3); Ctrl-C stops`.
pub(super) fn cost_line(
    label: &str,
    (total, what): (usize, &str),
    done: usize,
    elapsed: Duration,
) -> Option<String> {
    if done == 0 || done >= total {
        return None;
    }
    let each = elapsed.as_secs_f64() / done as f64;
    let whole = each * total as f64;
    (whole > ANNOUNCED_AFTER.as_secs_f64()).then(|| {
        format!(
            "{label}: {total} {what} will take about {} ({} each, timed on the first {done}); \
             Ctrl-C stops",
            duration_text(whole),
            duration_text(each)
        )
    })
}

#[derive(Default)]
struct Counts {
    sweeps: usize,
    exchanges: usize,
    excursions: usize,
}

/// DETMAX excursions of length 2..=[`EXCURSION_LENGTH`]: add the best L candidates one by one,
/// then remove the L least useful points one by one. Returns the first excursion that improves
/// the criterion by more than [`ACCEPT`](super::ACCEPT) (an excursion of length 1 is
/// a swap, already tried).
fn excursion(
    pool: &Pool,
    options: &SelectionOptions,
    engine: &mut dyn Engine,
    design: &[usize],
    eligible: &[bool],
) -> Option<Vec<usize>> {
    let criterion = options.criterion;
    let current = gram_value(&pool.gram(design, false), criterion);
    if !current.is_finite() {
        return None;
    }
    // The additions of an excursion of length L are the first L of the longest one (each
    // depends only on the ones before it): they are found once, as the excursions need them.
    let (mut grown, mut grown_eligible) = (design.to_vec(), eligible.to_vec());
    for length in 2..=EXCURSION_LENGTH.min(design.len()) {
        while grown.len() < design.len() + length {
            let j = engine.best_addition((pool, criterion), &grown, &grown_eligible)?;
            grown.push(j);
            grown_eligible[j] = options.allow_replicates;
        }
        let mut trial = grown.clone();
        for _ in 0..length {
            let pos = engine.best_removal((pool, criterion), &trial, &order(&trial))?;
            trial.remove(pos);
        }
        if gram_value(&pool.gram(&trial, false), criterion) > current + accept_ln() {
            return Some(trial);
        }
    }
    None
}

fn finish(
    pool: &Pool,
    mut design: Vec<usize>,
    counts: Counts,
    engine: &'static str,
) -> Result<Selection, SelectionError> {
    let m = pool.gram(&design, false);
    let log_det = log_det_spd(&m);
    // Both come from the same Jacobi-scaled Cholesky factorisation: where the inverse exists,
    // the log det is finite.
    let Some(minv) = spd_inverse(&m) else {
        return Err(pool.singular(&design));
    };
    let leverage = pool.row_leverages(&minv);
    let largest = (0..pool.k)
        .map(|j| (0..pool.b).map(|r| leverage[j * pool.b + r]).sum::<f64>())
        .fold(f64::NEG_INFINITY, f64::max);
    design.sort_unstable();
    Ok(Selection {
        engine,
        certificate: design.len() as f64 * largest,
        indices: design,
        sweeps: counts.sweeps,
        exchanges: counts.exchanges,
        excursions: counts.excursions,
        log_det,
    })
}
