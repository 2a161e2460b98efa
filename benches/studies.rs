//! One Monte Carlo trial of the bundled 5R: a real mechanism and noise drawn, three strategies
//! identified (D&C, traditional, traditional at an equal number of poses) and four accuracy maps
//! on the 5 cm grid (nominal and each result). 10 000 trials on 2 cores take about
//! 10 000 × (this median) / 2. Run: `cargo bench --bench studies`.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::model::Mechanism;
use legwise::study::montecarlo::{MonteCarloOptions, Study};

fn montecarlo(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
    let mechanism = Mechanism::load(&path).expect("bundled model");
    let study = Study::prepare(&mechanism, MonteCarloOptions::new(1, 2010)).expect("study");
    let mut group = c.benchmark_group("montecarlo/5r");
    let mut index = 0;
    group.bench_function("trial", |b| {
        b.iter(|| {
            index += 1;
            let trial = study.trial(black_box(index));
            assert!(trial.outcome.is_ok(), "trial {index}: {:?}", trial.outcome);
            trial
        })
    });
    group.finish();
}

criterion_group!(benches, montecarlo);
criterion_main!(benches);
