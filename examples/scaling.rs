//! Divide and conquer against all legs at once as the mechanism grows: planar n-RPR mechanisms
//! with n = 2 … 8 legs (6 parameters per leg), generated as model files (YAML + URDF in a
//! temporary directory) and loaded through the normal loader, so that the mechanisms stay data.
//!
//! Leg i: base joint on a circle of radius 0.5 m at 90° + 360° i/n, platform attachment on a
//! circle of radius 0.2 m a quarter turn further, prismatic actuator with gain 1 and offset
//! 0.2 m; the 3-RPR's workspace, noise and perturbation. Each mechanism is simulated at
//! `poses_per_leg` random poses per leg (divide and conquer) and as many shared poses
//! (traditional): both strategies fit the same number of rows, n · poses_per_leg.
//!
//! Printed: the size of the normal matrix JᵀJ each strategy factorises (divide and conquer
//! Σ nᵢ² entries in n small matrices, all legs (Σ nᵢ)² in one), the median wall time of a whole
//! identification (rank check, solver, statistics) and of the solver runs alone, and the
//! iterations. Run: `cargo run --release --example scaling [-- REPEATS]` (default 51).

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use legwise::identify::estimate::{identify, Strategy, StrategyResult};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use legwise::solver::SolverKind;

const BASE_RADIUS: f64 = 0.5;
const PLATFORM_RADIUS: f64 = 0.2;

/// The URDF and the model file of the planar n-RPR.
fn model_files(n: usize) -> (String, String) {
    let mut urdf = format!(
        "<?xml version=\"1.0\"?>\n<!-- Generated planar {n}-RPR. -->\n<robot name=\"planar_{n}rpr\">\n  <link name=\"base\"/>\n"
    );
    let mut legs = String::new();
    let mut parameters = String::new();
    for i in 1..=n {
        let angle = std::f64::consts::FRAC_PI_2 + std::f64::consts::TAU * (i - 1) as f64 / n as f64;
        let a = [BASE_RADIUS * angle.cos(), BASE_RADIUS * angle.sin()];
        let b_angle = angle + std::f64::consts::FRAC_PI_2;
        let b = [
            PLATFORM_RADIUS * b_angle.cos(),
            PLATFORM_RADIUS * b_angle.sin(),
        ];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let _ = write!(
            urdf,
            "  <link name=\"strut{i}\"/><link name=\"slider{i}\"/>\n  <joint name=\"R{i}\" type=\"continuous\">\n    <parent link=\"base\"/><child link=\"strut{i}\"/>\n    <origin xyz=\"{:.10} {:.10} 0\" rpy=\"0 0 0\"/><axis xyz=\"0 0 1\"/>\n  </joint>\n  <joint name=\"P{i}\" type=\"prismatic\">\n    <parent link=\"strut{i}\"/><child link=\"slider{i}\"/>\n    <origin xyz=\"0 0 0\" rpy=\"0 0 0\"/><axis xyz=\"1 0 0\"/>\n    <limit lower=\"0.0\" upper=\"1.0\" effort=\"1000\" velocity=\"1\"/>\n  </joint>\n",
            a[0], a[1]
        );
        let _ = write!(
            legs,
            "  - name: leg{i}\n    chain: [R{i}, P{i}]\n    actuator: {{joint: P{i}, gain: 1.0, offset: 0.2}}\n    attachment: [{:.10}, {:.10}, 0.0]\n    home: {{R{i}: {:.10}, P{i}: {:.10}}}\n",
            b[0],
            b[1],
            dy.atan2(dx),
            dx.hypot(dy)
        );
        let _ = write!(
            parameters,
            "  - {{name: a{i}x, joint: R{i}, origin: x}}\n  - {{name: a{i}y, joint: R{i}, origin: y}}\n  - {{name: b{i}x, leg: leg{i}, attachment: x}}\n  - {{name: b{i}y, leg: leg{i}, attachment: y}}\n  - {{name: k{i}, leg: leg{i}, actuator: gain}}\n  - {{name: rho0_{i}, leg: leg{i}, actuator: offset}}\n"
        );
    }
    urdf.push_str("</robot>\n");
    let yaml = format!(
        "name: planar {n}-RPR (generated)\nurdf: {n}rpr.urdf\nmeasured: [x, y, yaw]\nmode: \"legs from base to platform, home assembly at the origin\"\nhome:\n  pose: {{x: 0.0, y: 0.0, yaw: 0.0}}\nlegs:\n{legs}parameters:\n{parameters}workspace:\n  region: {{disc: {{centre: [0.0, 0.0], radius: 0.2}}}}\n  margin: 0.0\n  ranges: {{yaw: [-0.5235987756, 0.5235987756]}}\n  grid: 0.05\nnoise: {{x: 1.0e-4, y: 1.0e-4, yaw: 1.0e-4, readings: 1.0e-4}}\nsimulation:\n  perturbation: {{length: 0.002, angle: 0.002, gain: 0.002}}\n  poses_per_leg: 18\n  seed: 7\n"
    );
    (urdf, yaml)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// Median wall time of a whole identification, median solver time, total iterations.
fn timed(
    mechanism: &Mechanism,
    data: &legwise::measure::MeasurementSet,
    strategy: Strategy,
    repeats: usize,
) -> Result<(f64, f64, u64), legwise::error::Error> {
    let mut wall = Vec::new();
    let mut solver = Vec::new();
    let mut iterations = 0;
    for _ in 0..repeats {
        let clock = Instant::now();
        let result: StrategyResult =
            identify(mechanism, data, strategy, SolverKind::LevenbergMarquardt)?;
        wall.push(clock.elapsed().as_secs_f64());
        solver.push(result.runs.iter().map(|r| r.seconds).sum());
        iterations = result.runs.iter().map(|r| r.iterations).sum();
        assert!(
            result.runs.iter().all(|r| r.converged),
            "{strategy:?} converged"
        );
    }
    Ok((median(wall), median(solver), iterations))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let repeats: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(51);
    let dir = tempfile::tempdir()?;
    println!("| legs | parameters Σnᵢ | rows | JᵀJ entries D&C Σnᵢ² | JᵀJ entries all legs (Σnᵢ)² | D&C time (solver) | all legs time (solver) | all legs / D&C | iterations D&C (sum) / all legs |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for n in 2..=8 {
        let (urdf, yaml) = model_files(n);
        std::fs::write(dir.path().join(format!("{n}rpr.urdf")), urdf)?;
        let model_path = dir.path().join(format!("{n}rpr.yaml"));
        std::fs::write(&model_path, yaml)?;
        let mechanism = Mechanism::load(Path::new(&model_path))?;
        let experiment = simulate(&mechanism, SimulationOptions::default())?;
        let data = &experiment.measurements;
        let widths: Vec<usize> = mechanism
            .legs
            .iter()
            .map(|l| l.identified().len())
            .collect();
        let total: usize = widths.iter().sum();
        let small: usize = widths.iter().map(|w| w * w).sum();
        let (dc, dc_solver, dc_iterations) =
            timed(&mechanism, data, Strategy::DivideAndConquer, repeats)?;
        let (all, all_solver, all_iterations) =
            timed(&mechanism, data, Strategy::Traditional, repeats)?;
        println!(
            "| {n} | {total} | {} | {small} | {} | {:.2} ms ({:.2}) | {:.2} ms ({:.2}) | {:.1}× | {dc_iterations} / {all_iterations} |",
            data.shared_count() * n,
            total * total,
            dc * 1e3,
            dc_solver * 1e3,
            all * 1e3,
            all_solver * 1e3,
            all / dc
        );
    }
    Ok(())
}
