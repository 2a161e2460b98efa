//! Quality of the selected designs: random subsets, brute force, scaling invariance and the
//! Kiefer–Wolfowitz certificate.

use super::*;
use crate::selection::linalg::min_eigenvalue;
use crate::selection::pool::CHUNK;

/// Criterion values of a design: (log det, −tr M⁻¹, s_min).
fn criteria(pool: &[DMatrix<f64>], design: &[usize]) -> (f64, f64, f64) {
    let n = pool[0].ncols();
    let mut m = DMatrix::zeros(n, n);
    for &j in design {
        m += pool[j].tr_mul(&pool[j]);
    }
    let trace = m
        .clone()
        .try_inverse()
        .map_or(f64::INFINITY, |inverse| inverse.trace());
    (
        log_det(pool, design),
        -trace,
        min_eigenvalue(m).max(0.0).sqrt(),
    )
}

#[test]
fn the_selection_beats_1000_random_subsets() {
    let (k, count) = (200, 18);
    let pool = random_pool(7, k, 1, 6);
    let chosen: Vec<(f64, f64, f64)> = [Criterion::D, Criterion::A, Criterion::E]
        .into_iter()
        .map(|criterion| {
            let selection = select(
                &pool,
                &SelectionOptions {
                    criterion,
                    ..options(count)
                },
            )
            .unwrap();
            criteria(&pool, &selection.indices)
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut best = (f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for _ in 0..1000 {
        let subset = rand::seq::index::sample(&mut rng, k, count).into_vec();
        let c = criteria(&pool, &subset);
        best = (best.0.max(c.0), best.1.max(c.1), best.2.max(c.2));
    }
    assert!(chosen[0].0 >= best.0, "D: {} < {}", chosen[0].0, best.0);
    assert!(chosen[1].1 >= best.1, "A: {} < {}", chosen[1].1, best.1);
    assert!(chosen[2].2 >= best.2, "E: {} < {}", chosen[2].2, best.2);
}

/// All `count`-subsets of 0..k.
fn subsets(k: usize, count: usize) -> Vec<Vec<usize>> {
    if count == 0 {
        return vec![vec![]];
    }
    (count - 1..k)
        .flat_map(|last| {
            subsets(last, count - 1).into_iter().map(move |mut s| {
                s.push(last);
                s
            })
        })
        .collect()
}

#[test]
fn the_exchange_is_within_one_percent_of_the_brute_force_optimum() {
    // Single swaps plus DETMAX excursions are a local search: on 400 such pools, 2 end
    // 1.3–1.7% below the optimum (7 without excursions); these 100 seeds all reach 1%.
    let (k, n, count) = (10, 3, 4);
    let all = subsets(k, count);
    assert_eq!(all.len(), 210);
    let mut optimal = 0;
    for seed in 0..100 {
        let pool = random_pool(500 + seed, k, 1, n);
        let optimum = all
            .iter()
            .map(|s| log_det(&pool, s))
            .fold(f64::NEG_INFINITY, f64::max);
        let selection = select(&pool, &options(count)).unwrap();
        let efficiency = ((selection.log_det - optimum) / n as f64).exp();
        assert!(
            efficiency > 0.99,
            "seed {seed}: det^(1/n) efficiency {efficiency}"
        );
        optimal += usize::from(efficiency > 1.0 - 1e-12);
    }
    assert!(optimal >= 95, "only {optimal} of 100 designs are optimal");
    // Blocks of two rows: 5 parameters, 3 poses of 2 rows.
    let all = subsets(k, 3);
    for seed in 0..20 {
        let pool = random_pool(600 + seed, k, 2, 5);
        let optimum = all
            .iter()
            .map(|s| log_det(&pool, s))
            .fold(f64::NEG_INFINITY, f64::max);
        let selection = select(&pool, &options(3)).unwrap();
        let efficiency = ((selection.log_det - optimum) / 5.0).exp();
        assert!(
            efficiency > 0.99,
            "blocks, seed {seed}: efficiency {efficiency}"
        );
    }
}

#[test]
fn the_d_optimal_selection_is_invariant_to_column_scaling() {
    let weights = [1e3, 1e-2, 7.3, 1.0, 0.05, 250.0];
    let scale = |pool: &[DMatrix<f64>]| -> Vec<DMatrix<f64>> {
        pool.iter()
            .map(|c| DMatrix::from_fn(c.nrows(), c.ncols(), |r, p| c[(r, p)] * weights[p]))
            .collect()
    };
    let shift: f64 = 2.0 * weights.iter().map(|w: &f64| w.ln()).sum::<f64>();
    for seed in 0..4 {
        for (pool, count) in [
            (random_pool(700 + seed, 300, 1, 6), 18),
            (block_diagonal_pool(800 + seed, 150, 2, 3), 10),
        ] {
            let plain = select(&pool, &options(count)).unwrap();
            let scaled = select(&scale(&pool), &options(count)).unwrap();
            assert_eq!(plain.indices, scaled.indices, "seed {seed}");
            assert!((scaled.log_det - plain.log_det - shift).abs() < 1e-8 * shift.abs());
            assert!(relative_gap(plain.certificate, scaled.certificate) < 1e-8);
        }
    }
    // The ridge makes the greedy start scale-equivariant too: same set without exchange.
    let pool = random_pool(900, 300, 1, 6);
    let greedy = SelectionOptions {
        max_sweeps: 0,
        ..options(18)
    };
    assert_eq!(
        select(&pool, &greedy).unwrap().indices,
        select(&scale(&pool), &greedy).unwrap().indices
    );
}

/// The certificate is the design's size times the largest tr(C_j M⁻¹ C_jᵀ) over the pool,
/// recomputed here candidate by candidate from M of the selected rows, for pools of one
/// chunk and of several, of one row per candidate and of two.
#[test]
fn the_certificate_is_the_size_times_the_largest_candidate_variance() {
    for (seed, k, b, n, count) in [
        (3, 40, 1, 4, 6),
        (4, 40, 2, 4, 3),
        (5, 2 * CHUNK + 7, 2, 4, 3),
        (6, 2 * CHUNK + 7, 2, 4, 3),
        (7, 2 * CHUNK + 7, 2, 4, 3),
    ] {
        let candidates = random_pool(seed, k, b, n);
        let selection = select(&candidates, &options(count)).unwrap();
        let mut m = DMatrix::zeros(n, n);
        for &j in &selection.indices {
            m += candidates[j].transpose() * &candidates[j];
        }
        let minv = m.try_inverse().unwrap();
        let largest = candidates
            .iter()
            .map(|c| (c * &minv * c.transpose()).trace())
            .fold(f64::NEG_INFINITY, f64::max);
        let expected = count as f64 * largest;
        assert!(
            (selection.certificate - expected).abs() <= 1e-9 * expected,
            "seed {seed}: {} for {expected}",
            selection.certificate
        );
    }
}

#[test]
fn the_kiefer_wolfowitz_certificate_is_n_for_the_known_optimal_design() {
    let pool = quadratic_pool();
    // D-optimal support of the quadratic: {−1, 0, 1} with equal weights.
    let exact = select(&pool, &options(3)).unwrap();
    assert_eq!(exact.indices, vec![0, 100, 200]);
    assert!(
        (exact.certificate - 3.0).abs() < 1e-9,
        "{}",
        exact.certificate
    );
    let replicated = select(
        &pool,
        &SelectionOptions {
            allow_replicates: true,
            ..options(9)
        },
    )
    .unwrap();
    assert_eq!(
        replicated.indices,
        vec![0, 0, 0, 100, 100, 100, 200, 200, 200]
    );
    assert!((replicated.certificate - 3.0).abs() < 1e-9);
    // Without replicates: clusters around the support, nearly optimal.
    let clustered = select(&pool, &options(9)).unwrap();
    assert!(
        clustered.certificate >= 3.0 && clustered.certificate < 3.1,
        "{}",
        clustered.certificate
    );
    assert!(clustered
        .indices
        .iter()
        .all(|&i| i <= 2 || (98..=102).contains(&i) || i >= 198));
    // On random pools the certificate is at least n.
    for seed in 0..4 {
        let s = select(&random_pool(seed, 100, 1, 5), &options(10)).unwrap();
        assert!(s.certificate >= 5.0 - 1e-9, "{}", s.certificate);
        let s = select(&block_diagonal_pool(seed, 100, 2, 3), &options(6)).unwrap();
        assert!(s.certificate >= 6.0 - 1e-9, "{}", s.certificate);
    }
}

/// The exchange ends on a design that no single swap improves by more than the acceptance
/// factor: checked by brute force over every position and every candidate outside the
/// design, candidates swapped out on the way included (they must become eligible again).
#[test]
fn no_single_swap_improves_the_final_design() {
    let accept = ACCEPT.ln_1p();
    // Pools where a candidate swapped out early is swapped back in later (seeds 5001 and
    // 5004 for E and A), and others.
    for seed in 5000..5006 {
        for (b, n, k, count) in [(1, 4, 25, 6), (1, 6, 30, 8), (2, 6, 20, 5)] {
            let pool = skewed_pool(seed, k, b, n);
            for criterion in [Criterion::D, Criterion::A, Criterion::E] {
                let o = SelectionOptions {
                    criterion,
                    ..options(count)
                };
                let selection = select(&pool, &o).unwrap();
                assert!(selection.sweeps < o.max_sweeps, "seed {seed}: converged");
                let value = |design: &[usize]| {
                    let c = criteria(&pool, design);
                    match criterion {
                        Criterion::D => c.0,
                        Criterion::A => -(-c.1).ln(),
                        Criterion::E => c.2.ln(),
                    }
                };
                let design = &selection.indices;
                let current = value(design);
                for pos in 0..design.len() {
                    for j in (0..pool.len()).filter(|j| !design.contains(j)) {
                        let mut trial = design.clone();
                        trial[pos] = j;
                        assert!(
                            value(&trial) <= current + accept + 1e-9,
                            "seed {seed} {criterion:?}: swapping position {pos} for {j} improves"
                        );
                    }
                }
            }
        }
    }
}

/// An excursion is what lifts a design past a swap-optimal one, and it is counted: on this
/// pool (E criterion) one sweep of swaps ends on a design that no single swap improves
/// (brute force), yet the full selection ends higher, so an excursion improved it.
#[test]
fn an_excursion_past_a_swap_optimal_design_is_counted() {
    let pool = skewed_pool(5001, 25, 1, 4);
    let o = |max_sweeps| SelectionOptions {
        criterion: Criterion::E,
        max_sweeps,
        ..options(6)
    };
    let value = |design: &[usize]| criteria(&pool, design).2;
    let first = select(&pool, &o(1)).unwrap();
    assert_eq!(first.excursions, 0);
    for pos in 0..6 {
        for j in (0..pool.len()).filter(|j| !first.indices.contains(j)) {
            let mut trial = first.indices.clone();
            trial[pos] = j;
            assert!(value(&trial) <= value(&first.indices) * (1.0 + 1e-9));
        }
    }
    let full = select(&pool, &o(50)).unwrap();
    assert!(value(&full.indices) > value(&first.indices) * (1.0 + 1e-6));
    assert!(full.excursions >= 1, "{} excursions", full.excursions);
}

/// The Kiefer–Wolfowitz value reported with a selection of blocks is N·max_j tr(C_j M⁻¹ C_jᵀ),
/// recomputed here by an explicit inverse over every candidate block of two and three rows.
#[test]
fn the_certificate_of_a_block_design_is_recomputed_from_its_blocks() {
    for b in [2, 3] {
        let pool = random_pool(990 + b as u64, 30, b, 6);
        let selection = select(&pool, &options(5)).unwrap();
        let n = pool[0].ncols();
        let mut m = DMatrix::zeros(n, n);
        for &j in &selection.indices {
            m += pool[j].tr_mul(&pool[j]);
        }
        let inverse = m.try_inverse().unwrap();
        let largest = pool
            .iter()
            .map(|c| (c * &inverse * c.transpose()).trace())
            .fold(f64::NEG_INFINITY, f64::max);
        let expected = selection.indices.len() as f64 * largest;
        assert!(
            (selection.certificate - expected).abs() <= 1e-9 * expected,
            "b = {b}: {} vs {expected}",
            selection.certificate
        );
    }
}
