//! The fast engines (rank-one, block, A, E) against the from-scratch reference.

use std::time::Duration;

use super::*;
use crate::selection::driver::{cost_line, order, run, Engine, Step};
use crate::selection::e_optimal::Bounds;
use crate::selection::linalg::{min_eigenvalue, spd_inverse};
use crate::selection::pool::CHUNK;
use crate::selection::{BlockD, EOptimal, Naive, Pool, RankOneD};

#[test]
fn rank_one_updates_give_the_naive_selection() {
    let mut exchanges = 0;
    for seed in 0..6 {
        let pool = random_pool(seed, 120, 1, 6);
        exchanges += assert_matches_naive(&pool, &options(12));
        exchanges += assert_matches_naive(&pool, &options(6));
        exchanges += assert_matches_naive(&skewed_pool(seed, 120, 1, 6), &options(15));
    }
    assert!(exchanges > 0, "the exchange phase was never exercised");
}

#[test]
fn block_updates_give_the_naive_selection() {
    let mut exchanges = 0;
    for seed in 0..4 {
        exchanges += assert_matches_naive(&block_diagonal_pool(seed, 60, 2, 4), &options(8));
        exchanges += assert_matches_naive(&random_pool(100 + seed, 60, 2, 5), &options(6));
        exchanges += assert_matches_naive(&random_pool(200 + seed, 40, 3, 7), &options(4));
        exchanges += assert_matches_naive(&skewed_pool(250 + seed, 60, 2, 8), &options(10));
    }
    assert!(exchanges > 0, "the exchange phase was never exercised");
}

/// Runs one exchange sweep from the poor start "the first `count` candidates" with `fast`
/// and with the from-scratch evaluation; both must choose the same swaps, and the updated
/// M⁻¹ must equal (C_SᵀC_S)⁻¹ recomputed from scratch.
pub(super) fn follow_sweep<E: Engine>(
    pool: &Pool,
    count: usize,
    fast: &mut E,
    minv: impl Fn(&E) -> DMatrix<f64>,
) {
    let mut naive = Naive {
        pool,
        criterion: Criterion::D,
    };
    let mut design: Vec<usize> = (0..count).collect();
    let mut eligible: Vec<bool> = (0..pool.k).map(|j| j >= count).collect();
    let (start, ridge) = pool.exchange_inverse(&design).unwrap();
    fast.sweep_start(start);
    let mut swaps = 0;
    for _ in 0..count {
        let step = Step {
            design: &design,
            order: &order(&design),
            eligible: &eligible,
            ridge,
        };
        let chosen = fast.best_swap(&step).unwrap();
        assert_eq!(chosen, naive.best_swap(&step).unwrap(), "swap {swaps}");
        let Some((pos, j)) = chosen else { break };
        fast.swapped(&design, pos, j);
        eligible[design[pos]] = true;
        eligible[j] = false;
        design[pos] = j;
        swaps += 1;
        let scratch = spd_inverse(&pool.gram(&design, false)).unwrap();
        assert!(
            (minv(fast) - &scratch).norm() < 1e-9 * scratch.norm(),
            "M⁻¹ after swap {swaps}"
        );
    }
    assert!(swaps >= 3, "only {swaps} swaps");
}

#[test]
fn swaps_and_inverse_updates_follow_the_from_scratch_evaluation() {
    for (seed, count) in [(21, 10), (22, 7), (23, 14)] {
        let candidates = random_pool(seed, 80, 1, 6);
        let pool = Pool::new(&candidates, &options(count)).unwrap();
        follow_sweep(&pool, count, &mut RankOneD::new(&pool), |e| {
            e.inverse.minv.clone()
        });
    }
    for (candidates, count) in [
        (block_diagonal_pool(24, 60, 2, 4), 8),
        (random_pool(25, 60, 2, 5), 6),
        (random_pool(26, 60, 3, 7), 5),
    ] {
        let pool = Pool::new(&candidates, &options(count)).unwrap();
        follow_sweep(&pool, count, &mut BlockD::new(&pool), |e| {
            e.inverse.minv.clone()
        });
    }
}

#[test]
fn a_singular_design_is_exchanged_with_the_ridge() {
    // Design {0, 1, 2} spans only two of three directions: the sweep falls back to the
    // ridge, and the swaps (same as from scratch) restore full rank.
    let mut candidates = random_pool(31, 30, 1, 3);
    for (i, row) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]]
        .iter()
        .enumerate()
    {
        candidates[i] = DMatrix::from_row_slice(1, 3, row);
    }
    let pool = Pool::new(&candidates, &options(3)).unwrap();
    let design = vec![0, 1, 2];
    let (minv, ridge) = pool.exchange_inverse(&design).unwrap();
    assert!(ridge);
    let eligible: Vec<bool> = (0..pool.k).map(|j| j >= 3).collect();
    let mut fast = RankOneD::new(&pool);
    let mut naive = Naive {
        pool: &pool,
        criterion: Criterion::D,
    };
    fast.sweep_start(minv);
    let step = Step {
        design: &design,
        order: &order(&design),
        eligible: &eligible,
        ridge,
    };
    let chosen = fast.best_swap(&step).unwrap();
    assert_eq!(chosen, naive.best_swap(&step).unwrap());
    let (pos, j) = chosen.unwrap();
    let mut repaired = design.clone();
    repaired[pos] = j;
    assert!(log_det(&candidates, &repaired).is_finite());
}

#[test]
fn a_and_e_criteria_give_the_naive_selection() {
    for seed in 0..3 {
        for criterion in [Criterion::A, Criterion::E] {
            // The greedy construction alone too: the exchange would hide a greedy misstep.
            for max_sweeps in [0, 50] {
                let o = SelectionOptions {
                    criterion,
                    max_sweeps,
                    ..options(8)
                };
                for (pool, what) in [
                    (random_pool(300 + seed, 50, 1, 4), "rows"),
                    (block_diagonal_pool(400 + seed, 40, 2, 3), "leg blocks"),
                    (random_pool(450 + seed, 40, 3, 5), "blocks of 3"),
                ] {
                    let (fast, naive) =
                        (select(&pool, &o).unwrap(), select_naive(&pool, &o).unwrap());
                    assert_eq!(
                        fast.indices, naive.indices,
                        "{criterion:?}, {what}, {max_sweeps} sweeps, seed {seed}"
                    );
                }
            }
        }
    }
}

/// The E engine's bounds on each trial s_min rule out most swaps (here over three quarters of
/// them; measured: 1 or 2 of 416 evaluated) on a greedy design (where swaps improve) and on
/// the converged one (where none does: 0 to 2 evaluated), without changing the swap chosen.
#[test]
fn the_bounds_prune_e_swaps_without_changing_the_choice() {
    for seed in 0..3 {
        let candidates = random_pool(700 + seed, 60, 1, 4);
        let o = |max_sweeps| SelectionOptions {
            criterion: Criterion::E,
            max_sweeps,
            ..options(8)
        };
        for max_sweeps in [0, 50] {
            let design = select_naive(&candidates, &o(max_sweeps)).unwrap().indices;
            let pool = Pool::new(&candidates, &o(max_sweeps)).unwrap();
            let eligible: Vec<bool> = (0..pool.k).map(|j| !design.contains(&j)).collect();
            let step = Step {
                design: &design,
                order: &order(&design),
                eligible: &eligible,
                ridge: false,
            };
            let mut fast = EOptimal::new(&pool);
            let mut naive = Naive {
                pool: &pool,
                criterion: Criterion::E,
            };
            let chosen = fast.best_swap(&step).unwrap();
            assert_eq!(chosen, naive.best_swap(&step).unwrap(), "seed {seed}");
            assert_eq!(chosen.is_some(), max_sweeps == 0, "seed {seed}");
            let swaps = design.len() * (pool.k - design.len());
            // At least the chosen swap on the greedy design (none on the converged ones).
            assert!(
                (usize::from(chosen.is_some())..swaps / 4).contains(&fast.evaluated),
                "seed {seed}: {} of {swaps}",
                fast.evaluated
            );
        }
    }
}

/// The E engine's upper bounds on a trial's λ_min hold, up to their rounding slack: a
/// candidate added to A (Rayleigh–Ritz on A's v₁, v₂, and λ_{b+1}(A)), and a candidate swapped
/// for a design point (Ritz on M's v₁, v₂), against the eigenvalues of the trial matrix
/// computed from scratch. The bases: the design's M (eigenvalues spread), M less a design point,
/// and 2·I plus a tiny M (all eigenvalues clustered, the eigenvectors arbitrary).
#[test]
fn the_e_bounds_are_above_every_trial_s_smallest_eigenvalue() {
    let mut below_cap = 0;
    for seed in 0..4 {
        let candidates = random_pool(800 + seed, 60, 3, 8);
        let pool = Pool::new(&candidates, &options(6)).unwrap();
        let design: Vec<usize> = (0..6).collect();
        let m = pool.gram(&design, false);
        let less = &m - pool.block(0) * pool.block(0).transpose();
        let clustered = DMatrix::identity(8, 8) * 2.0 + &m * 1e-6;
        for base in [&m, &less, &clustered] {
            let bounds = Bounds::new(base, pool.b);
            for j in 0..pool.k {
                let block = pool.block(j);
                let exact = min_eigenvalue(base + block * block.transpose());
                let bound = bounds.of(&pool, j);
                let slack = bounds.slack(block.norm_squared());
                assert!(
                    exact <= bound + slack,
                    "seed {seed}, {j}: {exact} > {bound}"
                );
                below_cap += usize::from(bound < bounds.cap);
            }
        }
        let whole = Bounds::new(&m, pool.b);
        for &i in &design {
            let removed = pool.block(i);
            for j in 6..pool.k {
                let block = pool.block(j);
                let trial = &m - removed * removed.transpose() + block * block.transpose();
                let exact = min_eigenvalue(trial);
                let bound = whole.ritz(whole.projected(&pool, j), whole.projected(&pool, i));
                let slack = whole.slack(block.norm_squared());
                assert!(
                    exact <= bound + slack,
                    "seed {seed}, {i} for {j}: {exact} > {bound}"
                );
            }
        }
    }
    // The Ritz bound is the one that works, below λ_{b+1} for most candidates.
    assert!(below_cap > 4 * 3 * 60 / 2, "{below_cap}");
}

/// On pools of 3-row candidates (a tracker's x, y, z) the E engine selects as evaluating every
/// trial from scratch does, along the same path, and computes the eigenvalues of few trials.
#[test]
fn the_e_engine_evaluates_few_trials_and_selects_as_the_naive_one() {
    let mut exchanges = 0;
    for (seed, count) in [(0, 4), (1, 5), (2, 6), (3, 8), (4, 4), (5, 5)] {
        let candidates = match seed {
            0..3 => random_pool(900 + seed, 200, 3, 10),
            _ => skewed_pool(900 + seed, 200, 3, 10),
        };
        let o = SelectionOptions {
            criterion: Criterion::E,
            ..options(count)
        };
        let pool = Pool::new(&candidates, &o).unwrap();
        let mut fast = EOptimal::new(&pool);
        let chosen = run(&pool, &o, &mut fast).unwrap();
        let naive = select_naive(&candidates, &o).unwrap();
        assert_eq!(
            (
                &chosen.indices,
                chosen.sweeps,
                chosen.exchanges,
                chosen.excursions
            ),
            (
                &naive.indices,
                naive.sweeps,
                naive.exchanges,
                naive.excursions
            ),
            "seed {seed}"
        );
        exchanges += chosen.exchanges;
        // Measured: 178 to 236 of 2522 to 3699 trials on the random pools, 28 to 47 of 1759
        // to 6345 on the skewed ones (each greedy step and each swap scan evaluated at once).
        assert!(
            fast.evaluated * 10 < fast.trials,
            "seed {seed}: {} of {}",
            fast.evaluated,
            fast.trials
        );
    }
    assert!(exchanges > 0, "the exchange was exercised");
}

/// A phase's cost is said when its first steps promise more than five seconds, with the
/// steps it has and the time of each.
#[test]
fn a_long_phase_s_cost_is_said_from_its_first_steps() {
    let label = "selecting 100 of 15625 candidates (E): greedy";
    let line = cost_line(label, (100, "steps"), 3, Duration::from_millis(600)).unwrap();
    assert_eq!(
        line,
        "selecting 100 of 15625 candidates (E): greedy: 100 steps will take about 20 s (200 ms \
         each, timed on the first 3); Ctrl-C stops"
    );
    // 25 steps of 200 ms: exactly five seconds, not said; 26: said.
    let short = |total| cost_line(label, (total, "steps"), 3, Duration::from_millis(600));
    assert_eq!(short(25), None);
    assert!(short(26).is_some());
    // Nothing timed yet, or the phase already done: nothing to say.
    assert_eq!(
        cost_line(label, (100, "steps"), 0, Duration::from_secs(1)),
        None
    );
    assert_eq!(
        cost_line(label, (3, "steps"), 3, Duration::from_secs(60)),
        None
    );
}

/// The E criterion's greedy construction scores by the D gain while a design of `len + 1`
/// candidates of `b` rows cannot have full rank (`(len + 1)·b < n`), then by s_min itself. With
/// `b > 1` the switch comes before the count reaches n: the greedy designs (no exchange) of
/// the fast and the naive engines agree, and differ from the D criterion's.
#[test]
fn the_e_greedy_start_switches_to_s_min_when_full_rank_becomes_possible() {
    for (seed, b) in [(0, 2), (1, 2), (2, 3), (3, 3)] {
        let pool = random_pool(600 + seed, 40, b, 6);
        let greedy = |criterion| SelectionOptions {
            criterion,
            max_sweeps: 0,
            ..options(5)
        };
        let e = select(&pool, &greedy(Criterion::E)).unwrap();
        let naive = select_naive(&pool, &greedy(Criterion::E)).unwrap();
        assert_eq!(e.indices, naive.indices, "b = {b}, seed {seed}");
        let d = select(&pool, &greedy(Criterion::D)).unwrap();
        assert_ne!(e.indices, d.indices, "b = {b}, seed {seed}");
    }
}

/// Every candidate twice: each swap ties exactly with the one bringing in the copy, and ties
/// go to the lowest index, as in the naive reference.
#[test]
fn a_and_e_ties_go_to_the_lowest_index() {
    for criterion in [Criterion::A, Criterion::E] {
        let o = SelectionOptions {
            criterion,
            ..options(6)
        };
        for seed in 0..3 {
            let single = random_pool(500 + seed, 25, 1, 4);
            let pool: Vec<_> = single.iter().chain(&single).cloned().collect();
            let (fast, naive) = (select(&pool, &o).unwrap(), select_naive(&pool, &o).unwrap());
            assert_eq!(fast.indices, naive.indices, "{criterion:?}, seed {seed}");
            assert_eq!(
                fast.exchanges, naive.exchanges,
                "{criterion:?}, seed {seed}"
            );
        }
    }
}

#[test]
fn pools_larger_than_one_chunk_give_the_naive_selection() {
    // K > CHUNK: the products with X are formed in several chunks, the swaps pruned by the
    // leverage bound; the selection must still be the from-scratch one.
    let mut exchanges = 0;
    for (seed, b, n, count) in [(41, 1, 3, 5), (42, 1, 6, 8), (44, 1, 6, 15), (43, 2, 4, 3)] {
        let candidates = skewed_pool(seed, 2 * CHUNK + 7, b, n);
        let pool = Pool::new(&candidates, &options(count)).unwrap();
        assert!(pool.chunks().count() >= 2);
        let (fast, naive) = (
            select(&candidates, &options(count)).unwrap(),
            select_naive(&candidates, &options(count)).unwrap(),
        );
        assert_eq!(fast.indices, naive.indices, "seed {seed}, b = {b}");
        exchanges += fast.exchanges;
    }
    assert!(exchanges > 0, "the exchange phase was never exercised");
}

#[test]
fn chunks_cover_the_pool_in_order_with_nearly_equal_sizes() {
    for k in [1, 5, 6, CHUNK - 1, CHUNK, CHUNK + 1, 3 * CHUNK + 2, 10_000] {
        let pool = Pool::new(&random_pool(7, k, 1, 1), &options(1)).unwrap();
        let ranges: Vec<_> = pool.chunks().collect();
        assert_eq!(ranges.first().unwrap().start, 0, "K = {k}");
        assert_eq!(ranges.last().unwrap().end, k, "K = {k}");
        assert!(ranges.windows(2).all(|w| w[0].end == w[1].start), "K = {k}");
        let (shortest, longest) = (
            ranges.iter().map(|r| r.len()).min().unwrap(),
            ranges.iter().map(|r| r.len()).max().unwrap(),
        );
        assert!(longest <= CHUNK && longest - shortest <= 1, "K = {k}");
        assert!(shortest >= k.min(6), "K = {k}: a chunk of {shortest}");
        // Any k candidate indices are grouped as the pool of k candidates is chunked.
        let indices: Vec<usize> = (0..k).map(|j| 3 * j + 1).collect();
        let groups = pool.column_groups(&indices);
        assert_eq!(groups.len(), ranges.len(), "K = {k}");
        for (group, range) in groups.iter().zip(&ranges) {
            assert_eq!(*group, &indices[range.clone()], "K = {k}");
        }
    }
    assert!(Pool::new(&random_pool(7, 3, 1, 1), &options(1))
        .unwrap()
        .column_groups(&[])
        .is_empty());
}

/// Every row's leverage x_rᵀM⁻¹x_r, for a pool of several chunks and candidates of two rows,
/// is the one formed from that row alone (each chunk's leverages land at its own rows).
#[test]
fn row_leverages_of_a_pool_of_several_chunks_are_each_rows_own() {
    let (b, n) = (2, 4);
    let candidates = random_pool(12, 2 * CHUNK + 7, b, n);
    let pool = Pool::new(&candidates, &options(3)).unwrap();
    assert!(pool.chunks().count() >= 2);
    let minv = spd_inverse(&pool.gram(&[0, 1, 2, 3], false)).unwrap();
    let leverages = pool.row_leverages(&minv);
    assert_eq!(leverages.len(), candidates.len() * b);
    for (j, c) in candidates.iter().enumerate() {
        for r in 0..b {
            let row = c.row(r).transpose();
            let expected = row.dot(&(&minv * &row));
            let found = leverages[j * b + r];
            assert!(
                (found - expected).abs() <= 1e-12 * expected.abs(),
                "candidate {j}, row {r}: {found} for {expected}"
            );
        }
    }
}

#[test]
fn column_dots_are_the_row_sums_of_the_componentwise_product_to_the_bit() {
    // The leverages must be those of the whole-matrix formula, bit for bit, so that the
    // chunked engines choose exactly the swaps the unchunked ones did.
    for n in [3, 6, 12] {
        let x = DMatrix::from_fn(n, 50, |p, j| ((p * 31 + j * 17) as f64).sin() * 1e3);
        let y = DMatrix::from_fn(n, 50, |p, j| ((p * 7 + j * 13) as f64).cos() / 3.0);
        let mut dots = vec![0.0; 50];
        crate::selection::pool::column_dots(&x.columns(0, 50), &y, &mut dots);
        let expected = x.component_mul(&y).row_sum();
        for (a, b) in dots.iter().zip(expected.iter()) {
            assert_eq!(a.to_bits(), b.to_bits(), "n = {n}");
        }
    }
}

/// With no eligible candidate left, every engine's greedy step names what was asked: one
/// pose more than the design holds, out of the pool's candidates. (The driver never asks:
/// the pool holds at least the requested count; this is the engines' own contract.)
#[test]
fn a_greedy_step_without_an_eligible_candidate_names_the_poses_requested() {
    use crate::selection::{AOptimal, EOptimal};
    for b in [1, 2] {
        let candidates = random_pool(950 + b as u64, 12, b, 4);
        let pool = Pool::new(&candidates, &options(6)).unwrap();
        let design = [0, 1, 2, 3, 4];
        let none = vec![false; pool.k];
        let expected = Err(SelectionError::TooFewCandidates {
            available: 12,
            requested: 6,
        });
        let mut naive = Naive {
            pool: &pool,
            criterion: Criterion::D,
        };
        assert_eq!(
            naive.greedy_pick(&design, &none),
            expected,
            "naive, b = {b}"
        );
        assert_eq!(
            AOptimal { pool: &pool }.greedy_pick(&design, &none),
            expected,
            "A, b = {b}"
        );
        assert_eq!(
            EOptimal::new(&pool).greedy_pick(&design, &none),
            expected,
            "E, b = {b}"
        );
        if b == 1 {
            let mut engine = RankOneD::new(&pool);
            assert_eq!(engine.greedy_pick(&design, &none), expected, "rank one");
        } else {
            let mut engine = BlockD::new(&pool);
            assert_eq!(engine.greedy_pick(&design, &none), expected, "block");
        }
    }
}

/// The rank-one engine's leverage bound 1 + d_j − d_i rules out most swaps on a poor design
/// (the first candidates, where swaps improve) and on the converged one (where none does)
/// without changing the swap chosen; under the ridge it rules out none.
#[test]
fn the_leverage_bound_prunes_rank_one_swaps_except_under_the_ridge() {
    let mut pruned = 0;
    for seed in 0..3 {
        let candidates = random_pool(800 + seed, 60, 1, 4);
        let pool = Pool::new(&candidates, &options(8)).unwrap();
        let converged = select_naive(&candidates, &options(8)).unwrap().indices;
        for design in [(0..8).collect(), converged] {
            let eligible: Vec<bool> = (0..pool.k).map(|j| !design.contains(&j)).collect();
            let swaps = design.len() * (pool.k - design.len());
            for ridge in [false, true] {
                let step = Step {
                    design: &design,
                    order: &order(&design),
                    eligible: &eligible,
                    ridge,
                };
                let mut fast = RankOneD::new(&pool);
                fast.sweep_start(spd_inverse(&pool.gram(&design, false)).unwrap());
                let mut naive = Naive {
                    pool: &pool,
                    criterion: Criterion::D,
                };
                let chosen = fast.best_swap(&step).unwrap();
                assert_eq!(chosen, naive.best_swap(&step).unwrap(), "seed {seed}");
                // Measured: 4 to 37 of the 416 swaps evaluated without the ridge.
                let expected = if ridge {
                    swaps..swaps + 1
                } else {
                    1..swaps / 10
                };
                assert!(
                    expected.contains(&fast.evaluated),
                    "seed {seed}, ridge {ridge}: {} of {swaps}",
                    fast.evaluated
                );
                // The candidates left after the bound against the design's smallest leverage
                // (all of them under the ridge), counted from leverages formed here.
                let d = |j: usize| {
                    let c = candidates[j].transpose();
                    (c.transpose() * fast.inverse.minv.clone() * c)[(0, 0)]
                };
                let floor = design.iter().map(|&i| d(i)).fold(f64::INFINITY, f64::min);
                let hopeful = (0..pool.k)
                    .filter(|&j| eligible[j])
                    .filter(|&j| {
                        let (bound, slack) = (1.0 + d(j) - floor, 1e-6 * (1.0 + d(j) + floor));
                        ridge || bound >= 1.0 + ACCEPT - slack
                    })
                    .count();
                assert_eq!(fast.hopeful, hopeful, "seed {seed}, ridge {ridge}");
                pruned += pool.k - design.len() - hopeful;
            }
        }
    }
    assert!(
        pruned > 0,
        "no candidate ruled out against the whole design"
    );
}

/// The A engine's greedy step, at every design size from empty to past n rows, picks the
/// candidate the documented rule picks from scratch: while the trial design has fewer than n
/// rows, the largest det(M + C_jᵀC_j) (the D gain); from then on the smallest
/// tr (M + C_jᵀC_j)⁻¹, M with the ridge. One row per candidate and three.
#[test]
fn the_a_greedy_step_is_the_best_trial_from_scratch_at_every_design_size() {
    use crate::selection::AOptimal;
    for (seed, b, n) in [
        (960, 1, 5),
        (961, 1, 6),
        (962, 3, 5),
        (963, 2, 5),
        (964, 2, 3),
        (965, 3, 4),
    ] {
        let candidates = random_pool(seed, 40, b, n);
        let pool = Pool::new(&candidates, &options(8)).unwrap();
        for size in 0..=n + 1 {
            let design: Vec<usize> = (0..size).collect();
            let eligible: Vec<bool> = (0..pool.k).map(|j| j >= size).collect();
            let m = pool.gram(&design, true);
            let trial = |j: usize| &m + candidates[j].transpose() * &candidates[j];
            let singular_trial = (size + 1) * b < n;
            let score = |j: usize| {
                if singular_trial {
                    trial(j).determinant()
                } else {
                    -trial(j).try_inverse().unwrap().trace()
                }
            };
            let mut expected = (usize::MAX, f64::NEG_INFINITY);
            for j in size..pool.k {
                if score(j) > expected.1 {
                    expected = (j, score(j));
                }
            }
            assert_eq!(
                AOptimal { pool: &pool }.greedy_pick(&design, &eligible),
                Ok(expected.0),
                "b = {b}, n = {n}, {size} poses"
            );
        }
    }
}

/// The leverage bound rules a swap out only when 1 + d_j − d_i falls short of the target by
/// more than the slack 1e-6 (1 + |d_j| + |d_i|): a bound of 1.3 against targets a slack
/// above it (1.7e-6, and 2.3e-6 for negative leverages, whose magnitudes count), ± 1e-7.
#[test]
fn the_leverage_bound_rules_out_only_beyond_its_rounding_slack() {
    use crate::selection::rank_one_d::below;
    for (dj, di) in [(0.5, 0.2), (-0.5, -0.8)] {
        let bound = 1.0 + dj - di;
        let slack = 1e-6 * (1.0 + f64::abs(dj) + f64::abs(di));
        assert!(!below(dj, di, bound), "{dj}, {di}: at the bound");
        assert!(
            !below(dj, di, bound + slack - 1e-7),
            "{dj}, {di}: within the slack"
        );
        assert!(
            below(dj, di, bound + slack + 1e-7),
            "{dj}, {di}: beyond the slack"
        );
    }
}

/// At a design no swap improves, a candidate identical to a design point swaps for it with
/// Δ = 1 (to round-off), short of the acceptance 1 + ACCEPT: no D engine swaps them. (With
/// an acceptance of 1 − ACCEPT every engine would.)
#[test]
fn no_d_engine_swaps_a_design_point_for_its_copy() {
    use crate::selection::SeparableD;
    // (candidates, design size, separable: one row, or rows on columns of their own)
    for (candidates, count, separable) in [
        (random_pool(970, 40, 1, 4), 6, true),
        (random_pool(971, 40, 2, 4), 4, false),
        (block_diagonal_pool(972, 40, 2, 3), 4, true),
    ] {
        let converged = select_naive(&candidates, &options(count)).unwrap().indices;
        let mut with_copy = candidates.clone();
        with_copy.push(candidates[converged[0]].clone());
        let pool = Pool::new(&with_copy, &options(count)).unwrap();
        let eligible: Vec<bool> = (0..pool.k).map(|j| !converged.contains(&j)).collect();
        let step = Step {
            design: &converged,
            order: &order(&converged),
            eligible: &eligible,
            ridge: false,
        };
        let minv = spd_inverse(&pool.gram(&converged, false)).unwrap();
        let mut engines: Vec<Box<dyn Engine>> = vec![Box::new(Naive {
            pool: &pool,
            criterion: Criterion::D,
        })];
        if pool.b == 1 {
            engines.push(Box::new(RankOneD::new(&pool)));
        } else {
            engines.push(Box::new(BlockD::new(&pool)));
        }
        if let Some(separable) = SeparableD::new(&pool) {
            engines.push(Box::new(separable));
        }
        assert_eq!(engines.len(), 2 + usize::from(separable));
        for engine in &mut engines {
            engine.sweep_start(minv.clone());
            assert_eq!(engine.best_swap(&step).unwrap(), None, "{}", engine.name());
        }
    }
}

/// The block engine's swap ratio det(I − D_i + E G⁻¹ Eᵀ), written out for 2 × 2 blocks and
/// general for b × b, against nalgebra's determinant of the matrix formed explicitly: random
/// D_i, G⁻¹ and E (no symmetry assumed, so that every entry's term shows).
#[test]
fn the_block_swap_ratio_is_the_determinant_of_its_matrix() {
    use crate::selection::block_d::{ratio, ratio_2x2};
    let mut rng = ChaCha8Rng::seed_from_u64(980);
    for b in [2, 3, 4] {
        for _ in 0..5 {
            let mut random = || DMatrix::<f64>::from_fn(b, b, |_, _| rng.sample(StandardNormal));
            let (d, g_inverse, e) = (random(), random(), random());
            let expected =
                (DMatrix::identity(b, b) - &d + &e * &g_inverse * e.transpose()).determinant();
            let (di, gi) = (
                d.transpose().as_slice().to_vec(),
                g_inverse.transpose().as_slice().to_vec(),
            );
            let mut scratch = vec![0.0; 3 * b * b];
            let general = ratio(&di, &gi, &e.as_view(), &mut scratch);
            assert!(
                (general - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                "b = {b}: {general} for {expected}"
            );
            if b == 2 {
                let written_out = ratio_2x2(&di, &gi, &e.as_view());
                assert!(
                    (written_out - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                    "2 × 2: {written_out} for {expected}"
                );
            }
        }
    }
}
