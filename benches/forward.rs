//! Identification from partial observations through the forward kinematics against the inverse
//! identifications of the same mechanisms, with stable ids (docs/benchmarks.md):
//! `forward/{delta_probe,delta_probe_distances,hexapod_reflector}/lm` — the joint
//! Levenberg–Marquardt fit of the forward model's simulated rows exactly as `legwise identify`
//! runs it (`pipeline::identify_one`: rank check, solve, statistics, the held-frame test and
//! the predicted position σ over the workspace); `forward/{delta_probe,hexapod_reflector}/solve`
//! — the bare bordered solve from the nominal parameters on a fresh problem (its warm starts
//! and evaluation cache new, as in `identify_one`; the problem is built outside the timing);
//! `forward/{delta,hexapod}_inverse/dc` — divide and conquer of `delta.yaml` and
//! `hexapod.yaml` from their measured poses; `forward/{delta,hexapod}_tracker/joint` — the
//! joint fit of the tracker models (`delta-tracker.yaml`, `hexapod-tracker.yaml`), both also
//! by `identify_one`. Every model's data is simulated once, outside the timed loop, at random
//! poses with noise scale 1 (`pipeline::simulate`).
//! Run: `cargo bench --bench forward -- --warm-up-time 1 --measurement-time 3`.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::Strategy;
use legwise::measure::simulate::SimulationOptions;
use legwise::pipeline::{identify_one, simulate, PoseSource, SimulationSettings};
use legwise::solver::{solve_bordered, SolverKind};
use legwise::{FitOptions, Measurements, Mechanism};

/// A bundled model.
fn model(name: &str) -> Mechanism {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    Mechanism::load(&path).expect("bundled model")
}

/// The model's simulated measurements: random poses, the declared noise (scale 1).
fn simulated(mechanism: &Mechanism) -> Measurements {
    let settings = SimulationSettings {
        options: SimulationOptions {
            noise_scale: 1.0,
            ..Default::default()
        },
        poses: PoseSource::Random,
        grid: None,
    };
    simulate(mechanism, &settings)
        .expect("simulation")
        .measurements
}

/// Benches `identify_one` of `name`'s simulated data with `strategy` as `group/id`, and with
/// `solve` also the bare bordered solve as `group/solve`.
fn fit(c: &mut Criterion, (group, id): (&str, &str), name: &str, strategy: Strategy, solve: bool) {
    let mechanism = model(name);
    let data = simulated(&mechanism);
    let mut group = c.benchmark_group(group);
    group.bench_function(id, |b| {
        b.iter(|| {
            identify_one(
                black_box(&mechanism),
                black_box(&data),
                strategy,
                SolverKind::LevenbergMarquardt,
                FitOptions::default(),
            )
            .expect("identifies")
        })
    });
    if solve {
        let Measurements::Targets(observations) = &data else {
            panic!("{name}: a forward model's data are the targets' coordinates");
        };
        group.bench_function("solve", |b| {
            b.iter_batched(
                || {
                    IdentificationProblem::through_instrument(&mechanism, observations)
                        .expect("problem")
                },
                |problem| solve_bordered(black_box(&problem), problem.start()).expect("solves"),
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

/// Every id of the file, in one run: the forward fits, then the inverse ones.
fn forward(c: &mut Criterion) {
    let joint = Strategy::Joint;
    let dc = Strategy::DivideAndConquer;
    fit(
        c,
        ("forward/delta_probe", "lm"),
        "delta-probe.yaml",
        joint,
        true,
    );
    let distances = ("forward/delta_probe_distances", "lm");
    fit(c, distances, "delta-probe-distances.yaml", joint, false);
    let reflector = ("forward/hexapod_reflector", "lm");
    fit(c, reflector, "hexapod-reflector.yaml", joint, true);
    fit(c, ("forward/delta_inverse", "dc"), "delta.yaml", dc, false);
    fit(
        c,
        ("forward/hexapod_inverse", "dc"),
        "hexapod.yaml",
        dc,
        false,
    );
    let tracker = ("forward/delta_tracker", "joint");
    fit(c, tracker, "delta-tracker.yaml", joint, false);
    let tracker = ("forward/hexapod_tracker", "joint");
    fit(c, tracker, "hexapod-tracker.yaml", joint, false);
}

criterion_group!(benches, forward);
criterion_main!(benches);
