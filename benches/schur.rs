//! One damped Levenberg–Marquardt step of a bordered problem shaped like a planar n-RPR whose
//! legs share an instrument frame: per leg 6 own parameters (base joint x, y, attachment x, y,
//! actuator gain and offset) and 18 rows (one actuator reading per pose, 18 poses per leg, as
//! examples/scaling.rs generates them), plus 3 shared columns (a planar frame x, y, yaw).
//! Random blocks of those sizes (seeded): the cost of a step does not depend on the values.
//!
//! Ids: `schur_step/legs/{2..8}` — the step by the Schur complement on the shared block
//! ([`ArrowheadSystem`]: per-leg normal blocks, each leg's Cholesky, the reduced 3 × 3 system);
//! `dense_step/legs/{2..8}` — the same damped normal equations assembled densely
//! ([`to_dense`], `JᵀJ`) and solved by one Cholesky factorisation. Both start from the blocks
//! and return the step.
//!
//! Run: `nice -n 10 cargo bench --bench schur` (results in docs/benchmarks.md).
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use legwise::solver::bordered::{to_dense, BorderedBlock, BorderedLayout};
use legwise::solver::schur::arrowhead::ArrowheadSystem;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const OWN_PER_LEG: usize = 6;
const ROWS_PER_LEG: usize = 18;
const SHARED: usize = 3;
const LAMBDA: f64 = 1e-3;

fn problem(legs: usize) -> (BorderedLayout, Vec<BorderedBlock>, DVector<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(legs as u64);
    let mut entry = || rng.random_range(-1.0..1.0);
    let layout = BorderedLayout {
        own: vec![OWN_PER_LEG; legs],
        shared: SHARED,
    };
    let blocks = (0..legs)
        .map(|_| BorderedBlock {
            residuals: DVector::from_fn(ROWS_PER_LEG, |_, _| entry()),
            own: DMatrix::from_fn(ROWS_PER_LEG, OWN_PER_LEG, |_, _| entry()),
            shared: DMatrix::from_fn(ROWS_PER_LEG, SHARED, |_, _| entry()),
        })
        .collect();
    let scale = DVector::from_element(layout.unknowns(), 1.0);
    (layout, blocks, scale)
}

fn schur_step(
    layout: &BorderedLayout,
    blocks: &[BorderedBlock],
    scale: &DVector<f64>,
) -> DVector<f64> {
    let system = ArrowheadSystem::assemble(layout, blocks).expect("blocks fit");
    system.damped_step(LAMBDA, scale).expect("regular")
}

fn dense_step(
    layout: &BorderedLayout,
    blocks: &[BorderedBlock],
    scale: &DVector<f64>,
) -> DVector<f64> {
    let (r, j) = to_dense(layout, blocks);
    let mut normal = j.tr_mul(&j);
    for (i, d) in scale.iter().enumerate() {
        normal[(i, i)] += LAMBDA * d * d;
    }
    normal
        .cholesky()
        .expect("positive definite")
        .solve(&j.tr_mul(&r))
}

fn steps(c: &mut Criterion) {
    // The two steps agree (tests/it/schur.rs checks this to 1e-10 on many shapes).
    for legs in 2..=8 {
        let (layout, blocks, scale) = problem(legs);
        let (a, b) = (
            schur_step(&layout, &blocks, &scale),
            dense_step(&layout, &blocks, &scale),
        );
        assert!((&a - &b).norm() <= 1e-10 * b.norm(), "{legs} legs");
    }
    for (name, step) in [
        ("schur_step", schur_step as fn(&_, &_, &_) -> _),
        ("dense_step", dense_step),
    ] {
        let mut group = c.benchmark_group(name);
        group.measurement_time(Duration::from_secs(2));
        for legs in 2..=8 {
            let (layout, blocks, scale) = problem(legs);
            group.bench_function(BenchmarkId::new("legs", legs), |b| {
                b.iter(|| step(black_box(&layout), black_box(&blocks), black_box(&scale)))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, steps);
criterion_main!(benches);
