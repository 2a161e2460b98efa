//! The reported statistics, recomputed from scratch: on a noisy simulated 5R with one parameter
//! held fixed, every cost, σ̂ = √(‖r‖²/(m−n)) and every std = σ̂·√diag((CᵀC)⁻¹) are rebuilt from
//! the reported estimates with the one-off residual ([`ResidualBlock::evaluate`]), a Jacobian
//! taken one parameter at a time with forward-mode duals, and an explicit inverse of CᵀC — none
//! of which the identification itself uses. Plus the edge cases of the measurement count:
//! exactly n measurements for n parameters, and rank deficiency with n rows.
use legwise::error::Error;
use legwise::identify::estimate::{identify, identify_problem, LegEstimate, Strategy};
use legwise::identify::problem::IdentificationProblem;
use legwise::identify::residual::ResidualBlock;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::measure::{MeasuredPose, MeasurementSet};
use legwise::model::Mechanism;
use legwise::solver::SolverKind;
use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use crate::support::bundled;

/// The fixed parameter: leg 1's base-joint ordinate A1y (index 3), held at its nominal value.
const FIXED: (usize, usize) = (0, 3);

/// The bundled 5R with `A1y` fixed, and its seeded noisy experiment; the mechanism returned
/// declares no noise, so that its unweighted fits report the homoscedastic σ̂²(CᵀC)⁻¹
/// recomputed here (with a declared noise they report the sandwich of `identify::sandwich`).
fn noisy_5r_with_a_fixed_parameter() -> (Mechanism, MeasurementSet) {
    let mech =
        bundled("5r.yaml").edited(|parts| parts.legs[FIXED.0].params[FIXED.1].identified = false);
    let data = simulate(&mech, SimulationOptions::default())
        .unwrap()
        .measurements;
    (mech.edited(|parts| parts.noise = None), data)
}

/// Residuals and identified-column Jacobian of `blocks` at the full leg parameters `phi`,
/// evaluated block by block (one dual pass per identified parameter).
fn residuals_and_jacobian(
    mech: &Mechanism,
    leg: usize,
    blocks: &[ResidualBlock],
    phi: &[f64],
) -> (DVector<f64>, DMatrix<f64>) {
    let model = &mech.legs[leg];
    let columns = model.identified();
    let home = mech.home_pose;
    let r = DVector::from_iterator(
        blocks.len(),
        blocks
            .iter()
            .map(|b| b.evaluate::<f64>(model, phi, &home).unwrap()),
    );
    let c = DMatrix::from_fn(blocks.len(), columns.len(), |i, j| {
        let seeded: Vec<Dual64> = phi
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                let d = Dual64::from_re(v);
                if k == columns[j] {
                    d.derivative()
                } else {
                    d
                }
            })
            .collect();
        blocks[i].evaluate(model, &seeded, &home).unwrap().eps
    });
    (r, c)
}

fn close(actual: f64, expected: f64, relative: f64, what: &str) {
    assert!(
        (actual - expected).abs() <= relative * expected.abs(),
        "{what}: reported {actual:e}, recomputed {expected:e}"
    );
}

/// Checks one leg's reported statistics against an independent recomputation on `blocks`;
/// returns the recomputed (initial, final) costs.
fn check_leg(
    mech: &Mechanism,
    leg: usize,
    blocks: &[ResidualBlock],
    estimate: &LegEstimate,
) -> (f64, f64) {
    let model = &mech.legs[leg];
    assert_eq!(estimate.leg, model.name);
    let phi: Vec<f64> = estimate.parameters.iter().map(|p| p.estimate).collect();
    let (r0, _) = residuals_and_jacobian(mech, leg, blocks, &model.nominal());
    let (r, c) = residuals_and_jacobian(mech, leg, blocks, &phi);
    let (m, n) = c.shape();
    assert_eq!(
        estimate.measurements, m,
        "{}: measurement count",
        model.name
    );
    assert!(m > n);

    // The estimate is the least-squares minimum: Cᵀr vanishes (relative to ‖C‖‖r‖).
    let gradient = c.transpose() * &r;
    assert!(
        gradient.amax() <= 1e-7 * c.norm() * r.norm(),
        "{}: Cᵀr = {gradient}",
        model.name
    );

    let initial_cost = 0.5 * r0.norm_squared();
    let final_cost = 0.5 * r.norm_squared();
    close(estimate.initial_cost, initial_cost, 1e-9, "initial cost");
    close(estimate.final_cost, final_cost, 1e-9, "final cost");
    assert!(final_cost < initial_cost);

    let sigma = (r.norm_squared() / (m - n) as f64).sqrt();
    close(estimate.residual_sigma.unwrap(), sigma, 1e-9, "σ̂");
    let covariance = (c.transpose() * &c).try_inverse().unwrap();
    let mut column = 0;
    for (i, p) in estimate.parameters.iter().enumerate() {
        assert_eq!(p.name, model.params[i].name);
        assert_eq!(p.identified, model.params[i].identified);
        assert_eq!(p.nominal.to_bits(), model.params[i].nominal.to_bits());
        if p.identified {
            let std = sigma * covariance[(column, column)].sqrt();
            close(p.std.unwrap(), std, 1e-6, &format!("std of {}", p.name));
            column += 1;
        } else {
            assert_eq!(p.estimate.to_bits(), p.nominal.to_bits(), "{}", p.name);
            assert_eq!(p.std, None, "{}", p.name);
        }
    }
    assert_eq!(column, n);
    (initial_cost, final_cost)
}

#[test]
fn divide_and_conquer_statistics_match_an_independent_recomputation() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    for solver in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
        let result =
            crate::support::identify_unweighted(&mech, &data, Strategy::DivideAndConquer, solver)
                .unwrap();
        assert_eq!(result.strategy.name(), "divide and conquer");
        assert_eq!(result.legs.len(), 2);
        assert_eq!(result.runs.len(), 2);
        for (leg, estimate) in result.legs.iter().enumerate() {
            let (initial, last) = check_leg(&mech, leg, &data.leg_blocks(leg), estimate);
            let run = &result.runs[leg];
            assert_eq!(run.legs, vec![mech.legs[leg].name.clone()]);
            close(run.initial_cost, initial, 1e-9, "run initial cost");
            close(run.final_cost, last, 1e-9, "run final cost");
        }
    }
}

/// A problem handed to [`identify_problem`] with row weights of its own is fitted as the
/// options say (here plain least squares, its weights dropped): every cost reported is
/// that of the fitted problem, the initial one included (½‖r(x₀)‖², not ½‖√w r(x₀)‖²), and
/// the estimate and its statistics are those of the unweighted identification.
#[test]
fn a_weighted_problem_fitted_without_weights_reports_the_costs_of_the_fitted_problem() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    for leg in 0..mech.legs.len() {
        let blocks = data.leg_blocks(leg);
        let weights = vec![4.0; blocks.len()];
        let problem =
            IdentificationProblem::new(&mech, &[leg], blocks.clone()).with_weights(&weights);
        let (estimates, run) = identify_problem(
            &mech,
            &data,
            &problem,
            SolverKind::GaussNewton,
            crate::support::unweighted(),
        )
        .unwrap();
        assert_eq!(estimates.len(), 1);
        let (initial, last) = check_leg(&mech, leg, &blocks, &estimates[0]);
        close(run.initial_cost, initial, 1e-9, "run initial cost");
        close(run.final_cost, last, 1e-9, "run final cost");
    }
}

#[test]
fn traditional_statistics_match_an_independent_recomputation() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    let result = crate::support::identify_unweighted(
        &mech,
        &data,
        Strategy::Traditional,
        SolverKind::LevenbergMarquardt,
    )
    .unwrap();
    assert_eq!(result.strategy.name(), "traditional (all legs)");
    assert_eq!(result.runs.len(), 1);
    let (mut initial, mut last) = (0.0, 0.0);
    for (leg, estimate) in result.legs.iter().enumerate() {
        let blocks: Vec<ResidualBlock> = data
            .shared_blocks(mech.legs.len())
            .into_iter()
            .filter(|b| b.leg == leg)
            .collect();
        let (i, f) = check_leg(&mech, leg, &blocks, estimate);
        initial += i;
        last += f;
    }
    let run = &result.runs[0];
    assert_eq!(run.legs, vec!["leg1".to_string(), "leg2".to_string()]);
    close(run.initial_cost, initial, 1e-9, "run initial cost");
    close(run.final_cost, last, 1e-9, "run final cost");
}

/// Keeps the first `count` poses labelled with leg 1 and every pose of leg 2, with the leg-1
/// poses replaced by `map`.
fn with_leg1_poses(
    data: &MeasurementSet,
    count: usize,
    map: impl Fn(usize, Row<'_>) -> (MeasuredPose, Vec<Option<f64>>),
) -> MeasurementSet {
    let mut kept = 0;
    let mut poses = MeasurementSet::new(None, data.legs());
    for (pose, readings) in data.rows() {
        if pose.leg == Some(0) {
            if kept < count {
                let (pose, readings) = map(kept, (pose, readings));
                poses.push(pose, &readings);
                kept += 1;
            }
        } else if pose.leg == Some(1) {
            poses.push(*pose, readings);
        }
    }
    assert_eq!(kept, count);
    poses
}

/// A pose of a measurement set and its readings.
type Row<'r> = (&'r MeasuredPose, &'r [Option<f64>]);

/// The row as it is.
fn same((pose, readings): Row<'_>) -> (MeasuredPose, Vec<Option<f64>>) {
    (*pose, readings.to_vec())
}

#[test]
fn exactly_as_many_measurements_as_parameters_fit_exactly_without_a_std() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    let n = mech.legs[0].identified().len();
    let exact = with_leg1_poses(&data, n, |_, row| same(row));
    for solver in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
        let result = identify(&mech, &exact, Strategy::DivideAndConquer, solver).unwrap();
        let leg = &result.legs[0];
        assert_eq!(leg.measurements, n);
        // n equations in n unknowns: the fit is exact, and there is no redundancy for a σ̂.
        assert!(leg.final_cost < 1e-20, "{solver:?}: {}", leg.final_cost);
        assert_eq!(leg.residual_sigma, None);
        assert!(leg.parameters.iter().all(|p| p.std.is_none()), "{leg:?}");
        // The other leg keeps its redundancy.
        assert!(result.legs[1].residual_sigma.is_some());
        assert!(result.legs[1].parameters.iter().all(|p| p.std.is_some()));
    }
}

#[test]
fn n_copies_of_one_pose_are_rank_deficient_with_null_directions_not_a_count() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    let n = mech.legs[0].identified().len();
    let first = same(data.rows().find(|(p, _)| p.leg == Some(0)).unwrap());
    let repeated = with_leg1_poses(&data, n, |_, _| first.clone());
    let err = identify(
        &mech,
        &repeated,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
    )
    .unwrap_err();
    let Error::Unidentifiable {
        leg,
        rank,
        n: count,
        params,
        ..
    } = &err
    else {
        panic!("{err:?}");
    };
    assert_eq!((leg.as_str(), *rank, *count), ("leg1", 1, n));
    assert!(
        params.contains("(null-space directions, column-scaled: "),
        "{err}"
    );
    assert!(!params.contains("measurements for"), "{err}");
    assert_eq!(params.matches(';').count(), n - 2, "{err}");
}

#[test]
fn fewer_measurements_than_parameters_say_how_many() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    let n = mech.legs[0].identified().len();
    let short = with_leg1_poses(&data, n - 1, |_, row| same(row));
    let err = identify(
        &mech,
        &short,
        Strategy::DivideAndConquer,
        SolverKind::GaussNewton,
    )
    .unwrap_err();
    let Error::Unidentifiable { rank, params, .. } = &err else {
        panic!("{err:?}");
    };
    assert_eq!(*rank, n - 1);
    assert!(
        params.ends_with(&format!(
            " (only {} measurements for {n} parameters)",
            n - 1
        )),
        "{err}"
    );
    assert!(!params.contains("null-space"), "{err}");
}

/// A reading on another whole turn of a revolute actuator is the same reading: the residual of
/// a 5R block whose reading is moved by ±2π/gain (leg 1's gain is 1, leg 2's is −1) is the
/// residual of the original block, in f64 and in its derivative, and a residual within half a
/// turn is left as it is.
#[test]
fn a_reading_moved_by_whole_turns_gives_the_same_residual() {
    let (mech, data) = noisy_5r_with_a_fixed_parameter();
    let home = mech.home_pose;
    for (leg, model) in mech.legs.iter().enumerate() {
        let phi = model.nominal();
        let gain = model.geometry(&phi).gain;
        for block in data.leg_blocks(leg).iter().take(4) {
            let residual = block.evaluate::<f64>(model, &phi, &home).unwrap();
            assert!(residual.abs() < 0.1, "leg {leg}: residual {residual}");
            for turns in [-2.0, -1.0, 1.0, 3.0] {
                let moved = ResidualBlock {
                    reading: block.reading + turns * std::f64::consts::TAU / gain,
                    ..block.clone()
                };
                let value = moved.evaluate::<f64>(model, &phi, &home).unwrap();
                close(value, residual, 1e-9, &format!("leg {leg}, {turns} turns"));
                let seeded: Vec<Dual64> = phi
                    .iter()
                    .enumerate()
                    .map(|(k, &v)| {
                        let d = Dual64::from_re(v);
                        if k == 0 {
                            d.derivative()
                        } else {
                            d
                        }
                    })
                    .collect();
                let moved_dual = moved.evaluate(model, &seeded, &home).unwrap();
                let dual = block.evaluate(model, &seeded, &home).unwrap();
                close(moved_dual.re, dual.re, 1e-9, "dual value");
                close(moved_dual.eps, dual.eps, 1e-12, "derivative");
            }
        }
    }
}
