//! The separable D engine against the dense block engine and the from-scratch reference, its
//! detection from the pool's numbers, and the traditional designs of the bundled models.

use super::*;
use crate::selection::driver::run;
use crate::selection::pool::CHUNK;
use crate::selection::separable_d::row_supports;
use crate::selection::{design, BlockD, Pool, SeparableD};

/// K candidates whose row r is non-zero only in the columns q ≡ r (mod b) among the first
/// b·widths[r] (the supports interleaved, of unequal sizes), with log-normal candidate scales
/// and correlated columns within a row, so that the exchange does real work.
fn separable_pool(seed: u64, k: usize, widths: &[usize]) -> Vec<DMatrix<f64>> {
    let b = widths.len();
    let columns: Vec<Vec<usize>> = (0..b)
        .map(|r| (0..widths[r]).map(|q| q * b + r).collect())
        .collect();
    // Columns that no row owns (q·b + r with q ≥ widths[r]) are left out by renumbering.
    let mut used: Vec<usize> = columns.iter().flatten().copied().collect();
    used.sort_unstable();
    let renumber = |p: usize| used.binary_search(&p).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mixing: Vec<f64> = (0..b).map(|_| rng.sample(StandardNormal)).collect();
    (0..k)
        .map(|_| {
            let scale = (1.2 * rng.sample::<f64, _>(StandardNormal)).exp();
            let mut c = DMatrix::zeros(b, used.len());
            for (r, row) in columns.iter().enumerate() {
                let mut previous = 0.0;
                for &p in row {
                    let fresh: f64 = rng.sample(StandardNormal);
                    previous = fresh + 0.7 * mixing[r] * previous;
                    c[(r, renumber(p))] = previous * scale;
                }
            }
            c
        })
        .collect()
}

/// Runs the separable engine, the dense block engine and the from-scratch reference on
/// `candidates`: all three must select the same candidates by the same path, and [`select`]
/// must be the separable run. Returns the exchanges made.
fn assert_separable_matches(candidates: &[DMatrix<f64>], options: &SelectionOptions) -> usize {
    let pool = Pool::new(candidates, options).unwrap();
    let mut separable = SeparableD::new(&pool).expect("a separable pool");
    let fast = run(&pool, options, &mut separable).unwrap();
    let dense = run(&pool, options, &mut BlockD::new(&pool)).unwrap();
    let naive = select_naive(candidates, options).unwrap();
    let path = |s: &Selection| (s.sweeps, s.exchanges, s.excursions);
    assert_eq!(fast.indices, dense.indices, "separable vs dense blocks");
    assert_eq!(path(&fast), path(&dense));
    assert_eq!(fast.indices, naive.indices, "separable vs from scratch");
    assert_eq!(path(&fast), path(&naive));
    assert!(relative_gap(fast.log_det, dense.log_det) < 1e-12);
    assert!(relative_gap(fast.log_det, log_det(candidates, &fast.indices)) < 1e-9);
    assert_eq!(select(candidates, options).unwrap(), fast);
    fast.exchanges
}

#[test]
fn separable_updates_give_the_dense_block_and_naive_selection() {
    let mut exchanges = 0;
    for seed in 0..3 {
        for (widths, count) in [
            (vec![3, 3], 5),
            (vec![4, 2], 4),
            (vec![2, 3, 4], 5),
            (vec![2, 2, 2, 3, 2, 2], 3),
            (vec![3; 6], 4),
        ] {
            let candidates = separable_pool(seed * 10 + widths.len() as u64, 80, &widths);
            exchanges += assert_separable_matches(&candidates, &options(count));
        }
        exchanges += assert_separable_matches(&block_diagonal_pool(seed, 60, 2, 4), &options(8));
        exchanges += assert_separable_matches(&block_diagonal_pool(seed, 60, 6, 2), &options(3));
    }
    assert!(exchanges > 0, "the exchange phase was never exercised");
}

#[test]
fn separable_pools_larger_than_one_chunk_give_the_dense_block_and_naive_selection() {
    let mut exchanges = 0;
    for (seed, widths, count) in [
        (71, vec![3, 3], 6),
        (78, vec![2, 3, 2], 5),
        (73, vec![2, 2], 4),
    ] {
        let candidates = separable_pool(seed, 2 * CHUNK + 7, &widths);
        let pool = Pool::new(&candidates, &options(count)).unwrap();
        assert!(pool.chunks().count() >= 2);
        exchanges += assert_separable_matches(&candidates, &options(count));
    }
    assert!(exchanges > 0, "the exchange phase was never exercised");
}

#[test]
fn separable_swaps_and_inverse_updates_follow_the_from_scratch_evaluation() {
    for (seed, widths, count) in [(81, vec![3, 3], 5), (82, vec![2, 3, 2], 4)] {
        let candidates = separable_pool(seed, 60, &widths);
        let pool = Pool::new(&candidates, &options(count)).unwrap();
        let mut engine = SeparableD::new(&pool).unwrap();
        super::engines::follow_sweep(&pool, count, &mut engine, |e| {
            // The dense M⁻¹ the blocks stand for (zero between different row positions).
            let mut minv = DMatrix::zeros(pool.n, pool.n);
            for (support, block) in e.supports.iter().zip(&e.blocks) {
                for (a, &p) in support.iter().enumerate() {
                    for (c, &q) in support.iter().enumerate() {
                        minv[(p, q)] = block[(a, c)];
                    }
                }
            }
            minv
        });
    }
}

#[test]
fn separability_is_read_from_the_column_supports() {
    let o = options(4);
    // Interleaved supports of sizes 3 and 2: row 0 in columns 0, 2, 4; row 1 in 1, 3.
    let candidates = separable_pool(91, 30, &[3, 2]);
    let pool = Pool::new(&candidates, &o).unwrap();
    assert_eq!(row_supports(&pool), Some(vec![vec![0, 2, 4], vec![1, 3]]));
    // One entry of one candidate in the other row's columns: not separable, dense blocks.
    for (r, p) in [(0, 1), (1, 4)] {
        let mut touched = candidates.clone();
        touched[17][(r, p)] = 1e-3;
        let pool = Pool::new(&touched, &o).unwrap();
        assert!(row_supports(&pool).is_none(), "row {r} in column {p}");
        assert!(SeparableD::new(&pool).is_none());
        let dense = run(&pool, &o, &mut BlockD::new(&pool)).unwrap();
        assert_eq!(select(&touched, &o).unwrap(), dense);
    }
    // Dense random rows share every column.
    let random = random_pool(92, 40, 2, 5);
    assert!(row_supports(&Pool::new(&random, &o).unwrap()).is_none());
}

/// The traditional (shared) design of every bundled model: its pool is separable, and the
/// selection is the dense block engine's on the same pool, candidate for candidate. The pools
/// are thinned to at most about 1500 candidates (every k-th, in grid order) so that the dense
/// engine stays quick on the hexapod's 15 625; the full pools were compared when the engine
/// was written (docs/benchmarks.md, "Separable pools").
#[test]
fn the_traditional_designs_of_the_bundled_models_are_the_dense_block_selections() {
    let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
    let mut paths: Vec<_> = std::fs::read_dir(&models)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "yaml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 8, "{paths:?}");
    for path in paths {
        let mechanism = crate::model::Mechanism::load(&path).unwrap();
        let mut pool = crate::selection::candidates::candidate_pool(&mechanism, None).unwrap();
        let step = pool.candidates.len().div_ceil(1500);
        pool.candidates = pool.candidates.into_iter().step_by(step).collect();
        let setup = &mechanism.selection;
        let d = crate::model::mechanism::SelectionCriterion::D;
        let shared = design::traditional(&mechanism, &pool, setup.poses_per_leg, d).unwrap();
        let o = SelectionOptions {
            count: setup.poses_per_leg,
            criterion: Criterion::D,
            ..Default::default()
        };
        let legs = mechanism.identified_legs().len();
        let columns = design::shared_columns(&mechanism, &pool);
        let pool = Pool::from_columns(columns, legs, &o).unwrap();
        assert!(SeparableD::new(&pool).is_some(), "{}", path.display());
        let dense = run(&pool, &o, &mut BlockD::new(&pool)).unwrap();
        // The same design, or one of the same criterion to round-off: a symmetric mechanism's
        // grid holds candidates whose exchange gains tie exactly (models/delta-probe-poses.yaml,
        // every tower parameter free: log det agreeing to 5e-13), where round-off picks.
        let tie = (shared.selection.log_det - dense.log_det).abs() <= 1e-10;
        assert!(
            shared.indices == dense.indices || tie,
            "{}: {:?} (log det {}) vs {:?} (log det {})",
            path.display(),
            shared.indices,
            shared.selection.log_det,
            dense.indices,
            dense.log_det
        );
    }
}
