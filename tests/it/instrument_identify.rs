//! Identification through the instrument: the measurement file's round trip, zero-noise
//! recovery of every identified leg and instrument parameter, the Schur-complement solve
//! against a dense Levenberg–Marquardt solve of the same problem, and the rank check naming the
//! frame/base gauge when everything is freed.
use std::path::Path;

use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::Strategy;
use legwise::measure::observations::{parse, to_csv};
use legwise::measure::observe_simulate::simulate_observed;
use legwise::model::Mechanism;
use legwise::solver::bordered::DenseView;
use legwise::solver::{solve, solve_bordered, SolverKind};

use crate::instrument_support::{
    assert_recovered, assert_targets_give_the_true_poses, identify_shared, instrument, shared,
    simulation,
};
use crate::support::{assert_central_differences, bundled, crate_path};

#[test]
fn the_instrument_measurement_file_round_trips_and_its_targets_give_back_the_true_poses() {
    let mechanism = bundled("3rpr-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
    let text = to_csv(&mechanism, &experiment.observations).unwrap();
    assert!(
        text.starts_with("leg,x.r1,y.r1,x.r2,y.r2,P1,P2,P3\n"),
        "{text}"
    );
    let back = parse(&text, Path::new("m.csv"), &mechanism).unwrap();
    assert_eq!(back.rows.len(), experiment.observations.rows.len());
    for (a, b) in back.rows.iter().zip(&experiment.observations.rows) {
        assert_eq!(
            (&a.observed, &a.readings, a.leg),
            (&b.observed, &b.readings, b.leg)
        );
    }
    assert_targets_give_the_true_poses(&mechanism, &experiment);
    // The perturbed frame really differs from the nominal one.
    assert!((experiment.real_shared[0] - 1.5).abs() > 1e-4);
}

#[test]
fn an_instrument_file_without_a_target_column_names_it() {
    let mechanism = bundled("3rpr-tracker.yaml");
    let err = parse(
        "leg,x.r1,y.r1,x.r2,P1,P2,P3\n",
        Path::new("m.csv"),
        &mechanism,
    )
    .expect_err("rejected")
    .to_string();
    assert_eq!(
        err,
        "m.csv: header: missing column `y.r2`; expected the columns leg, x.r1, y.r1, x.r2, y.r2, \
         P1, P2, P3 (and optionally pose.x, pose.y, pose.yaw, ignored)"
    );
    let err = parse("leg,x,y,yaw,P1,P2,P3\n", Path::new("m.csv"), &mechanism)
        .expect_err("rejected")
        .to_string();
    assert!(err.contains("unknown column `x`"), "{err}");
}

#[test]
fn zero_noise_recovers_every_identified_leg_and_instrument_parameter_of_the_5r_and_the_3rpr() {
    for model in ["5r-tracker.yaml", "3rpr-tracker.yaml"] {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
        let estimate =
            identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
        assert!(
            estimate.runs[0].converged,
            "{model}: {:?}",
            estimate.runs[0]
        );
        assert_recovered(&mechanism, &estimate, &experiment, 1e-9);
        let rms = instrument(&estimate).rms;
        assert!(rms < 1e-10, "{model}: rms {rms}");
    }
}

#[test]
fn the_schur_solution_equals_a_dense_levenberg_marquardt_solve_of_the_same_problem() {
    for model in ["5r-tracker.yaml", "3rpr-tracker.yaml"] {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
        let problem =
            IdentificationProblem::through_instrument(&mechanism, &experiment.observations)
                .unwrap();
        let schur = solve_bordered(&problem, problem.start()).unwrap();
        let dense = solve(
            &DenseView(&problem),
            problem.start(),
            SolverKind::LevenbergMarquardt,
        )
        .unwrap();
        assert!(schur.converged && dense.converged);
        let gap = (&schur.x - &dense.x).amax();
        assert!(gap <= 1e-10, "{model}: Schur and dense differ by {gap:e}");
        // Noise moved the estimate: the comparison is not of two copies of the start.
        assert!((&schur.x - problem.start()).amax() > 1e-4);
    }
}

#[test]
fn freeing_every_base_joint_and_target_names_the_frame_gauge() {
    let text = std::fs::read_to_string(crate_path("models/3rpr-tracker.yaml"))
        .unwrap()
        .replace(", identify: false}", "}")
        .replace("identify: [y], ", "");
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    let mechanism =
        Mechanism::parse(&text, Path::new("free.yaml"), &urdf, Path::new("3rpr.urdf")).unwrap();
    let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
    let err = identify_shared(&mechanism, &experiment.observations, Strategy::Joint)
        .expect_err("rank-deficient")
        .to_string();
    // 18 leg parameters and 7 instrument ones; 3 base-frame and 3 platform-frame directions,
    // and the reflectors' distance.
    assert!(err.contains("rank 18 of 25 parameters"), "{err}");
    assert!(err.contains("frame_x") || err.contains("frame_y"), "{err}");
    assert!(err.contains("null-space directions"), "{err}");
    assert!(err.contains("docs/models.md"), "{err}");
}

#[test]
fn the_two_stage_strategy_also_recovers_at_zero_noise() {
    let mechanism = bundled("3rpr-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
    let estimate =
        identify_shared(&mechanism, &experiment.observations, Strategy::TwoStage).unwrap();
    // The registration uses the nominal legs: its frame is off by the legs' errors, and the
    // legs then absorb what they can of it. Only the order of magnitude is asserted.
    let frame_error = (shared(&estimate)[0].estimate - experiment.real_shared[0]).abs();
    assert!(frame_error < 0.01, "frame_x off by {frame_error}");
}

#[test]
fn with_noise_every_identified_error_is_at_the_noise_level_and_a_held_off_frame_is_rejected() {
    use legwise::identify::trust::trust_issues;
    let mechanism = bundled("3rpr-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
    let estimate = identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
    let test = instrument(&estimate)
        .noise_test
        .as_ref()
        .expect("a declared noise");
    assert!(!test.rejected, "{test:?}");
    for (k, p) in shared(&estimate).iter().enumerate() {
        if let Some(std) = p.std {
            let error = p.estimate - experiment.real_shared[k];
            assert!(error.abs() < 4.0 * std, "{}: error {error} σ {std}", p.name);
        }
    }
    assert!(trust_issues(&[estimate]).is_empty());
    // The frame held at a nominal 5 mm and 5 mrad off the real one.
    let text = std::fs::read_to_string(crate_path("models/3rpr-tracker.yaml"))
        .unwrap()
        .replace(
            "    perturbation: {length: 0.005, angle: 0.005}",
            "    identify: []",
        )
        .replace(
            "  poses_per_leg: 18",
            "  real: {frame_x: 1.505, frame_yaw: 0.305}\n  poses_per_leg: 18",
        );
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    let held =
        Mechanism::parse(&text, Path::new("held.yaml"), &urdf, Path::new("3rpr.urdf")).unwrap();
    let experiment = simulate_observed(&held, simulation(1.0)).unwrap();
    let estimate = identify_shared(&held, &experiment.observations, Strategy::Joint).unwrap();
    let issues = trust_issues(&[estimate]);
    assert!(
        issues
            .iter()
            .any(|i| i.contains("reject the declared noise")),
        "{issues:?}"
    );
}

#[test]
fn the_jacobian_of_the_shared_problem_matches_central_differences_of_its_residuals() {
    use argmin::core::Operator;
    use legwise::solver::bordered::{to_dense, BorderedLeastSquares};
    // The planar and the spatial tracker models (6-DoF frame, three reflectors on the hexapod).
    for model in [
        "5r-tracker.yaml",
        "3rpr-tracker.yaml",
        "delta-tracker.yaml",
        "hexapod-tracker.yaml",
    ] {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
        let problem =
            IdentificationProblem::through_instrument(&mechanism, &experiment.observations)
                .unwrap();
        // Away from the nominal start, every column non-trivial.
        let x = problem.start().map(|v| v * (1.0 + 1e-3));
        let (r, jacobian) = to_dense(&problem.layout(), &problem.bordered(&x).unwrap());
        assert!((&r - problem.apply(&x).unwrap()).amax() < 1e-14);
        assert_central_differences(&problem, &x, &jacobian, model);
    }
}

/// Readings on another turn of their revolute actuator (leg 1 shifted by one turn, 2π/gain, on
/// every other row): the residuals are matched modulo the turn, and the Jacobian, the identified
/// gain's column with its turn term included, still matches central differences.
#[test]
fn readings_on_another_turn_give_the_same_residuals_and_a_jacobian_that_accounts_for_the_turn() {
    use argmin::core::Operator;
    use legwise::solver::bordered::{to_dense, BorderedLeastSquares};
    let mechanism = bundled("5r-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
    let mut shifted = experiment.observations.clone();
    let turn = 2.0 * std::f64::consts::PI / mechanism.legs[0].gain;
    let mut moved = 0;
    for (i, row) in shifted.rows.iter_mut().enumerate() {
        if let (true, Some(reading)) = (i % 2 == 0, row.readings[0].as_mut()) {
            *reading += turn;
            moved += 1;
        }
    }
    assert!(moved > 3);
    let plain =
        IdentificationProblem::through_instrument(&mechanism, &experiment.observations).unwrap();
    let problem = IdentificationProblem::through_instrument(&mechanism, &shifted).unwrap();
    // At the gains the shift was made with, a whole turn: the same residuals.
    let start = problem.start();
    let gap = (problem.apply(&start).unwrap() - plain.apply(&start).unwrap()).amax();
    assert!(gap <= 1e-12, "residuals differ by {gap:e}");
    let x = start.map(|v| v * (1.0 + 1e-3));
    let r = problem.apply(&x).unwrap();
    let (r_dense, jacobian) = to_dense(&problem.layout(), &problem.bordered(&x).unwrap());
    assert!((&r_dense - &r).amax() < 1e-14);
    let gain = problem.names().iter().position(|n| n == "k1").unwrap();
    assert_central_differences(&problem, &x, &jacobian, "turned readings");
    // The turn term is a large part of the gain's column on the shifted rows.
    let (_, plain_jacobian) = to_dense(&plain.layout(), &plain.bordered(&x).unwrap());
    let change = (jacobian.column(gain) - plain_jacobian.column(gain)).amax();
    assert!(change > 1.0, "{change}");
}

/// Every number of identified shared parameters (1 to all: every size of a last, partial dual
/// pass over them) gives the border columns of the problem identifying them all, which the
/// central differences above check.
#[test]
fn every_count_of_shared_parameters_gives_the_same_border_columns() {
    use legwise::solver::bordered::BorderedLeastSquares;
    let mechanism = bundled("hexapod-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
    let observations = &experiment.observations;
    let full = IdentificationProblem::through_instrument(&mechanism, observations).unwrap();
    let shared = full.shared_columns().to_vec();
    assert!(shared.len() > 8, "{} shared: two passes", shared.len());
    let own = full.start().len() - shared.len();
    // The legs' unknowns moved, the shared ones at their nominal values (as the held ones are).
    let mut x = full.start();
    for v in x.rows_mut(0, own).iter_mut() {
        *v *= 1.0 + 1e-3;
    }
    let reference = full.bordered(&x).unwrap();
    for count in 1..=shared.len() {
        let fewer = mechanism.edited(|fewer| {
            for &k in &shared[count..] {
                fewer.instrument.as_mut().unwrap().parameters[k].identified = false;
            }
        });
        let problem = IdentificationProblem::through_instrument(&fewer, observations).unwrap();
        assert_eq!(problem.shared_columns(), &shared[..count]);
        let blocks = problem
            .bordered(&x.rows(0, own + count).into_owned())
            .unwrap();
        for (block, expected) in blocks.iter().zip(&reference) {
            assert_eq!(block.residuals, expected.residuals);
            let columns = expected.shared.columns(0, count);
            let gap = (&block.shared - columns).amax();
            assert!(
                gap <= 1e-12 * columns.amax().max(1.0),
                "{count} shared parameters: gap {gap:e}"
            );
        }
    }
}

#[test]
fn a_camera_marker_measuring_the_pose_gives_the_same_zero_noise_recovery() {
    // One pose target (a camera's marker) instead of the two reflectors; its offset held with
    // the attachments that define the platform frame, the frame identified.
    let text = std::fs::read_to_string(crate_path("models/3rpr-tracker.yaml"))
        .unwrap()
        .replace(
            "    - {name: r1, offset: [0.08, 0.03], measures: position, perturbation: 0.002}\n",
            "    - {name: marker, offset: [0.05, -0.02], measures: pose, identify: []}\n",
        )
        .replace(
            "    - {name: r2, offset: [-0.07, 0.03], measures: position, identify: [y], perturbation: 0.002}\n",
            "",
        );
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    let mechanism = Mechanism::parse(
        &text,
        Path::new("camera.yaml"),
        &urdf,
        Path::new("3rpr.urdf"),
    )
    .unwrap();
    assert_eq!(
        mechanism.instrument.as_ref().unwrap().columns(),
        ["x.marker", "y.marker", "yaw.marker"]
    );
    let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
    let estimate = identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
    assert!(estimate.runs[0].converged);
    assert_recovered(&mechanism, &estimate, &experiment, 1e-9);
}

/// Through an instrument too, a row's residual is its measured minus its predicted reading
/// (docs/report.md, `rows`): raising one reading by δ raises its row's residual by almost δ
/// (by δ less the part the refit absorbs), with each strategy.
#[test]
fn a_rows_residual_is_the_measured_minus_the_predicted_reading() {
    let mechanism = bundled("5r-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
    let text = to_csv(&mechanism, &experiment.observations).unwrap();
    let observations = parse(&text, Path::new("m.csv"), &mechanism).unwrap();
    let row = 7;
    let leg = observations.rows[row].leg.unwrap_or(0);
    let line = observations.rows[row].line;
    let mut raised = observations.clone();
    let delta = 1e-3;
    *raised.rows[row].readings[leg].as_mut().unwrap() += delta;
    for strategy in [Strategy::Joint, Strategy::TwoStage] {
        let residual = |data: &_| {
            let result = identify_shared(&mechanism, data, strategy).unwrap();
            let rows = &result.legs[leg].residuals;
            rows.iter().find(|r| r.line == line).unwrap().residual
        };
        let change = residual(&raised) - residual(&observations);
        assert!(
            (0.5 * delta..delta).contains(&change),
            "{strategy:?}: the residual moved by {change:e} for a reading raised by {delta:e}"
        );
    }
}
