//! Identification speed, with stable benchmark ids (docs/benchmarks.md):
//! `identify_leg/{5r,3rpr,hexapod}/{lm,gn}` — one leg's solve (Levenberg–Marquardt and
//! Gauss–Newton on identical inputs: the model's simulated measurements of its first leg, 18
//! poses for the 5R, 24 for the hexapod's 8 parameters);
//! `strategy/{5r,3rpr}/{dc,traditional}` — the whole identification (rank check, solve,
//! statistics) by divide and conquer and by the traditional all-legs problem, on identical
//! shared poses.
//! Run: `cargo bench --bench identify`; `benches/scipy_leg.py` compares
//! `identify_leg/5r/lm` with scipy on the same poses.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use legwise::solver::{solve, SolverKind};

fn model(name: &str) -> Mechanism {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    Mechanism::load(&path).expect("bundled model")
}

fn solvers(c: &mut Criterion) {
    for name in ["5r.yaml", "3rpr.yaml", "hexapod.yaml"] {
        let mechanism = model(name);
        let data = simulate(&mechanism, SimulationOptions::default())
            .expect("simulation")
            .measurements;
        let problem = IdentificationProblem::new(&mechanism, &[0], data.leg_blocks(0));
        let mut group =
            c.benchmark_group(format!("identify_leg/{}", name.trim_end_matches(".yaml")));
        for kind in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
            group.bench_function(kind.short_name(), |b| {
                b.iter(|| solve(black_box(&problem), problem.start(), kind).expect("solves"))
            });
        }
        group.finish();
    }
}

fn strategies(c: &mut Criterion) {
    for name in ["5r.yaml", "3rpr.yaml"] {
        let mechanism = model(name);
        let data = simulate(&mechanism, SimulationOptions::default())
            .expect("simulation")
            .measurements;
        let shared = data.filtered(|p, _| p.leg.is_none());
        let mut group = c.benchmark_group(format!("strategy/{}", name.trim_end_matches(".yaml")));
        for (label, strategy) in [
            ("dc", Strategy::DivideAndConquer),
            ("traditional", Strategy::Traditional),
        ] {
            group.bench_function(label, |b| {
                b.iter(|| {
                    identify(
                        &mechanism,
                        black_box(&shared),
                        strategy,
                        SolverKind::GaussNewton,
                    )
                    .expect("identifies")
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, solvers, strategies);
criterion_main!(benches);
