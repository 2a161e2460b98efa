//! The hand-written 5R leg of the floor benches (benches/reference/closed_form_leg.rs: the
//! actuated angle by the law of cosines, its Jacobian by hand) against legwise's own leg: the
//! same residuals at legwise's estimate, a Jacobian that finite differences confirm, and both
//! of its fits (legwise's solver, the fixed-size Levenberg–Marquardt) on legwise's estimate.
//! An independent check of the 5R leg's fit, and of the benches' reference.
use std::path::Path;

use argmin::core::{Jacobian, Operator};
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::solver::{solve, SolverKind};
use legwise::Mechanism;
use nalgebra::DVector;

#[path = "../../benches/reference/closed_form_leg.rs"]
mod closed_form_leg;
use closed_form_leg::{fixed_size_lm, residual_and_gradient, ClosedFormLeg, NOMINAL};

/// The 5R model, its first leg's simulated blocks as the hand-written leg's rows, and
/// legwise's estimate of that leg.
fn setup() -> (ClosedFormLeg, DVector<f64>, DVector<f64>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
    let mechanism = Mechanism::load(&path).expect("bundled model");
    let blocks = simulate(&mechanism, SimulationOptions::default())
        .expect("simulates")
        .measurements
        .leg_blocks(0);
    let rows = blocks
        .iter()
        .map(|b| (b.pose[0], b.pose[1], b.reading))
        .collect();
    let problem = IdentificationProblem::new(&mechanism, &[0], blocks);
    let estimate = solve(&problem, problem.start(), SolverKind::LevenbergMarquardt)
        .expect("solves")
        .x;
    let residuals = problem.apply(&estimate).expect("evaluates");
    (ClosedFormLeg { rows }, estimate, residuals)
}

#[test]
fn the_hand_written_leg_predicts_legwise_s_residuals() {
    let (leg, estimate, residuals) = setup();
    assert_eq!(estimate.len(), NOMINAL.len());
    let by_hand = leg.apply(&estimate).expect("evaluates");
    let gap = (&by_hand - &residuals).amax();
    assert!(gap < 1e-12, "hand-written residuals {gap:e} from legwise's");
    // Not a trivial agreement: the residuals are the noise's size.
    assert!(residuals.amax() > 1e-5, "{}", residuals.amax());
}

#[test]
fn the_hand_written_jacobian_is_the_residuals_derivative() {
    let (leg, estimate, _) = setup();
    let jacobian = leg.jacobian(&estimate).expect("differentiates");
    for k in 0..estimate.len() {
        let h = 1e-6 * estimate[k].abs().max(1e-3);
        let (mut up, mut down) = (estimate.clone(), estimate.clone());
        up[k] += h;
        down[k] -= h;
        for (i, &row) in leg.rows.iter().enumerate() {
            let difference = (residual_and_gradient(up.as_slice(), row).0
                - residual_and_gradient(down.as_slice(), row).0)
                / (2.0 * h);
            let analytic = jacobian[(i, k)];
            assert!(
                (difference - analytic).abs() < 1e-6 * analytic.abs().max(1.0),
                "row {i}, column {k}: {analytic} against {difference}"
            );
        }
    }
}

#[test]
fn both_floor_fits_land_on_legwise_s_estimate() {
    let (leg, estimate, _) = setup();
    let start = DVector::from_column_slice(&NOMINAL);
    let by_solver = solve(&leg, start, SolverKind::LevenbergMarquardt)
        .expect("solves")
        .x;
    let fixed = DVector::from_column_slice(&fixed_size_lm(&leg.rows, NOMINAL));
    for (name, fit) in [("legwise's solver", by_solver), ("fixed-size LM", fixed)] {
        let gap = (&fit - &estimate).amax() / estimate.amax();
        assert!(gap < 1e-9, "{name}: {gap:e} from legwise's estimate");
        // The nominal start is far from it: the fits moved.
        let moved = (&fit - DVector::from_column_slice(&NOMINAL)).amax();
        assert!(moved > 1e-4, "{name} moved only {moved:e}");
    }
}
