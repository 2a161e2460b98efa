//! Identification through the instrument against plain divide and conquer, with stable ids:
//! `instrument/{5r,3rpr}/dc` — the whole plain identification (rank check, solve, statistics)
//! of the model's legs from the true platform poses (as if the instrument were registered
//! perfectly); `instrument/{5r,3rpr}/joint` — the legs and the instrument together from the
//! targets' coordinates (rank check, Schur-complement solve, σ, χ² test);
//! `instrument/{5r,3rpr}/two_stage` — the instrument registered first, then the legs.
//! Same simulated rows (the tracker models' simulation, noise scale 1) for all three.
//! Run: `cargo bench --bench instrument`.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::shared_estimate::identify_shared;
use legwise::measure::observe_simulate::simulate_observed;
use legwise::measure::simulate::SimulationOptions;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;
use legwise::FitOptions;

fn model(name: &str) -> Mechanism {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    Mechanism::load(&path).expect("bundled model")
}

fn instrument(c: &mut Criterion) {
    for name in ["5r", "3rpr"] {
        let mechanism = model(&format!("{name}-tracker.yaml"));
        let experiment =
            simulate_observed(&mechanism, SimulationOptions::default()).expect("simulation");
        let mut group = c.benchmark_group(format!("instrument/{name}"));
        group.bench_function("dc", |b| {
            b.iter(|| {
                identify(
                    black_box(&mechanism),
                    &experiment.poses,
                    Strategy::DivideAndConquer,
                    SolverKind::LevenbergMarquardt,
                )
                .expect("identifies")
            })
        });
        for (id, strategy) in [
            ("joint", Strategy::Joint),
            ("two_stage", Strategy::TwoStage),
        ] {
            group.bench_function(id, |b| {
                b.iter(|| {
                    identify_shared(
                        black_box(&mechanism),
                        &experiment.observations,
                        strategy,
                        FitOptions::default(),
                    )
                    .expect("identifies")
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, instrument);
criterion_main!(benches);
