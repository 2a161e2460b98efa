//! After the fit, on the spatial models (models/delta.yaml, models/hexapod.yaml): pose
//! selection, evaluation, the accuracy map, the calibrated model and the pictures. Each value is
//! recomputed here from the closed forms of `tests/it/spatial.rs` (a hexapod leg's length
//! |p + R·b − a|, a delta carriage a rod length from its effector joint): forward kinematics by
//! Newton on those closed forms, the identification rows by central differences.
use legwise::evaluate::accuracy::accuracy_map;
use legwise::evaluate::held_out::evaluate;
use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::file;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::mechanism::SelectionCriterion;
use legwise::model::Mechanism;
use legwise::report::calibrated::{calibrated_files, urdf_path, Calibration};
use legwise::selection::candidates::candidate_pool;
use legwise::selection::design::divide_and_conquer;
use legwise::selection::log_det;
use legwise::solver::SolverKind;
use nalgebra::{DMatrix, DVector};
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::cli::{legwise, text};
use crate::spatial::{closed_form_rows, real_parameters, rotation, spread_poses, Spatial, MODELS};
use crate::support::{bundled, svg_texts};

// ---------------------------------------------------------------- closed-form helpers

/// The readings of every leg with parameters `params` at `pose`, from the closed form.
fn readings(model: &Spatial, params: &[Vec<f64>], pose: &[f64; 6]) -> Vec<f64> {
    params
        .iter()
        .map(|phi| (model.reading)(phi, pose))
        .collect()
}

/// Forward kinematics from the closed forms: the pose near `start` whose readings under
/// `params` are `wanted`, by Newton over the measured coordinates with a central-difference
/// Jacobian; `None` unless the readings are met to 1e-13 m.
fn forward(
    model: &Spatial,
    mech: &Mechanism,
    params: &[Vec<f64>],
    wanted: &[f64],
    start: [f64; 6],
) -> Option<[f64; 6]> {
    let coordinates = &mech.measured;
    let n = coordinates.len();
    let residual = |pose: &[f64; 6]| -> Vec<f64> {
        readings(model, params, pose)
            .iter()
            .zip(wanted)
            .map(|(s, w)| s - w)
            .collect()
    };
    let mut pose = start;
    for _ in 0..40 {
        let f = residual(&pose);
        if f.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut jacobian = DMatrix::zeros(n, n);
        for (column, &c) in coordinates.iter().enumerate() {
            let h = 1e-7;
            let (mut plus, mut minus) = (pose, pose);
            plus[c] += h;
            minus[c] -= h;
            let (a, b) = (residual(&plus), residual(&minus));
            for row in 0..n {
                jacobian[(row, column)] = (a[row] - b[row]) / (2.0 * h);
            }
        }
        let step = jacobian.lu().solve(&DVector::from_vec(f))?;
        for (column, &c) in coordinates.iter().enumerate() {
            pose[c] -= step[column];
        }
    }
    residual(&pose)
        .iter()
        .all(|r| r.abs() <= 1e-13)
        .then_some(pose)
}

fn position_distance(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The angle between two orientations, `2·asin(‖Ra − Rb‖_F / (2√2))` (well conditioned at 0).
fn angle_between(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let (ra, rb) = (rotation(a[3], a[4], a[5]), rotation(b[3], b[4], b[5]));
    let frobenius = (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .map(|(i, j)| (ra[i][j] - rb[i][j]).powi(2))
        .sum::<f64>()
        .sqrt();
    2.0 * (frobenius / (2.0 * 2f64.sqrt())).asin()
}

/// Is `(x, y)` in the model's region shrunk by `scale` about its centre (the delta's cylinder of
/// radius 0.08 m about z, the hexapod's square |x|, |y| ≤ 0.05 m)?
fn in_scaled_section(file: &str, x: f64, y: f64, scale: f64) -> bool {
    if file == "delta.yaml" {
        x.hypot(y) <= scale * 0.08 + 1e-12
    } else {
        x.abs().max(y.abs()) <= scale * 0.05 + 1e-12
    }
}

// ---------------------------------------------------------------- the accuracy map

#[test]
fn the_spatial_accuracy_maps_are_the_horizontal_slice_and_agree_with_the_closed_forms() {
    for model in &MODELS {
        let mech = bundled(model.file);
        let real = real_parameters(&mech);
        let nominal = mech.nominal_parameters();
        let map = accuracy_map(&mech, &nominal, &real, 0.02, 0.95, "t").unwrap();
        // The lattice of spacing 0.02 m from the region's lower corner (-0.08 or -0.05 m), in
        // the section shrunk to 0.95, counted here.
        let corner: f64 = if model.file == "delta.yaml" {
            -0.08
        } else {
            -0.05
        };
        let steps = (2.0 * -corner / 0.02 + 1e-9).floor() as usize;
        let expected = (0..=steps)
            .flat_map(|i| (0..=steps).map(move |j| (i, j)))
            .filter(|&(i, j)| {
                let (x, y) = (corner + i as f64 * 0.02, corner + j as f64 * 0.02);
                in_scaled_section(model.file, x, y, 0.95)
            })
            .count();
        assert_eq!(map.points.len(), expected, "{}", model.file);
        assert_eq!(map.non_assemblable, 0, "{}", model.file);
        for point in &map.points {
            let target = point.pose;
            // The horizontal slice through home at the home orientation.
            assert_eq!(&target[2..], &mech.home_pose[2..], "{}", model.file);
            let commanded = readings(model, &nominal, &target);
            let reached = forward(model, &mech, &real, &commanded, target)
                .unwrap_or_else(|| panic!("{}: {target:?} not assembled", model.file));
            let expected = position_distance(&reached, &target);
            let error = point.position_error.unwrap();
            assert!(
                (error - expected).abs() <= 1e-10,
                "{} at {target:?}: map {error} vs closed form {expected}",
                model.file
            );
            if model.file == "hexapod.yaml" {
                let expected = angle_between(&reached, &target);
                let error = point.orientation_error.unwrap();
                assert!(
                    (error - expected).abs() <= 1e-10,
                    "{} at {target:?}: map {error} rad vs closed form {expected}",
                    model.file
                );
            } else {
                assert_eq!(point.orientation_error, None, "the delta only translates");
            }
        }
        // The nominal model misses by millimetres; the real model commanding itself, not at all.
        assert!(map.position_error.rms > 1e-3, "{:?}", map.position_error);
        let exact = accuracy_map(&mech, &real, &real, 0.02, 0.95, "t").unwrap();
        assert!(
            exact.position_error.max < 1e-9,
            "{:?}",
            exact.position_error
        );
    }
}

// ---------------------------------------------------------------- evaluation

/// `evaluate` of `mech` (its nominal values) on closed-form readings of the real geometry at
/// `poses`: every row's pose error and every leg's reading residual, recomputed here; returns
/// the RMS position error.
fn check_evaluation(model: &Spatial, mech: &Mechanism, poses: &[[f64; 6]]) -> f64 {
    let real = real_parameters(&bundled(model.file));
    let params = mech.nominal_parameters();
    let data = closed_form_rows(model, &real, poses, 0.0);
    let evaluation = evaluate(mech, &data).unwrap();
    assert_eq!(evaluation.row_errors.len(), poses.len());
    assert!(evaluation.non_assemblable.is_empty());
    let mut squares = 0.0;
    for (row, pose) in evaluation.row_errors.iter().zip(poses) {
        let measured = readings(model, &real, pose);
        let estimated = forward(model, mech, &params, &measured, *pose).unwrap();
        let expected = position_distance(&estimated, pose);
        squares += expected * expected;
        let error = row.position_error.unwrap();
        assert!(
            (error - expected).abs() <= 1e-10,
            "{} line {}: {error} vs closed form {expected}",
            model.file,
            row.line
        );
        if model.file == "hexapod.yaml" {
            let expected = angle_between(&estimated, pose);
            assert!((row.orientation_error.unwrap() - expected).abs() <= 1e-10);
        }
    }
    for (l, stats) in evaluation.reading_residual.iter().enumerate() {
        let residuals: Vec<f64> = poses
            .iter()
            .map(|pose| (model.reading)(&real[l], pose) - (model.reading)(&params[l], pose))
            .collect();
        let rms = (residuals.iter().map(|r| r * r).sum::<f64>() / residuals.len() as f64).sqrt();
        assert_eq!(stats.rows, poses.len());
        assert!(
            (stats.rms.unwrap() - rms).abs() <= 1e-12 + 1e-9 * rms,
            "{} {}: {:?} vs {rms}",
            model.file,
            stats.leg,
            stats.rms
        );
    }
    (squares / poses.len() as f64).sqrt()
}

#[test]
fn evaluating_the_nominal_spatial_models_matches_the_closed_forms() {
    for model in &MODELS {
        let mech = bundled(model.file);
        let rms = check_evaluation(model, &mech, &spread_poses(model.file, 12, 21));
        assert!(
            rms > 1e-3,
            "{}: the nominal model misses by mm: {rms}",
            model.file
        );
    }
}

// ---------------------------------------------------------------- the calibrated model

#[test]
fn the_calibrated_spatial_models_reload_identify_again_without_iterating_and_evaluate_better() {
    for model in &MODELS {
        let dir = tempfile::tempdir().unwrap();
        let mech = bundled(model.file);
        let experiment = simulate(&mech, SimulationOptions::default()).unwrap();
        let csv = dir.path().join("measurements.csv");
        file::write(&csv, &mech, &experiment.measurements).unwrap();
        let data = file::read(&csv, &mech).unwrap();
        let solver = SolverKind::LevenbergMarquardt;
        let result = identify(&mech, &data, Strategy::DivideAndConquer, solver).unwrap();
        let out = dir.path().join("calibrated.yaml");
        let calibration = Calibration {
            mechanism: &mech,
            result: &result,
            source: &csv.display().to_string(),
            real: None,
            note: None,
        };
        let urdf = urdf_path(&out).unwrap();
        let files = calibrated_files(&calibration, "calibrated.urdf").unwrap();
        std::fs::write(&urdf, &files.urdf).unwrap();
        std::fs::write(&out, &files.yaml).unwrap();

        let calibrated = Mechanism::load(&out).unwrap();
        assert_eq!(calibrated.measured, mech.measured);
        assert_eq!(calibrated.workspace, mech.workspace);
        // The joints keep their URDF limits (the strokes bound the workspace).
        for (leg, original) in calibrated.legs.iter().zip(&mech.legs) {
            let limits = |l: &legwise::model::leg::LegModel| -> Vec<Option<[f64; 2]>> {
                l.joints.iter().map(|j| j.limits).collect()
            };
            assert_eq!(limits(leg), limits(original), "{}", model.file);
            assert!(limits(leg).iter().any(Option::is_some));
        }
        for (leg, estimate) in calibrated.legs.iter().zip(&result.legs) {
            for (param, p) in leg.params.iter().zip(&estimate.parameters) {
                assert_eq!(
                    param.nominal.to_bits(),
                    p.estimate.to_bits(),
                    "{} {}",
                    model.file,
                    p.name
                );
            }
        }
        let again = identify(&calibrated, &data, Strategy::DivideAndConquer, solver).unwrap();
        for run in &again.runs {
            assert_eq!(run.iterations, 0, "{}: {run:?}", model.file);
        }
        for (a, b) in again.legs.iter().zip(&result.legs) {
            for (pa, pb) in a.parameters.iter().zip(&b.parameters) {
                assert!((pa.estimate - pb.estimate).abs() <= 1e-10, "{}", pa.name);
            }
        }
        // On poses held out of the fit, the calibrated model's pose errors (recomputed from the
        // closed forms with its values) are far below the nominal model's.
        let held_out = spread_poses(model.file, 12, 22);
        let before = check_evaluation(model, &mech, &held_out);
        let after = check_evaluation(model, &calibrated, &held_out);
        assert!(
            after < before / 20.0,
            "{}: RMS {after} m after vs {before} m before",
            model.file
        );
    }
}

// ---------------------------------------------------------------- selection

#[test]
fn spatial_selection_uses_closed_form_rows_and_beats_random_sets() {
    for model in &MODELS {
        let mech = bundled(model.file);
        // A coarser grid than the model's keeps the hexapod's 6-D pool small (3³ × 5³).
        let pool = candidate_pool(&mech, Some(0.05)).unwrap();
        // Every candidate row is the closed form's gradient (central differences) over the
        // identified parameters, at the nominal values.
        for candidate in pool
            .candidates
            .iter()
            .step_by(pool.candidates.len() / 9 + 1)
        {
            for (l, leg) in mech.legs.iter().enumerate() {
                let phi = leg.nominal();
                for (column, &p) in leg.identified().iter().enumerate() {
                    let h = 1e-6;
                    let (mut plus, mut minus) = (phi.clone(), phi.clone());
                    plus[p] += h;
                    minus[p] -= h;
                    let difference = ((model.reading)(&plus, &candidate.pose)
                        - (model.reading)(&minus, &candidate.pose))
                        / (2.0 * h);
                    let row = candidate.rows[l][column];
                    assert!(
                        (row - difference).abs() <= 1e-6 * difference.abs().max(1.0),
                        "{} {}: {row} vs {difference}",
                        model.file,
                        leg.params[p].name
                    );
                }
            }
        }
        let count = 3 * mech.legs[0].identified().len();
        let designs = divide_and_conquer(&mech, &pool, count, SelectionCriterion::D).unwrap();
        assert_eq!(designs.len(), mech.legs.len());
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for design in &designs {
            let rows: Vec<DMatrix<f64>> = pool
                .candidates
                .iter()
                .map(|c| {
                    DMatrix::from_row_slice(
                        1,
                        c.rows[design.leg].len(),
                        c.rows[design.leg].as_slice(),
                    )
                })
                .collect();
            assert_eq!(design.indices.len(), count);
            let selected = log_det(&rows, &design.indices);
            assert!(selected.is_finite(), "{}: a singular design", model.file);
            let best_random = (0..300)
                .map(|_| log_det(&rows, &sample(&mut rng, rows.len(), count).into_vec()))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(
                selected > best_random,
                "{} leg {}: log det {selected} vs best random {best_random}",
                model.file,
                design.leg
            );
        }
    }
}

#[test]
fn select_on_the_spatial_models_writes_their_csv_layout() {
    for (model, header, legs, per_leg) in [
        ("models/delta.yaml", "leg,x,y,z,C1,C2,C3", 3, 15),
        (
            "models/hexapod.yaml",
            "leg,x,y,z,roll,pitch,yaw,P1,P2,P3,P4,P5,P6",
            6,
            24,
        ),
    ] {
        let out = legwise(&["select", "--model", model, "--out", "-"]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        let csv = text(&out.stdout);
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some(header));
        let rows: Vec<&str> = lines.collect();
        assert_eq!(rows.len(), legs * per_leg, "{model}");
        for l in 1..=legs {
            let label = format!("leg{l},");
            assert_eq!(
                rows.iter().filter(|r| r.starts_with(&label)).count(),
                per_leg
            );
        }
        // Readings are left empty, to be measured.
        let columns = header.split(',').count();
        for row in &rows {
            let cells: Vec<&str> = row.split(',').collect();
            assert_eq!(cells.len(), columns, "{row}");
            assert!(
                cells[columns - legs..].iter().all(|c| c.is_empty()),
                "{row}"
            );
        }
    }
}

// ---------------------------------------------------------------- the pictures

#[test]
fn identify_plots_on_the_spatial_models_label_the_slice_and_the_units() {
    for (model, slice) in [
        ("models/delta.yaml", "slice z = 0.05 m; poses projected"),
        (
            "models/hexapod.yaml",
            "slice z = 0.6 m, (roll, pitch, yaw) = (0, 0, 0) rad; poses projected",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let plots = dir.path().join("plots");
        // A coarser candidate grid than the hexapod's keeps its 6-D pool small (3³ × 5³).
        let grid = if model.contains("hexapod") {
            "0.05"
        } else {
            "0.02"
        };
        let run = legwise(&[
            "identify",
            "--model",
            model,
            "--grid",
            grid,
            "--map",
            "0.02",
            "--plots",
            plots.to_str().unwrap(),
            "--json",
            "-",
        ]);
        assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
        let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
        let stderr = text(&run.stderr);
        let terminal_slice = slice.trim_end_matches("; poses projected");
        assert!(
            stderr.contains(&format!("grid 0.02 m, {terminal_slice}:")),
            "{stderr}"
        );
        let map = std::fs::read_to_string(plots.join("accuracy-map.svg")).unwrap();
        let texts = svg_texts(&map);
        assert!(
            texts.iter().any(|t| t.ends_with(slice)),
            "{model}: no slice in the title: {texts:?}"
        );
        for wanted in ["x (m)", "y (m)", "position error (mm)"] {
            assert_eq!(
                texts.iter().filter(|t| *t == wanted).count(),
                2,
                "{model}: {wanted} on both panels"
            );
        }
        // The panels' captions give the maps' RMS in millimetres, as the JSON report does.
        let before = report["accuracy_map_before"]["position_error_m"]["rms"]
            .as_f64()
            .unwrap();
        let caption = format!(
            "before (nominal model): RMS {} mm",
            legwise::report::plots::style::short_number(before * 1e3)
        );
        assert!(
            texts.iter().any(|t| t.starts_with(&caption)),
            "{model}: {caption} not in {texts:?}"
        );
        // One pose marker per simulated pose (each leg's and the shared ones): two circles
        // (fill, outline) per pose and panel, plus the legend's.
        let per_leg: usize = report["results"][0]["legs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|leg| leg["measurements"].as_u64().unwrap() as usize)
            .sum();
        let source = report["measurements"].as_str().unwrap();
        let shared: usize = source
            .split(" and ")
            .nth(1)
            .and_then(|rest| rest.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{source}"));
        let poses = per_leg + shared;
        assert!(
            texts.contains(&format!("measured poses ({poses})")),
            "{texts:?}"
        );
        assert_eq!(
            map.matches("<circle").count(),
            2 * (2 * poses + 1),
            "{model}"
        );
        let errors = std::fs::read_to_string(plots.join("parameter-errors.svg")).unwrap();
        let texts = svg_texts(&errors);
        for wanted in ["length error (mm)", "k1"] {
            assert!(texts.iter().any(|t| t == wanted), "{model}: {wanted}");
        }
    }
}

#[test]
fn evaluate_on_the_spatial_models_draws_both_models_position_errors() {
    let dir = tempfile::tempdir().unwrap();
    let held_out = dir.path().join("held-out.csv");
    let run = legwise(&[
        "simulate",
        "--model",
        "models/hexapod.yaml",
        "--poses",
        "random",
        "--seed",
        "11",
        "--out",
        held_out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    let plots = dir.path().join("plots");
    let run = legwise(&[
        "evaluate",
        "--model",
        "models/hexapod.yaml",
        "--measurements",
        held_out.to_str().unwrap(),
        "--plots",
        plots.to_str().unwrap(),
        "--json",
        "-",
    ]);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    let report: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let text = report.to_string();
    assert!(
        report["orientation_error_rad"]["rms"].as_f64().unwrap() > 1e-3,
        "{text}"
    );
    let svg = std::fs::read_to_string(plots.join("position-errors.svg")).unwrap();
    let texts = svg_texts(&svg);
    assert!(
        texts
            .iter()
            .any(|t| t.starts_with("hexapod.yaml: RMS ") && t.ends_with("(24 poses)")),
        "{texts:?}"
    );
}

#[test]
fn the_command_line_recovers_both_spatial_models_at_zero_noise() {
    // The README's commands; the hexapod's on a coarser candidate grid (3³ × 5³ poses instead
    // of 5³ × 5³), as its shared selection over the full pool takes seconds in a debug build.
    for (model, grid) in [
        ("models/hexapod.yaml", "0.05"),
        ("models/delta.yaml", "0.02"),
    ] {
        let out = legwise(&[
            "identify",
            "--model",
            model,
            "--grid",
            grid,
            "--noise-scale",
            "0",
            "--json",
            "-",
        ]);
        assert_eq!(out.status.code(), Some(0), "{model}: {}", text(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let legs = report["results"][0]["legs"].as_array().unwrap();
        assert_eq!(legs.len(), if model.contains("hexapod") { 6 } else { 3 });
        for leg in legs {
            let after = leg["parameter_error_rms_after"].as_f64().unwrap();
            let before = leg["parameter_error_rms_before"].as_f64().unwrap();
            assert!(
                after <= 1e-9 && before > 1e-4,
                "{model}: {before} -> {after}"
            );
        }
    }
}
