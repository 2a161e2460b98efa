//! Pose selection with rank-one / block updates (`select`) against the same greedy + exchange
//! with a from-scratch log det per trial (`select_naive`), on identification rows of the
//! planar 5R (docs/method.md §9) at random poses of the f = 0.95 workspace disc (§8).
//!
//! Run with `cargo bench --bench pose_selection` (set `POSE_SELECTION_COMPARE=1` to print both
//! selections first). Ids: `select/5r/rank_one` and `select/5r/naive` (one leg, 6 parameters,
//! K = 3000 candidates, N = 18), `select/5r/block` (both legs stacked, 2 × 12 blocks, K = 3000,
//! the dense block engine), `select/5r/block_k1000` and `select/5r/block_naive_k1000`
//! (K = 1000). The traditional design of a bundled model from its own candidate pool, with the
//! separable engine that `select` picks for it and with the dense block engine forced:
//! `select/5r/traditional`, `select/5r/traditional_dense`, `select/hexapod/traditional`,
//! `select/hexapod/traditional_dense`. A forward model's rows (3 a candidate, 45 unknowns) on
//! a coarser grid than its own (3375 candidates), D against E, the pool built each time:
//! `select/hexapod-reflector/d`, `select/hexapod-reflector/e`.
//!
//! # Reference
//! docs/method.md §6 (the greedy and exchange phases and their rank-one updates).
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::model::mechanism::SelectionCriterion;
use legwise::model::Mechanism;
use legwise::selection::candidates::{candidate_pool, CandidatePool};
use legwise::selection::forward_design::select_forward;
use legwise::selection::{select, select_dense_blocks, select_naive, SelectionOptions};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// One leg of the nominal 5R: base joint (a_x, 0), gain k, offset γ, working mode σ and the
/// reference angle θ_ref used to unwrap θ (docs/method.md §2.2, §9).
struct Leg {
    a_x: f64,
    k: f64,
    gamma: f64,
    sigma: f64,
    theta_ref: f64,
}

const PSI_REF: f64 = 2.2529;
const LEGS: [Leg; 2] = [
    Leg {
        a_x: -0.5,
        k: 1.0,
        gamma: 0.0,
        sigma: 1.0,
        theta_ref: PSI_REF,
    },
    Leg {
        a_x: 0.5,
        k: -1.0,
        gamma: PI,
        sigma: -1.0,
        theta_ref: PI - PSI_REF,
    },
];

/// Identification row ∂ψ/∂[l, L, A_x, A_y, k, γ] of `leg` at the end-effector point (x, y)
/// (docs/method.md §9, nominal parameters l = 0.75, L = 1.10, A_y = 0).
fn leg_row(leg: &Leg, x: f64, y: f64) -> [f64; 6] {
    let (l, big_l) = (0.75, 1.10);
    let (dx, dy) = (x - leg.a_x, y);
    let rho = dx.hypot(dy);
    let c = (rho * rho + l * l - big_l * big_l) / (2.0 * l * rho);
    let raw = dy.atan2(dx) + leg.sigma * c.acos();
    let wrapped = (raw - leg.theta_ref + PI).rem_euclid(2.0 * PI) - PI;
    let theta = leg.theta_ref + wrapped;
    let psi = (theta - leg.gamma) / leg.k;
    let (u, v) = (x - l * theta.cos() - leg.a_x, y - l * theta.sin());
    let d = l * (u * theta.sin() - v * theta.cos());
    [
        (u * theta.cos() + v * theta.sin()) / d / leg.k,
        big_l / d / leg.k,
        u / d / leg.k,
        v / d / leg.k,
        -psi / leg.k,
        -1.0 / leg.k,
    ]
}

/// `k` seeded random points of the disc of centre (0, 1.0956522), radius 0.95 · 0.6456522.
fn poses(k: usize, seed: u64) -> Vec<(f64, f64)> {
    let (centre, radius) = ((0.0, 1.095_652_2), 0.95 * 0.645_652_2);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut points = Vec::with_capacity(k);
    while points.len() < k {
        let (u, v): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        if u * u + v * v <= 1.0 {
            points.push((centre.0 + radius * u, centre.1 + radius * v));
        }
    }
    points
}

/// One row per candidate (leg 1, divide and conquer: 6 parameters).
fn leg_pool(points: &[(f64, f64)]) -> Vec<DMatrix<f64>> {
    points
        .iter()
        .map(|&(x, y)| DMatrix::from_row_slice(1, 6, &leg_row(&LEGS[0], x, y)))
        .collect()
}

/// One block-diagonal 2 × 12 matrix per candidate (traditional strategy, both legs).
fn stacked_pool(points: &[(f64, f64)]) -> Vec<DMatrix<f64>> {
    points
        .iter()
        .map(|&(x, y)| {
            let mut c = DMatrix::zeros(2, 12);
            for (i, leg) in LEGS.iter().enumerate() {
                for (j, value) in leg_row(leg, x, y).into_iter().enumerate() {
                    c[(i, 6 * i + j)] = value;
                }
            }
            c
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    // The generator reproduces the golden row of docs/method.md §9 at the disc centre.
    let golden = [
        -0.2653426423,
        1.3594794944,
        1.2022875474,
        0.6345779299,
        -2.2528832244,
        -1.0,
    ];
    let row = leg_row(&LEGS[0], 0.0, 1.095_652_2);
    assert!(
        row.iter().zip(golden).all(|(a, b)| (a - b).abs() < 1e-6),
        "{row:?}"
    );

    let options = SelectionOptions {
        count: 18,
        ..Default::default()
    };
    let leg = leg_pool(&poses(3000, 1));
    let stacked = stacked_pool(&poses(3000, 2));
    let stacked_small = stacked_pool(&poses(1000, 3));
    // With POSE_SELECTION_COMPARE set: check that both give the same design, and print it.
    let pools = [
        ("leg", &leg),
        ("stacked", &stacked),
        ("stacked", &stacked_small),
    ];
    for (name, pool) in pools
        .into_iter()
        .filter(|_| std::env::var_os("POSE_SELECTION_COMPARE").is_some())
    {
        let (fast, naive) = (
            select(pool, &options).unwrap(),
            select_naive(pool, &options).unwrap(),
        );
        println!(
            "{name} K = {}: log det {:.9} (naive {:.9}), same set: {}, sweeps {}, exchanges {}, \
             excursions {}, certificate {:.3}",
            pool.len(),
            fast.log_det,
            naive.log_det,
            fast.indices == naive.indices,
            fast.sweeps,
            fast.exchanges,
            fast.excursions,
            fast.certificate
        );
    }

    // Stable ids: select/5r/rank_one (one leg, one row per candidate, rank-one updates) and
    // select/5r/naive (the same algorithm, every trial design from scratch), side by side.
    let mut group = c.benchmark_group("select");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(3));
    group.bench_function("5r/rank_one", |b| {
        b.iter(|| select(black_box(&leg), &options).unwrap())
    });
    // The stacked pools are separable: the dense block engine is forced, as these ids measure it.
    group.bench_function("5r/block", |b| {
        b.iter(|| select_dense_blocks(black_box(&stacked), &options).unwrap())
    });
    group.bench_function("5r/block_k1000", |b| {
        b.iter(|| select_dense_blocks(black_box(&stacked_small), &options).unwrap())
    });
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    group.bench_function("5r/naive", |b| {
        b.iter(|| select_naive(black_box(&leg), &options).unwrap())
    });
    group.bench_function("5r/block_naive_k1000", |b| {
        b.iter(|| select_naive(black_box(&stacked_small), &options).unwrap())
    });
    group.finish();
}

/// The hexapod: its candidate pool (a 6-D grid with orientation levels, each candidate's legs
/// solved and screened for singularities) and one leg's selection of 24 poses from it (8
/// parameters, one row per candidate). Ids: `candidates/hexapod`, `select/hexapod/rank_one`.
fn hexapod(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/hexapod.yaml");
    let mechanism = Mechanism::load(&path).expect("bundled model");
    let pool = candidate_pool(&mechanism, None).expect("candidate pool");
    let rows: Vec<DMatrix<f64>> = pool
        .candidates
        .iter()
        .map(|candidate| {
            DMatrix::from_row_slice(1, candidate.rows[0].len(), candidate.rows[0].as_slice())
        })
        .collect();
    println!(
        "hexapod: {} candidates, {} parameters",
        rows.len(),
        rows[0].ncols()
    );
    let options = SelectionOptions {
        count: 24,
        ..Default::default()
    };
    let mut group = c.benchmark_group("select");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(5));
    group.bench_function("hexapod/rank_one", |b| {
        b.iter(|| select(black_box(&rows), &options).unwrap())
    });
    group.finish();
    let mut group = c.benchmark_group("candidates");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    group.bench_function("hexapod", |b| {
        b.iter(|| candidate_pool(black_box(&mechanism), None).unwrap())
    });
    group.finish();
}

/// The traditional design's candidates: one block-diagonal matrix per candidate, row r the r-th
/// identified leg's row in the columns of that leg's parameters.
fn shared_blocks(mechanism: &Mechanism, pool: &CandidatePool) -> Vec<DMatrix<f64>> {
    let legs = mechanism.identified_legs();
    let n: usize = legs.iter().map(|&l| pool.candidates[0].rows[l].len()).sum();
    pool.candidates
        .iter()
        .map(|candidate| {
            let mut block = DMatrix::zeros(legs.len(), n);
            let mut offset = 0;
            for (r, &l) in legs.iter().enumerate() {
                for (p, &value) in candidate.rows[l].iter().enumerate() {
                    block[(r, offset + p)] = value;
                }
                offset += candidate.rows[l].len();
            }
            block
        })
        .collect()
}

/// The traditional (shared) design of the bundled models 5R and hexapod from their candidate
/// pools, N = the model's poses per leg: `select` (the separable engine) against the dense
/// block engine. Ids: `select/{5r,hexapod}/traditional` and `.../traditional_dense`.
fn traditional(c: &mut Criterion) {
    let mut group = c.benchmark_group("select");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(5));
    for name in ["5r", "hexapod"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(format!("{name}.yaml"));
        let mechanism = Mechanism::load(&path).expect("bundled model");
        let pool = candidate_pool(&mechanism, None).expect("candidate pool");
        let blocks = shared_blocks(&mechanism, &pool);
        let options = SelectionOptions {
            count: mechanism.selection.poses_per_leg,
            ..Default::default()
        };
        let (separable, dense) = (
            select(&blocks, &options).unwrap(),
            select_dense_blocks(&blocks, &options).unwrap(),
        );
        assert_eq!(separable.indices, dense.indices, "{name}");
        println!(
            "{name} traditional: {} candidates, {} × {} blocks, N = {}, the same selection",
            blocks.len(),
            blocks[0].nrows(),
            blocks[0].ncols(),
            options.count
        );
        group.bench_function(format!("{name}/traditional"), |b| {
            b.iter(|| select(black_box(&blocks), &options).unwrap())
        });
        group.bench_function(format!("{name}/traditional_dense"), |b| {
            b.iter(|| select_dense_blocks(black_box(&blocks), &options).unwrap())
        });
    }
    group.finish();
}

/// The hexapod seen by one tracker reflector (`models/hexapod-reflector.yaml`): 100 rows of
/// three coordinates from the candidate pool of a 0.05 m grid (3375 candidates, 45 unknowns),
/// by the D and the E criterion; `select_forward` builds the pool (the same for both) and
/// selects. Ids: `select/hexapod-reflector/d`, `select/hexapod-reflector/e`.
fn forward(c: &mut Criterion) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/hexapod-reflector.yaml");
    let mechanism = Mechanism::load(&path).expect("bundled model");
    let mut group = c.benchmark_group("select");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    for (name, criterion) in [("d", SelectionCriterion::D), ("e", SelectionCriterion::E)] {
        group.bench_function(format!("hexapod-reflector/{name}"), |b| {
            b.iter(|| select_forward(black_box(&mechanism), Some(0.05), 100, criterion).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, bench, hexapod, traditional, forward);
criterion_main!(benches);
