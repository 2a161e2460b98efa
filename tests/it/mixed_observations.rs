//! Mixed rows (`instrument.poses`): a forward model's touches beside a few rows of a platform
//! pose measured in the base frame (models/delta-probe-poses.yaml), one problem of both kinds
//! of residual block. The Jacobian against central differences, the noise's reach recomputed
//! from perturbed data, exact recovery at zero noise, what the poses let the rank check see,
//! the CSV round trip and bad input.

use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::Strategy;
use legwise::measure::observations::{self, Observations};
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;
use legwise::pipeline::PoseSource;
use legwise::report::selection::forward_pose_file;
use legwise::selection::forward_design::select_forward;
use nalgebra::{DMatrix, DVector};

use crate::forward_observations::{
    assert_recovered, exact, experiment_at, jacobian_gap, parse_model,
};
use crate::instrument_support::identify_shared;
use crate::support::{bundled, crate_path};

/// The bundled model of touches and measured poses.
fn mixed() -> Mechanism {
    bundled("delta-probe-poses.yaml")
}

/// The model's simulated experiment (random rows, seed 3) at `noise_scale`.
fn experiment(mechanism: &Mechanism, noise_scale: f64) -> (Observations, Vec<Vec<f64>>, Vec<f64>) {
    experiment_at(mechanism, noise_scale, PoseSource::Random, None)
}

/// `observations` with the pose of its last row of a measured pose given to its first touch
/// too (the readings of that touch unchanged): a row of both kinds.
fn with_a_touch_measured(mut observations: Observations) -> Observations {
    let pose = observations.rows.iter().rev().find_map(|r| r.pose);
    let touch = observations
        .rows
        .iter_mut()
        .find(|r| !r.observed.is_empty());
    touch.expect("a touch").pose = pose;
    observations
}

#[test]
fn the_mixed_jacobian_matches_central_differences() {
    let mechanism = mixed();
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let poses = observations
        .rows
        .iter()
        .filter(|r| r.pose.is_some())
        .count();
    assert_eq!(poses, 6, "the model's six measured poses");
    for data in [observations.clone(), with_a_touch_measured(observations)] {
        let problem = IdentificationProblem::through_instrument(&mechanism, &data).unwrap();
        let start = problem.start();
        let (r, jacobian) = problem.residuals_and_jacobian(&start).unwrap();
        let blocks = problem.blocks().len();
        assert!(
            blocks >= 18,
            "{blocks} blocks: every leg at every measured pose"
        );
        // The blocks' rows first, then one per touch.
        assert_eq!(r.len(), blocks + 37);
        // A block's row moves no shared parameter (its pose is measured, not seen).
        let shared = problem.shared_columns().len();
        let first = problem.parameter_count() - shared;
        let by_shared = jacobian.view((0, first), (blocks, shared));
        assert!(by_shared.iter().all(|&v| v == 0.0), "{by_shared}");
        let moved = DVector::from_fn(start.len(), |j, _| start[j] + 1e-4 * ((j % 5) as f64 - 2.0));
        for x in [start, moved] {
            let gap = jacobian_gap(&problem, &x);
            assert!(
                gap <= 1e-6,
                "Jacobian against central differences {gap:.2e}"
            );
        }
    }
}

/// Every residual's derivative with respect to every noisy value of `data` (each touch's
/// height, each measured pose's coordinates, each row's readings, each distance) by central
/// differences of the problem's residuals at `x`, times the value's σ: the columns of `W` with
/// `V = W Wᵀ`.
pub(crate) fn loadings_by_perturbation(
    mechanism: &Mechanism,
    data: &Observations,
    x: &DVector<f64>,
    noise: &MeasurementNoise,
) -> DMatrix<f64> {
    let residuals = |data: &Observations| {
        let problem = IdentificationProblem::through_instrument(mechanism, data).unwrap();
        problem.residuals(x).unwrap()
    };
    let instrument = mechanism.instrument.as_ref().unwrap();
    let pose_sigma = instrument.poses.as_ref().map_or([0.0; 6], |p| p.noise);
    let distance_sigma = instrument.distances.as_ref().map_or(0.0, |d| d.noise);
    let mut columns: Vec<DVector<f64>> = Vec::new();
    let mut column = |edit: &dyn Fn(&mut Observations, f64), sigma: f64| {
        if sigma == 0.0 {
            return;
        }
        let h = 1e-7;
        let (mut up, mut down) = (data.clone(), data.clone());
        edit(&mut up, h);
        edit(&mut down, -h);
        columns.push((residuals(&up) - residuals(&down)) * (sigma / (2.0 * h)));
    };
    for i in 0..data.rows.len() {
        if !data.rows[i].observed.is_empty() {
            column(&|d, h| d.rows[i].observed[0] += h, noise.pose[2]);
        }
        if data.rows[i].pose.is_some() {
            for c in 0..6 {
                let edit = move |d: &mut Observations, h: f64| {
                    if let Some(p) = d.rows[i].pose.as_mut() {
                        p[c] += h;
                    }
                };
                column(&edit, pose_sigma[c]);
            }
        }
        for l in 0..data.rows[i].readings.len() {
            let edit = move |d: &mut Observations, h: f64| {
                if let Some(s) = d.rows[i].readings[l].as_mut() {
                    *s += h;
                }
            };
            column(&edit, noise.reading);
        }
    }
    for k in 0..data.distances.len() {
        column(&|d, h| d.distances[k].value += h, distance_sigma);
    }
    DMatrix::from_columns(&columns)
}

#[test]
fn the_noise_reaches_the_residuals_as_perturbing_the_data_shows() {
    // Readings with noise too: a row of both kinds shares them between its touch and its
    // legs' blocks.
    let mechanism = mixed().edited(|parts| {
        if let Some(noise) = parts.noise.as_mut() {
            noise.reading = 3e-6;
        }
    });
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let data = with_a_touch_measured(observations);
    let problem = IdentificationProblem::through_instrument(&mechanism, &data).unwrap();
    let x = problem.start();
    let noise = mechanism.noise.expect("declared noise");
    let (_, jacobian) = problem.residuals_and_jacobian(&x).unwrap();
    let loadings = problem.noise_loadings(&x, &noise).unwrap();
    let w = loadings_by_perturbation(&mechanism, &data, &x, &noise);
    // Jᵀ V J, and V's diagonal, both ways.
    let meat = loadings.meat(&jacobian);
    let by_data = jacobian.transpose() * &w * w.transpose() * &jacobian;
    let gap = (&meat - &by_data).amax() / by_data.amax();
    assert!(gap <= 1e-6, "Jᵀ V J: {gap:.2e} relative");
    let variances = loadings.variances();
    for (i, v) in variances.iter().enumerate() {
        let expected = w.row(i).norm_squared();
        assert!(
            (v - expected).abs() <= 1e-6 * expected,
            "residual {i}: variance {v:.6e} vs {expected:.6e} from the data"
        );
    }
}

#[test]
fn at_zero_noise_touches_and_measured_poses_recover_all_eighteen_parameters() {
    let mechanism = exact(&mixed());
    for poses in [PoseSource::Random, PoseSource::Selected] {
        let (observations, legs, shared) = experiment_at(&mechanism, 0.0, poses, None);
        let result = identify_shared(&mechanism, &observations, Strategy::Joint).unwrap();
        let count = assert_recovered(&result, (&legs, &shared), 1e-9);
        assert_eq!(count, 18, "{poses:?}");
    }
}

#[test]
fn measured_poses_see_what_heights_on_a_plane_cannot() {
    let mechanism = mixed();
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let mut touches = observations.clone();
    touches.rows.retain(|r| r.pose.is_none());
    let message = identify_shared(&mechanism, &touches, Strategy::Joint)
        .expect_err("heights alone cannot see 18 unknowns")
        .to_string();
    assert!(message.contains("rank 14 of 18"), "{message}");
    assert!(
        message.contains("translation along x, translation along y")
            && message.contains("rotation about z"),
        "{message}"
    );
    let result = identify_shared(&mechanism, &observations, Strategy::Joint).unwrap();
    let instrument = result.instrument.expect("the instrument's estimate");
    let frame_z = instrument.parameters.iter().find(|p| p.name == "frame_z");
    assert!(frame_z.is_some_and(|p| p.std.is_some_and(|s| s > 0.0)));
}

#[test]
fn measured_poses_round_trip_through_the_csv() {
    let mechanism = mixed();
    let (observations, _, _) = experiment(&mechanism, 1.0);
    let data = with_a_touch_measured(observations);
    let text = observations::to_csv(&mechanism, &data).unwrap();
    assert!(text.lines().next().unwrap().ends_with(",x,y,z"), "{text}");
    let read = observations::parse(&text, std::path::Path::new("m.csv"), &mechanism).unwrap();
    for (a, b) in read.rows.iter().zip(&data.rows) {
        assert_eq!(
            (&a.observed, &a.readings, a.pose),
            (&b.observed, &b.readings, b.pose)
        );
    }
    assert_eq!(read.rows.len(), data.rows.len());
}

/// The error of reading `text` (a CSV of the bundled mixed model).
fn read_error(text: &str) -> String {
    observations::parse(text, std::path::Path::new("m.csv"), &mixed())
        .expect_err("bad input")
        .to_string()
}

#[test]
fn bad_measured_poses_are_named_by_line_and_column() {
    let header = "z.nozzle,C1,C2,C3,id,x,y,z\n";
    let touch = "0.0,0.27,0.31,0.23,t1,,,\n";
    // A coordinate missing.
    let message = read_error(&format!("{header}{touch},0.32,0.29,0.31,p,0.01,,0.05\n"));
    assert!(
        message.contains("line 3, column `y`") && message.contains("measured pose"),
        "{message}"
    );
    // A pose without any reading.
    let message = read_error(&format!("{header}{touch},,,,p,0.01,0.02,0.05\n"));
    assert!(
        message.contains("line 3") && message.contains("no reading"),
        "{message}"
    );
    // A touch with a measured pose still needs every reading (its forward kinematics).
    let message = read_error(&format!("{header}0.0,0.27,,0.23,t2,0.01,0.02,0.05\n"));
    assert!(
        message.contains("line 2, column `C2`") && message.contains("missing reading"),
        "{message}"
    );
    // Only some of the pose's columns.
    let message = read_error("z.nozzle,C1,C2,C3,x,z\n0.0,0.27,0.31,0.23,,\n");
    assert!(
        message.contains("header") && message.contains("`y`"),
        "{message}"
    );
    // A pose in the file of a model that declares none.
    let probe = bundled("delta-probe.yaml");
    let message = observations::parse(
        &format!("{header}{touch}"),
        std::path::Path::new("m.csv"),
        &probe,
    )
    .expect_err("no measured poses in this model")
    .to_string();
    assert!(message.contains("unknown column `x`"), "{message}");
    // A distance to a row of a measured pose that lacks a reading.
    let distances = parse_model(
        &std::fs::read_to_string(crate_path("models/delta-probe-poses.yaml"))
            .unwrap()
            .replace(
                "  poses: {",
                "  distances: {target: nozzle, noise: 2.0e-5}\n  poses: {",
            ),
    )
    .unwrap();
    let text = "z.nozzle,C1,C2,C3,id,from,to,distance,x,y,z\n\
                0.0,0.27,0.31,0.23,t1,,,,,,\n\
                ,0.32,,0.31,p,,,,0.01,0.02,0.05\n\
                ,,,,,t1,p,0.05,,,\n";
    let message = observations::parse(text, std::path::Path::new("m.csv"), &distances)
        .expect_err("a distance's row needs every reading")
        .to_string();
    assert!(
        message.contains("line 4, column `to`") && message.contains("lacks a reading"),
        "{message}"
    );
    // A row of readings alone is what a distance names, or nothing to fit.
    let named = "z.nozzle,C1,C2,C3,id,from,to,distance,x,y,z\n\
                 0.0,0.27,0.31,0.23,t1,,,,,,\n\
                 ,0.32,0.29,0.31,r,,,,,,\n\
                 ,,,,,t1,r,0.05,,,\n";
    let read = observations::parse(named, std::path::Path::new("m.csv"), &distances).unwrap();
    assert_eq!((read.rows.len(), read.distances.len()), (2, 1));
    let unnamed = named.replace(",,,,,t1,r,0.05,,,\n", "");
    let message = observations::parse(&unnamed, std::path::Path::new("m.csv"), &distances)
        .expect_err("a row of readings alone that no distance names")
        .to_string();
    assert!(
        message.contains("line 3") && message.contains("nothing to fit"),
        "{message}"
    );
}

#[test]
fn the_poses_block_is_checked_when_the_model_loads() {
    let text = std::fs::read_to_string(crate_path("models/delta-probe-poses.yaml")).unwrap();
    for (edit, field, words) in [
        (
            text.replace("kinematics: forward", "kinematics: inverse")
                .replace("measures: [z], touch: 0.0", "measures: position"),
            "instrument.poses",
            "kinematics: forward",
        ),
        (
            text.replace("noise: {x: 2.0e-5,", "noise: {readings: 1.0e-6, x: 2.0e-5,"),
            "instrument.poses.noise.readings",
            "noise.readings",
        ),
        (
            text.replace(
                "noise: {x: 2.0e-5, y: 2.0e-5, z: 2.0e-5}",
                "noise: {x: 0.0}",
            ),
            "instrument.poses.noise",
            "positive standard deviation",
        ),
        (
            text.replace("noise: {x: 2.0e-5,", "noise: {yaw: 1.0e-5, x: 2.0e-5,"),
            "instrument.poses.noise.yaw",
            "measured coordinate",
        ),
    ] {
        let message = parse_model(&edit)
            .expect_err("a bad poses block")
            .to_string();
        assert!(
            message.contains(field) && message.contains(words),
            "{field}: {message}"
        );
    }
}

#[test]
fn the_instrument_blocks_own_noise_takes_the_runs_noise_scale() {
    // Measured poses' σ and distances' σ are declared in the instrument block, the touches'
    // in the model's noise: at noise scale 2, every loading doubles, not only the touches'.
    for model in ["delta-probe-poses.yaml", "delta-probe-distances.yaml"] {
        let mechanism = bundled(model);
        let (observations, _, _) = experiment(&mechanism, 1.0);
        let problem = IdentificationProblem::through_instrument(&mechanism, &observations).unwrap();
        let x = problem.start();
        let at = |scale: f64| {
            let options = legwise::identify::result::FitOptions {
                noise_scale: scale,
                ..Default::default()
            };
            let noise = options.expected_noise(&mechanism).expect("declared noise");
            problem.noise_loadings(&x, &noise).unwrap().rows
        };
        let (once, twice) = (at(1.0), at(2.0));
        let mut own = 0;
        for ((a, wa), (b, wb)) in once.iter().zip(&twice) {
            assert_eq!(a, b);
            for (u, v) in wa.iter().zip(wb) {
                assert!(
                    (2.0 * u - v).abs() <= 1e-15 * u.abs().max(1e-300),
                    "{model}"
                );
                own += usize::from(*u != 0.0);
            }
        }
        assert!(own > 0, "{model}: loadings");
    }
}

#[test]
fn the_selected_touches_and_poses_make_a_template_that_reads_back_and_identifies() {
    let mechanism = mixed();
    let criterion = mechanism.selection.criterion;
    let design = select_forward(&mechanism, None, 37, criterion).unwrap();
    assert_eq!((design.poses.len(), design.measured_poses.len()), (37, 6));
    // The poses to measure sit above the bed (the nozzle 0.02 m under the effector).
    assert!(
        design.measured_poses.iter().all(|p| p[2] > 0.02),
        "{:?}",
        design.measured_poses
    );
    let template = forward_pose_file(&mechanism, &design).unwrap();
    let mut lines = template.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    // Filled as the nominal mechanism would: each touch at height 0, each pose measured where
    // it was commanded (the readings left empty: the nominal model's at the commanded pose).
    let mut filled = vec![header.join(",")];
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        if cells[column("id")].starts_with('t') {
            cells[column("z.nozzle")] = "0".into();
        } else {
            for c in ["x", "y", "z"] {
                cells[column(c)] = cells[column(&format!("pose.{c}"))].clone();
            }
        }
        filled.push(cells.join(","));
    }
    let text = filled.join("\n") + "\n";
    let data = observations::parse(&text, std::path::Path::new("m.csv"), &mechanism).unwrap();
    assert_eq!(data.rows.iter().filter(|r| r.pose.is_some()).count(), 6);
    let problem = IdentificationProblem::through_instrument(&mechanism, &data).unwrap();
    let r = problem.residuals(&problem.start()).unwrap();
    assert_eq!(r.len(), 6 * 3 + 37);
    assert!(r.amax() <= 1e-12, "{}", r.amax());
}

#[test]
fn evaluate_takes_reading_residuals_at_the_rows_of_a_measured_pose_only() {
    use legwise::evaluate::through_instrument::evaluate_observed;
    let mechanism = mixed();
    let (observations, legs, _) = experiment(&mechanism, 0.0);
    let evaluation = evaluate_observed(&mechanism, &observations).unwrap();
    for (l, leg) in evaluation.reading_residual.iter().enumerate() {
        assert_eq!(leg.rows, 6, "{}: the six measured poses", leg.leg);
        // The nominal model against exact data: its leg's reading error at each pose.
        let expected: Vec<f64> = observations
            .rows
            .iter()
            .filter_map(|r| r.pose.map(|pose| (pose, r.readings[l].unwrap())))
            .map(|(pose, reading)| {
                let model = &mechanism.legs[l];
                let home = mechanism.home_pose;
                let nominal = legwise::kinematics::inverse::predict_reading(
                    model,
                    &model.nominal(),
                    &pose,
                    &home,
                )
                .unwrap();
                let real =
                    legwise::kinematics::inverse::predict_reading(model, &legs[l], &pose, &home)
                        .unwrap();
                assert!(
                    (real - reading).abs() <= 1e-12,
                    "zero-noise readings are the real legs'"
                );
                nominal - reading
            })
            .collect();
        let rms = (expected.iter().map(|e| e * e).sum::<f64>() / 6.0).sqrt();
        let reported = leg.rms.expect("residuals");
        assert!((reported - rms).abs() <= 1e-12, "{reported} vs {rms}");
    }
    let mut touches = observations;
    touches.rows.retain(|r| r.pose.is_none());
    let evaluation = evaluate_observed(&mechanism, &touches).unwrap();
    assert!(evaluation.reading_residual.iter().all(|l| l.rms.is_none()));
}

#[test]
fn a_workspace_with_no_pose_above_the_touch_surface_is_an_error_not_a_hang() {
    // The region above z = 0.06 (the nozzle above 0.04), home below it (the nozzle at 0.03)
    // and the bed at 0.035: every pose of the region is on the far side of the bed from home.
    let text = std::fs::read_to_string(crate_path("models/delta-probe-poses.yaml"))
        .unwrap()
        .replace(
            "region: {cylinder: {centre: [0.0, 0.0, 0.05], radius: 0.08, height: 0.1}}",
            "region: {cylinder: {centre: [0.0, 0.0, 0.08], radius: 0.08, height: 0.04}}",
        )
        .replace("touch: 0.0,", "touch: 0.035,");
    let mechanism = parse_model(&text).expect("the edited model loads");
    let settings = legwise::pipeline::SimulationSettings {
        options: Default::default(),
        poses: PoseSource::Random,
        grid: None,
    };
    let message = legwise::pipeline::simulate(&mechanism, &settings)
        .expect_err("no pose to measure above the bed")
        .to_string();
    assert!(
        message.contains("instrument.poses.simulate") && message.contains("touch surface"),
        "{message}"
    );
}
