//! Tests of the pose selection: shared pools and helpers, errors, determinism and log det;
//! agreement with the naive reference in [`engines`] and [`separable`], design quality in
//! [`optimality`].

use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

mod engines;
mod exchange;
mod gains;
mod linalg;
mod optimality;
mod separable;

fn options(count: usize) -> SelectionOptions {
    SelectionOptions {
        count,
        ..Default::default()
    }
}

/// K random candidates of b × n standard-normal entries.
fn random_pool(seed: u64, k: usize, b: usize, n: usize) -> Vec<DMatrix<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..k)
        .map(|_| DMatrix::from_fn(b, n, |_, _| rng.sample(StandardNormal)))
        .collect()
}

/// K random block-diagonal candidates: leg l's row has entries only in columns l·w..(l+1)·w.
fn block_diagonal_pool(seed: u64, k: usize, legs: usize, width: usize) -> Vec<DMatrix<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..k)
        .map(|_| {
            let mut c = DMatrix::zeros(legs, legs * width);
            for l in 0..legs {
                for p in 0..width {
                    c[(l, l * width + p)] = rng.sample::<f64, _>(StandardNormal) * (1.0 + p as f64);
                }
            }
            c
        })
        .collect()
}

/// K candidates of b × n rows with correlated columns and log-normal row scales: the greedy
/// start is poor, so the exchange does real work.
fn skewed_pool(seed: u64, k: usize, b: usize, n: usize) -> Vec<DMatrix<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mixing = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            1.0
        } else {
            0.8 * rng.sample::<f64, _>(StandardNormal)
        }
    });
    (0..k)
        .map(|_| {
            let scale = (1.5 * rng.sample::<f64, _>(StandardNormal)).exp();
            DMatrix::from_fn(b, n, |_, _| rng.sample::<f64, _>(StandardNormal) * scale) * &mixing
        })
        .collect()
}

/// Quadratic regression rows [1, x, x²] on 201 grid points of [−1, 1].
fn quadratic_pool() -> Vec<DMatrix<f64>> {
    (0..=200)
        .map(|k| {
            let x = -1.0 + k as f64 / 100.0;
            DMatrix::from_row_slice(1, 3, &[1.0, x, x * x])
        })
        .collect()
}

fn relative_gap(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1.0)
}

fn assert_matches_naive(pool: &[DMatrix<f64>], options: &SelectionOptions) -> usize {
    let fast = select(pool, options).unwrap();
    let naive = select_naive(pool, options).unwrap();
    assert!(
        fast.indices == naive.indices || relative_gap(fast.log_det, naive.log_det) < 1e-9,
        "{:?}: fast {:?} ({}) vs naive {:?} ({})",
        options.criterion,
        fast.indices,
        fast.log_det,
        naive.indices,
        naive.log_det
    );
    assert!(
        (fast.log_det - log_det(pool, &fast.indices)).abs() < 1e-9 * fast.log_det.abs().max(1.0)
    );
    if fast.indices == naive.indices {
        // Same decisions all the way: same path.
        assert_eq!(
            (fast.sweeps, fast.exchanges, fast.excursions),
            (naive.sweeps, naive.exchanges, naive.excursions)
        );
    }
    fast.exchanges
}

#[test]
fn errors_name_what_is_missing() {
    let pool = random_pool(1, 5, 1, 3);
    assert_eq!(
        select(&pool, &options(6)),
        Err(SelectionError::TooFewCandidates {
            available: 5,
            requested: 6
        })
    );
    assert_eq!(
        select(&[], &options(6)),
        Err(SelectionError::TooFewCandidates {
            available: 0,
            requested: 6
        })
    );
    assert_eq!(
        select(&pool, &options(2)),
        Err(SelectionError::TooFewRows {
            poses: 2,
            rows: 2,
            n: 3
        })
    );
    // Replicates: more poses than candidates is fine.
    let replicated = select(
        &pool,
        &SelectionOptions {
            allow_replicates: true,
            ..options(6)
        },
    )
    .unwrap();
    assert_eq!(replicated.indices.len(), 6);
    // A duplicated column (p2 = 2·p0) cannot be identified from any design.
    let deficient: Vec<DMatrix<f64>> = random_pool(2, 50, 1, 3)
        .into_iter()
        .map(|c| DMatrix::from_row_slice(1, 4, &[c[0], c[1], 2.0 * c[0], c[2]]))
        .collect();
    for o in [
        options(10),
        SelectionOptions {
            criterion: Criterion::E,
            ..options(10)
        },
    ] {
        assert_eq!(
            select(&deficient, &o),
            Err(SelectionError::RankDeficient { rank: 3, n: 4 })
        );
        assert_eq!(
            select_naive(&deficient, &o),
            Err(SelectionError::RankDeficient { rank: 3, n: 4 })
        );
    }
    let mut mixed = random_pool(3, 5, 1, 3);
    mixed[3] = DMatrix::zeros(1, 4);
    assert!(matches!(
        select(&mixed, &options(3)),
        Err(SelectionError::ShapeMismatch { index: 3, .. })
    ));
    mixed[3] = DMatrix::from_row_slice(1, 3, &[0.0, f64::NAN, 1.0]);
    assert_eq!(
        select(&mixed, &options(3)),
        Err(SelectionError::NonFinite { index: 3 })
    );
    let message = SelectionError::RankDeficient { rank: 3, n: 4 }.to_string();
    assert!(!message.contains('\n') && message.contains("rank 3"));
}

#[test]
fn the_selection_is_deterministic_and_distinct() {
    let pool = random_pool(11, 150, 1, 6);
    let a = select(&pool, &options(18)).unwrap();
    assert_eq!(a, select(&pool, &options(18)).unwrap());
    let mut distinct = a.indices.clone();
    distinct.dedup();
    assert_eq!(distinct, a.indices);
    assert!(a.sweeps >= 1 && a.sweeps <= 50);
    // Exact copies of a candidate: ties go to the lowest index.
    let mut copies = quadratic_pool();
    copies.push(copies[200].clone());
    let s = select(&copies, &options(3)).unwrap();
    assert_eq!(s.indices, vec![0, 100, 200]);
}

#[test]
fn log_det_of_a_design() {
    let pool: Vec<DMatrix<f64>> = [[2.0, 0.0], [0.0, 3.0], [1.0, 1.0]]
        .iter()
        .map(|r| DMatrix::from_row_slice(1, 2, r))
        .collect();
    assert!((log_det(&pool, &[0, 1]) - 36f64.ln()).abs() < 1e-12);
    assert!((log_det(&pool, &[0, 1, 2]) - (5.0f64 * 10.0 - 1.0).ln()).abs() < 1e-12);
    assert!(log_det(&pool, &[0]).is_infinite() && log_det(&pool, &[0]) < 0.0);
    assert!(log_det(&pool, &[0, 0]).is_infinite());
}

#[test]
fn candidates_as_columns_select_as_candidate_matrices() {
    for (seed, b, n, count) in [(51, 1, 6, 10), (52, 2, 5, 6)] {
        let candidates = skewed_pool(seed, 300, b, n);
        let mut columns = DMatrix::zeros(n, 300 * b);
        for (j, c) in candidates.iter().enumerate() {
            for r in 0..b {
                for p in 0..n {
                    columns[(p, j * b + r)] = c[(r, p)];
                }
            }
        }
        assert_eq!(
            select_columns(columns, b, &options(count)),
            select(&candidates, &options(count)),
            "seed {seed}"
        );
    }
}

#[test]
fn bad_columns_are_refused_like_bad_candidates() {
    let o = options(3);
    let mut columns = DMatrix::from_fn(3, 40, |p, j| ((p + 1) * (j + 2)) as f64 % 7.0 + 0.5);
    assert_eq!(
        select_columns(columns.clone(), 3, &o),
        Err(SelectionError::ShapeMismatch {
            index: 13,
            rows: 1,
            cols: 3,
            expected_rows: 3,
            expected_cols: 3
        })
    );
    columns[(1, 25)] = f64::NAN;
    assert_eq!(
        select_columns(columns.clone(), 2, &o),
        Err(SelectionError::NonFinite { index: 12 })
    );
    assert_eq!(
        select_columns(DMatrix::zeros(3, 0), 1, &o),
        Err(SelectionError::TooFewCandidates {
            available: 0,
            requested: 3
        })
    );
    assert_eq!(
        select_columns(DMatrix::zeros(0, 5), 1, &o),
        Err(SelectionError::Empty { rows: 1, cols: 0 })
    );
}

#[test]
fn the_rank_of_a_pool_of_many_rows_is_found_from_its_triangular_factor() {
    // 5000 rows (more than are decomposed at once): parameter 3 = parameter 0 + parameter 1
    // at every candidate is rank 3 of 4; perturbing one row restores full rank.
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut candidates: Vec<DMatrix<f64>> = (0..5000)
        .map(|_| {
            let (a, b, c): (f64, f64, f64) = (
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
            );
            DMatrix::from_row_slice(1, 4, &[a, 1e3 * b, c, a + 1e3 * b])
        })
        .collect();
    assert_eq!(
        select(&candidates, &options(6)),
        Err(SelectionError::RankDeficient { rank: 3, n: 4 })
    );
    candidates[4321][(0, 3)] += 0.5;
    assert!(select(&candidates, &options(6)).is_ok());
}

/// The rank is that of the parameters scaled to unit norm: parameters of magnitudes 1e-8 and
/// 1e8 are independent (unscaled, the small one is below the rank tolerance); a parameter that
/// is zero at every candidate is one rank short, and so is every pool of zeros.
#[test]
fn the_rank_is_that_of_the_parameters_scaled_to_unit_norm() {
    let candidates: Vec<DMatrix<f64>> = random_pool(71, 40, 1, 3)
        .into_iter()
        .map(|c| DMatrix::from_row_slice(1, 3, &[1e-8 * c[0], c[1], 1e8 * c[2]]))
        .collect();
    assert!(select(&candidates, &options(6)).is_ok());
    let with_zero: Vec<DMatrix<f64>> = candidates
        .iter()
        .map(|c| DMatrix::from_row_slice(1, 4, &[c[0], 0.0, c[1], c[2]]))
        .collect();
    assert_eq!(
        select(&with_zero, &options(6)),
        Err(SelectionError::RankDeficient { rank: 3, n: 4 })
    );
    assert_eq!(
        select(&vec![DMatrix::zeros(1, 3); 10], &options(6)),
        Err(SelectionError::RankDeficient { rank: 0, n: 3 })
    );
}

/// The rank tolerance is relative to the largest scaled singular value: parameters u and
/// u + εv (u ⟂ v, unit norms) have scaled singular values √2 and ε/√2 to first order, so they
/// are one rank short for ε below 2e-8 (ratio 1e-8) and independent above.
#[test]
fn the_pools_rank_tolerance_is_relative_to_its_largest_singular_value() {
    let (u, v) = ([0.5, 0.5, 0.5, 0.5], [0.5, -0.5, 0.5, -0.5]);
    let pool = |epsilon: f64| -> Vec<DMatrix<f64>> {
        (0..4)
            .map(|i| DMatrix::from_row_slice(1, 2, &[u[i], u[i] + epsilon * v[i]]))
            .collect()
    };
    assert_eq!(
        select(&pool(1.5e-8), &options(2)),
        Err(SelectionError::RankDeficient { rank: 1, n: 2 })
    );
    assert!(select(&pool(2.5e-8), &options(2)).is_ok());
}

/// A design's rank in the error for a singular selection: of its own rows, scaled.
#[test]
fn a_singular_design_reports_the_rank_of_its_rows() {
    let candidates: Vec<DMatrix<f64>> = random_pool(72, 30, 1, 4)
        .into_iter()
        .map(|c| DMatrix::from_row_slice(1, 4, &[c[0], 1e6 * c[1], c[2], 1e-6 * c[3]]))
        .collect();
    let pool = Pool::new(&candidates, &options(6)).unwrap();
    for (design, rank) in [(vec![0, 1, 2, 3, 4], 4), (vec![5, 6], 2), (vec![7], 1)] {
        assert_eq!(
            pool.singular(&design),
            SelectionError::SingularDesign { rank, n: 4 },
            "{design:?}"
        );
    }
}

/// Each entry point hands a pool to the engine its criterion and row structure call for, and
/// the selection names it: the engines agree on their selections, so only the name tells
/// which one ran (the benchmarks' and the tests' references depend on it).
#[test]
fn each_pool_goes_to_its_engine() {
    let o = |criterion| SelectionOptions {
        criterion,
        ..options(6)
    };
    let rows = random_pool(61, 40, 1, 4);
    let separable = block_diagonal_pool(62, 40, 2, 3);
    let dense = random_pool(63, 40, 2, 4);
    let engine = |selection: Result<Selection, SelectionError>| selection.unwrap().engine;
    assert_eq!(engine(select(&rows, &o(Criterion::D))), "rank-one D");
    assert_eq!(engine(select(&separable, &o(Criterion::D))), "separable D");
    assert_eq!(engine(select(&dense, &o(Criterion::D))), "block D");
    assert_eq!(
        engine(select_dense_blocks(&separable, &o(Criterion::D))),
        "block D"
    );
    assert_eq!(
        engine(select_dense_blocks(&rows, &o(Criterion::D))),
        "rank-one D"
    );
    for pool in [&rows, &dense] {
        assert_eq!(engine(select(pool, &o(Criterion::A))), "A");
        assert_eq!(engine(select(pool, &o(Criterion::E))), "E");
        assert_eq!(engine(select_dense_blocks(pool, &o(Criterion::E))), "E");
        assert_eq!(engine(select_naive(pool, &o(Criterion::D))), "naive");
    }
    let columns = DMatrix::from_fn(4, 40, |p, j| rows[j][(0, p)]);
    assert_eq!(
        engine(select_columns(columns, 1, &o(Criterion::D))),
        "rank-one D"
    );
}
