//! Identification speed, with stable benchmark ids (docs/benchmarks.md):
//! `identify_leg/{5r,3rpr,hexapod}/{lm,gn}` — one leg's solve (Levenberg–Marquardt and
//! Gauss–Newton on identical inputs: the model's simulated measurements of its first leg, 18
//! poses for the 5R, 24 for the hexapod's 8 parameters);
//! `strategy/{5r,3rpr}/{dc,traditional}` — the whole identification (rank check, solve,
//! statistics) by divide and conquer and by the traditional all-legs problem, on identical
//! shared poses;
//! `identify_leg/5r/{floor_solver,floor_fixed}` — the floor of the 5R leg's fit on the same
//! rows: the leg written by hand in closed form (benches/reference/closed_form_leg.rs), solved
//! by legwise's `solve` and by a fixed-size Levenberg–Marquardt (each checked to land on
//! `identify_leg/5r/lm`'s estimate before it is timed); `identify_leg/5r/{rows,rows_gradients}`
//! — one evaluation of the same 18 rows through legwise's own leg path (the leg prepared at
//! the parameters, each row's warm-started closed-form solve and its reading, with the
//! gradient for the second), what a solve repeats at every evaluation.
//! Run: `cargo bench --bench identify`; `benches/scipy_leg.py` compares
//! `identify_leg/5r/lm` with scipy on the same poses.
use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::jacobian::PreparedLeg;
use legwise::identify::problem::IdentificationProblem;
use legwise::kinematics::chain::platform_transform_f64;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use legwise::solver::{solve, SolverKind};
use nalgebra::DVector;

#[path = "reference/closed_form_leg.rs"]
mod closed_form_leg;
use closed_form_leg::{fixed_size_lm, ClosedFormLeg, NOMINAL};

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
        if name == "5r.yaml" {
            floor(&mut group, &problem, data.leg_blocks(0));
        }
        group.finish();
    }
}

/// The 5R leg's floor benches (`floor_solver`, `floor_fixed`), after checking that both land
/// on the identification's estimate (relative 1e-9: the stopping rules differ).
fn floor(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    problem: &IdentificationProblem<'_>,
    blocks: Vec<legwise::measure::ResidualBlock>,
) {
    let leg = ClosedFormLeg {
        rows: blocks
            .iter()
            .map(|b| (b.pose[0], b.pose[1], b.reading))
            .collect(),
    };
    let start = DVector::from_column_slice(&NOMINAL);
    let reference = solve(problem, problem.start(), SolverKind::LevenbergMarquardt)
        .expect("solves")
        .x;
    let by_solver = solve(&leg, start.clone(), SolverKind::LevenbergMarquardt)
        .expect("solves")
        .x;
    let fixed = DVector::from_column_slice(&fixed_size_lm(&leg.rows, NOMINAL));
    for (name, estimate) in [("floor_solver", &by_solver), ("floor_fixed", &fixed)] {
        let gap = (estimate - &reference).amax() / reference.amax();
        assert!(
            gap < 1e-9,
            "{name} lands {gap:e} away from the identification"
        );
    }
    group.bench_function("floor_solver", |b| {
        b.iter(|| {
            solve(
                black_box(&leg),
                start.clone(),
                SolverKind::LevenbergMarquardt,
            )
            .expect("solves")
        })
    });
    group.bench_function("floor_fixed", |b| {
        b.iter(|| fixed_size_lm(black_box(&leg.rows), NOMINAL))
    });
    rows(group, problem.mechanism(), &blocks);
}

/// `rows` and `rows_gradients`: one evaluation of leg 0's `blocks` at the nominal parameters
/// through [`PreparedLeg`], each row warm-started from its own last solution.
fn rows(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    mechanism: &legwise::Mechanism,
    blocks: &[legwise::measure::ResidualBlock],
) {
    let leg = &mechanism.legs[0];
    let (phi, identified, home) = (leg.nominal(), leg.identified(), mechanism.home_pose);
    let mut seeds = vec![None; blocks.len()];
    let mut gradient = vec![0.0; identified.len()];
    let mut evaluate = |columns: &[usize]| {
        let prepared = PreparedLeg::new(leg, &phi, columns);
        let mut sum = 0.0;
        for (block, seed) in blocks.iter().zip(seeds.iter_mut()) {
            let platform = platform_transform_f64(&block.pose);
            let solution = prepared
                .solve_warm_on(&platform, &block.pose, &home, seed.as_ref())
                .expect("reaches");
            sum += match columns.is_empty() {
                true => prepared.reading_of(&solution),
                false => prepared.reading_and_gradient_on(&platform, &solution, &mut gradient),
            };
            *seed = Some(solution.q);
        }
        sum
    };
    evaluate(&[]);
    group.bench_function("rows", |b| b.iter(|| evaluate(black_box(&[]))));
    group.bench_function("rows_gradients", |b| {
        b.iter(|| evaluate(black_box(&identified)))
    });
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
