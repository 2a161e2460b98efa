//! Levenberg–Marquardt against Gauss–Newton: how far from the truth can a fit start?
//!
//! For each bundled model, each leg is identified (divide and conquer, the model's selected
//! poses and noise) from seeded starts 1×, 10× and 100× further from the real parameters than
//! the model's perturbation: `x₀ = real + f · σ ∘ z`, `z ~ N(0, I)`, where σ is the declared
//! perturbation (`simulation.perturbation`) or, for a model that declares its real values,
//! `|real − nominal|` per parameter. A start succeeds when the solver reports convergence *and*
//! lands on the reference minimum (the fit from the nominal values) to 1e-6 relative. A start
//! whose residuals cannot be evaluated (a leg that cannot reach a pose) fails for both solvers
//! and is counted apart; a solve that ends in an error (a step left the reachable parameters)
//! counts as diverged. Times are of the solves that ran (median).
//!
//! Run: `cargo run --release --example lm_vs_gn [-- STARTS]` (default 200 starts per leg and
//! factor). Prints a Markdown table.

use std::path::Path;
use std::time::Instant;

use legwise::identify::problem::IdentificationProblem;
use legwise::measure::simulate::{real_parameters, setup, simulate_at, SimulationOptions};
use legwise::model::params::{ParamTarget, Unit};
use legwise::model::Mechanism;
use legwise::selection::design::ExperimentDesign;
use legwise::solver::{solve, SolverKind};
use legwise::study::stats::proportion_interval;
use nalgebra::DVector;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

const FACTORS: [f64; 3] = [1.0, 10.0, 100.0];
const SOLVERS: [SolverKind; 2] = [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton];

#[derive(Default)]
struct Tally {
    starts: usize,
    succeeded: usize,
    reported_converged: usize,
    not_evaluable: usize,
    diverged: usize,
    iterations: Vec<f64>,
    seconds: Vec<f64>,
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// Per identified parameter of `leg`: the scale of the model's perturbation.
fn perturbation_scale(mechanism: &Mechanism, leg: usize, real: &[f64]) -> Vec<f64> {
    let model = &mechanism.legs[leg];
    let declared = mechanism.simulation.as_ref().and_then(|s| s.perturbation);
    model
        .identified()
        .into_iter()
        .map(|c| {
            let p = &model.params[c];
            match declared {
                Some((length, angle, gain)) => match (p.target, p.unit) {
                    (ParamTarget::Gain, _) => gain,
                    (_, Unit::Radian) => angle,
                    _ => length,
                },
                None => (real[c] - p.nominal).abs().max(1e-6),
            }
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let starts: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(200);
    println!("| model | start distance | solver | success rate [95 % CI] | solver-reported convergence | not evaluable at start | solver error (diverged) | median iterations | median time per fit |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for name in ["5r.yaml", "3rpr.yaml"] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(name);
        let mechanism = Mechanism::load(&path)?;
        let simulation = setup(&mechanism)?;
        let count = mechanism.selection.poses_per_leg;
        let design = ExperimentDesign::select(
            &mechanism,
            None,
            count,
            mechanism.selection.criterion,
            false,
        )?;
        let experiment = simulate_at(
            &mechanism,
            &design.pose_sets(),
            SimulationOptions::default(),
        )?;
        let real = real_parameters(&mechanism, simulation, simulation.seed);
        for (f, &factor) in FACTORS.iter().enumerate() {
            let mut tallies: Vec<Tally> = SOLVERS.iter().map(|_| Tally::default()).collect();
            for leg in mechanism.identified_legs() {
                let blocks = experiment.measurements.leg_blocks(leg);
                let problem = IdentificationProblem::new(&mechanism, &[leg], blocks);
                let reference = solve(&problem, problem.start(), SolverKind::LevenbergMarquardt)?;
                let columns = mechanism.legs[leg].identified();
                let truth =
                    DVector::from_iterator(columns.len(), columns.iter().map(|&c| real[leg][c]));
                let sigma = perturbation_scale(&mechanism, leg, &real[leg]);
                for start in 0..starts {
                    let seed = ((f as u64) << 48) ^ ((leg as u64) << 32) ^ start as u64;
                    let mut rng = ChaCha8Rng::seed_from_u64(seed);
                    let x0 = DVector::from_iterator(
                        truth.len(),
                        truth.iter().zip(&sigma).map(|(t, s)| {
                            let z: f64 = StandardNormal.sample(&mut rng);
                            t + factor * s * z
                        }),
                    );
                    let evaluable = problem.residuals(&x0).is_ok();
                    for (solver, tally) in SOLVERS.iter().zip(tallies.iter_mut()) {
                        tally.starts += 1;
                        if !evaluable {
                            tally.not_evaluable += 1;
                            continue;
                        }
                        let clock = Instant::now();
                        let outcome = solve(&problem, x0.clone(), *solver);
                        let seconds = clock.elapsed().as_secs_f64();
                        let Ok(outcome) = outcome else {
                            tally.diverged += 1;
                            continue;
                        };
                        tally.seconds.push(seconds);
                        tally.iterations.push(outcome.iterations as f64);
                        if outcome.converged {
                            tally.reported_converged += 1;
                        }
                        let distance = (&outcome.x - &reference.x).amax();
                        let finite = outcome.x.iter().all(|v| v.is_finite());
                        if outcome.converged
                            && finite
                            && distance <= 1e-6 * (1.0 + reference.x.amax())
                        {
                            tally.succeeded += 1;
                        }
                    }
                }
            }
            for (solver, tally) in SOLVERS.iter().zip(tallies.iter_mut()) {
                let rate = proportion_interval(tally.succeeded, tally.starts);
                println!(
                    "| {} | {}× | {} | {:.1} % [{:.1}, {:.1}] ({}/{}) | {:.1} % | {} | {} | {} | {:.3} ms |",
                    name.trim_end_matches(".yaml"),
                    factor,
                    solver.short_name().to_uppercase(),
                    100.0 * rate.value,
                    100.0 * rate.low,
                    100.0 * rate.high,
                    tally.succeeded,
                    tally.starts,
                    100.0 * tally.reported_converged as f64 / tally.starts as f64,
                    tally.not_evaluable,
                    tally.diverged,
                    median(&mut tally.iterations),
                    1e3 * median(&mut tally.seconds)
                );
            }
        }
    }
    Ok(())
}
