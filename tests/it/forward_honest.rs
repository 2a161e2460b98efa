//! What a forward fit says about itself (docs/models.md §10): the frame its observations
//! define on a tilted and turned bed, the null directions that move nothing, σ on few degrees
//! of freedom, and the JSON's warnings and full covariance.

use legwise::evaluate::observed_frame::unseen_frame;
use legwise::{run, MapSettings, Mechanism, Settings};
use nalgebra::DMatrix;

use crate::support::bundled;

/// The probe model with its bed held at `roll`, `pitch`, `yaw` (a user who knows the tilt),
/// its simulated real bed the same.
fn held_bed(roll: f64, pitch: f64, yaw: f64) -> Mechanism {
    bundled("delta-probe.yaml").edited(|parts| {
        let instrument = parts.instrument.as_mut().expect("a bed");
        for (name, value) in [
            ("frame_roll", roll),
            ("frame_pitch", pitch),
            ("frame_yaw", yaw),
        ] {
            let p = instrument
                .parameters
                .iter_mut()
                .find(|p| p.name == name)
                .expect("a frame component");
            p.nominal = value;
            parts
                .simulation
                .as_mut()
                .expect("a simulation")
                .real
                .insert(name.to_string(), value);
        }
    })
}

/// The predicted σ (RMS, m) and the map's error in the frame the observations define after
/// the fit (RMS, m), with the motions aligned, of `mechanism`'s simulated run.
fn judged(mechanism: &Mechanism) -> (f64, f64, Vec<String>) {
    let settings = Settings {
        map: Some(MapSettings {
            grid_m: 0.01,
            scale: 0.95,
        }),
        ..Settings::default()
    };
    let report = run(mechanism, &settings).expect("runs");
    let predicted = report.results[0]
        .instrument
        .as_ref()
        .and_then(|i| i.predicted_position.clone())
        .expect("a predicted σ");
    let maps = report.maps.as_ref().expect("maps");
    let seen = maps.after[0]
        .observed_frame
        .clone()
        .expect("an observed frame");
    (predicted.rms, seen.position_error.rms, seen.aligned)
}

#[test]
fn a_tilted_or_turned_bed_is_judged_in_the_frame_its_heights_define() {
    let (level_sigma, level_map, aligned) = judged(&held_bed(0.0, 0.0, 0.0));
    assert_eq!(aligned, ["along x", "along y", "about z"]);
    for tilt in [1e-10, 1e-6, 1e-3, 0.05] {
        for yaw in [0.0, 0.3] {
            let (sigma, map, aligned) = judged(&held_bed(0.8 * tilt, -0.6 * tilt, yaw));
            let case = format!("tilt {tilt}, yaw {yaw}");
            assert_eq!(aligned, ["along x", "along y", "about z"], "{case}");
            assert!(
                (sigma / level_sigma - 1.0).abs() <= 0.01,
                "{case}: predicted σ {sigma} against {level_sigma} level"
            );
            assert!(
                map <= 1.5 * level_map && map >= level_map / 1.5,
                "{case}: map error {map} against {level_map} level"
            );
        }
    }
}

#[test]
fn the_issues_tilted_copy_predicts_as_the_level_model() {
    // The bed tilt the probe model's simulation draws, held: within 10 % of the level model's
    // predicted σ (it was 2.6 times it when only single frame components could be unseen).
    let (level, level_map, _) = judged(&bundled("delta-probe.yaml"));
    let (tilted, tilted_map, _) = judged(&held_bed(0.0008, -0.0006, 0.0));
    assert!((tilted / level - 1.0).abs() <= 0.1, "{tilted} vs {level}");
    assert!(tilted_map <= 1.5 * level_map, "{tilted_map} vs {level_map}");
}

#[test]
fn unseen_frame_motions_are_the_null_space_of_what_the_target_reports() {
    let probe = held_bed(0.02, -0.01, 0.4);
    let instrument = probe.instrument.as_ref().expect("a bed");
    let shared = instrument.nominal();
    let poses: Vec<[f64; 6]> = [[0.0, 0.0], [0.05, 0.01], [-0.03, 0.04], [0.01, -0.05]]
        .iter()
        .map(|&[x, y]| [x, y, 0.05, 0.0, 0.0, 0.0])
        .collect();
    let unseen = unseen_frame(instrument, &shared, &poses);
    assert_eq!(unseen.names, ["along x", "along y", "about z"]);
    // Each unseen twist moves the nozzle within the bed's plane only: its frame z never.
    for j in 0..unseen.motions.ncols() {
        let moved = unseen.motions.column(j);
        let in_plane: f64 = (0..poses.len())
            .map(|i| moved[3 * i].hypot(moved[3 * i + 1]))
            .fold(0.0, f64::max);
        assert!(in_plane > 1e-3, "twist {j} moves the nozzle: {in_plane}");
        for i in 0..poses.len() {
            assert!(moved[3 * i + 2].abs() <= 1e-12 * in_plane, "twist {j}");
        }
    }
    // Checked against the frame's own parametrisation: a finite step of the frame along its
    // own x (base-frame step R_f e_x) leaves every height as it was.
    let f = legwise::model::instrument::Instrument::FRAME;
    let (roll, pitch, yaw) = (shared[f + 3], shared[f + 4], shared[f + 5]);
    let r = nalgebra::Rotation3::from_euler_angles(roll, pitch, yaw);
    let step = r * nalgebra::Vector3::new(1e-3, 0.0, 0.0);
    let mut moved = shared.clone();
    for k in 0..3 {
        moved[f + k] += step[k];
    }
    for pose in &poses {
        let before = legwise::measure::targets::observe(instrument, &shared, pose);
        let after = legwise::measure::targets::observe(instrument, &moved, pose);
        assert!(
            (before[0] - after[0]).abs() <= 1e-15,
            "{before:?} {after:?}"
        );
    }
    // While a step along the base frame's x changes them (the bed is tilted).
    let mut base = shared.clone();
    base[f] += 1e-3;
    let before = legwise::measure::targets::observe(instrument, &shared, &poses[0]);
    let after = legwise::measure::targets::observe(instrument, &base, &poses[0]);
    assert!((before[0] - after[0]).abs() > 1e-6);
}

#[test]
fn a_reflector_sees_every_frame_motion() {
    let hexapod = bundled("hexapod-reflector.yaml");
    let instrument = hexapod.instrument.as_ref().expect("a tracker");
    let home = hexapod.home_pose;
    let mut poses = vec![home];
    for (k, d) in [(0, 0.03), (1, -0.02), (2, 0.02), (5, 0.1)] {
        let mut pose = home;
        pose[k] += d;
        poses.push(pose);
    }
    let unseen = unseen_frame(instrument, &instrument.nominal(), &poses);
    assert!(unseen.is_empty(), "{:?}", unseen.names);
    // At one pose a lone point cannot see the frame turn about itself: three rotations.
    let unseen = unseen_frame(instrument, &instrument.nominal(), &[home]);
    assert_eq!(unseen.twists.ncols(), 3, "{:?}", unseen.names);
    // Turns about the point are no frame axis: each moves it by nothing (the twists in the
    // frame's units, not the scaled ones the SVD saw), and they are counted, not named.
    assert_eq!(unseen.names, ["3 other motion(s)"]);
    for j in 0..3 {
        let twist = unseen.twists.column(j);
        let turn = twist.rows(3, 3).norm();
        assert!(turn > 1e-3, "twist {j} turns: {twist}");
        assert!(
            unseen.motions.column(j).norm() <= 1e-12 * turn,
            "twist {j} moves the point: {}",
            unseen.motions.column(j)
        );
    }
}

/// The full covariance of a result's JSON: its parameter names and matrix.
fn full_covariance(result: &serde_json::Value) -> (Vec<String>, DMatrix<f64>) {
    let covariance = &result["covariance"];
    let names: Vec<String> = covariance["parameters"]
        .as_array()
        .expect("names")
        .iter()
        .map(|n| n.as_str().expect("a name").to_string())
        .collect();
    let rows = covariance["matrix"].as_array().expect("a matrix");
    let n = names.len();
    assert_eq!(rows.len(), n);
    let matrix = DMatrix::from_fn(n, n, |i, j| rows[i][j].as_f64().expect("a number"));
    (names, matrix)
}

/// Each identified parameter's reported std of a result's JSON, by name.
fn reported_std(result: &serde_json::Value, name: &str) -> f64 {
    let legs = result["legs"].as_array().expect("legs");
    let instrument = result["instrument"]["parameters"].as_array();
    legs.iter()
        .flat_map(|l| l["parameters"].as_array().expect("parameters"))
        .chain(instrument.into_iter().flatten())
        .find(|p| p["name"] == name)
        .and_then(|p| p["std"].as_f64())
        .unwrap_or_else(|| panic!("no std of {name}"))
}

#[test]
fn the_json_full_covariance_reproduces_every_std_and_a_derived_sigma() {
    for model in ["delta-probe-distances.yaml", "5r.yaml"] {
        let mechanism = bundled(model);
        let report = run(&mechanism, &Settings::default()).expect("runs");
        let json: serde_json::Value =
            serde_json::from_str(&report.to_json().to_text().expect("text")).expect("JSON");
        let result = &json["results"][0];
        let (names, matrix) = full_covariance(result);
        assert!(!names.is_empty(), "{model}");
        for (i, name) in names.iter().enumerate() {
            let std = reported_std(result, name);
            assert!(
                (matrix[(i, i)].sqrt() - std).abs() <= 1e-12 * std,
                "{model}: {name}: {} vs {std}",
                matrix[(i, i)].sqrt()
            );
        }
        // Symmetric to round-off: 6.9e-13 of its largest entry on the delta's design of main
        // c16f3c2, 1.2e-12 on its mirror image (x → −x), which the D-optimal selection picks
        // since the delta's legs are solved in closed form (a tie broken by round-off).
        assert!((&matrix - matrix.transpose()).amax() <= 4e-12 * matrix.amax());
        // A derived quantity: the difference of the first two parameters, its σ from the
        // matrix against the report's own covariance of the fit.
        let fit = report.results[0]
            .instrument
            .as_ref()
            .and_then(|i| i.covariance.clone());
        let g = DMatrix::from_fn(1, names.len(), |_, j| match j {
            0 => 1.0,
            1 => -1.0,
            _ => 0.0,
        });
        let derived = (&g * &matrix * g.transpose())[(0, 0)];
        match fit {
            Some(c) => {
                let expected = c[(0, 0)] + c[(1, 1)] - 2.0 * c[(0, 1)];
                let size = c[(0, 0)] + c[(1, 1)];
                assert!((derived - expected).abs() <= 1e-12 * size, "{model}");
                // The cross terms are there: without them the σ would differ.
                assert!((c[(0, 1)]).abs() > 1e-6 * expected, "{model}");
            }
            None => {
                // Divide and conquer: the first leg's block.
                let c = report.results[0].legs[0]
                    .covariance
                    .clone()
                    .expect("a block");
                let expected = c[(0, 0)] + c[(1, 1)] - 2.0 * c[(0, 1)];
                let size = c[(0, 0)] + c[(1, 1)];
                assert!((derived - expected).abs() <= 1e-12 * size, "{model}");
            }
        }
    }
}

#[test]
fn every_reason_for_exit_3_is_in_the_json_warnings() {
    // A tolerance the probe model cannot meet: the predicted-σ warning.
    let strict = bundled("delta-probe.yaml").edited(|parts| {
        parts.instrument.as_mut().expect("a bed").tolerance = Some(1e-6);
    });
    let report = run(&strict, &Settings::default()).expect("runs");
    assert!(!report.trusted());
    let json: serde_json::Value =
        serde_json::from_str(&report.to_json().to_text().expect("text")).expect("JSON");
    assert_eq!(json["trusted"], false);
    let issues: Vec<&str> = json["trust_issues"]
        .as_array()
        .expect("issues")
        .iter()
        .map(|i| i.as_str().expect("text"))
        .collect();
    assert_eq!(issues.len(), report.trust_issues().len());
    let warnings: Vec<&str> = json["results"][0]["warnings"]
        .as_array()
        .expect("warnings")
        .iter()
        .map(|w| w.as_str().expect("text"))
        .collect();
    for issue in report.trust_issues() {
        assert!(
            warnings.contains(&issue.as_str()),
            "{issue} not in {warnings:?}"
        );
    }
    assert!(warnings
        .iter()
        .any(|w| w.contains("above the model's tolerance")));
}

/// The joint fit of `mechanism` on its simulated data with `weights`, and the map error in the
/// frame the observations define (RMS, m).
fn fitted(mechanism: &Mechanism, weights: legwise::Weighting) -> (legwise::Report<'_>, f64) {
    let mut settings = Settings {
        map: Some(MapSettings {
            grid_m: 0.01,
            scale: 0.95,
        }),
        ..Settings::default()
    };
    settings.fit.weights = weights;
    let report = run(mechanism, &settings).expect("runs");
    let map = report.maps.as_ref().expect("maps").after[0]
        .observed_frame
        .as_ref()
        .expect("an observed frame")
        .position_error
        .rms;
    (report, map)
}

#[test]
fn the_joint_fit_is_weighted_by_the_declared_noise_by_default() {
    use legwise::identify::problem::IdentificationProblem;
    use legwise::Weighting;
    let mechanism = bundled("delta-probe-distances.yaml");
    let (weighted, weighted_map) = fitted(&mechanism, Weighting::Declared);
    let (plain, plain_map) = fitted(&mechanism, Weighting::Unweighted);
    assert_eq!(weighted.results[0].options.weights, Weighting::Noise);
    assert_eq!(plain.results[0].options.weights, Weighting::Unweighted);
    // Heights (10 µm) and distances (20 µm) each on their own σ: the map is no worse.
    assert!(
        weighted_map <= plain_map,
        "weighted {weighted_map} against unweighted {plain_map}"
    );
    // The weighted estimate is where the weighted objective is stationary, with the weights
    // 1/v_i of the declared noise at the estimate: Σ r_i ∇r_i / v_i = 0 (checked from the
    // problem's own residuals and variances, not from the fit's), and the unweighted one is not.
    let legwise::Measurements::Targets(observations) = &weighted.measurements else {
        panic!("targets");
    };
    let problem =
        IdentificationProblem::through_instrument(&mechanism, observations).expect("a problem");
    let noise = weighted.results[0]
        .options
        .expected_noise(&mechanism)
        .expect("a declared noise");
    let stationarity = |report: &legwise::Report<'_>| -> f64 {
        let estimates: Vec<(String, f64)> = report.results[0]
            .parameters()
            .map(|p| (p.name.clone(), p.estimate))
            .collect();
        let x = nalgebra::DVector::from_iterator(
            problem.names().len(),
            problem
                .names()
                .iter()
                .map(|n| estimates.iter().find(|(m, _)| m == n).expect("named").1),
        );
        let (r, jacobian) = problem.residuals_and_jacobian(&x).expect("evaluates");
        let v = problem.row_variances(&x, &noise).expect("variances");
        let weighted_r = nalgebra::DVector::from_fn(r.len(), |i, _| r[i] / v[i]);
        let gradient = jacobian.transpose() * weighted_r;
        // Relative to the gradient's size term by term.
        let size: f64 = (0..jacobian.ncols())
            .map(|j| {
                (0..r.len())
                    .map(|i| (jacobian[(i, j)] * r[i] / v[i]).abs())
                    .sum::<f64>()
            })
            .fold(0.0, f64::max);
        gradient.amax() / size
    };
    let at_weighted = stationarity(&weighted);
    let at_plain = stationarity(&plain);
    assert!(at_weighted <= 1e-8, "weighted gradient {at_weighted}");
    assert!(at_plain > 1e-3, "unweighted gradient {at_plain}");
}

#[test]
fn freed_platform_holds_are_directions_moving_no_reached_point() {
    use legwise::{PoseSource, SimulationSettings};
    // The attachments that define the platform frame freed: six null directions that move
    // the reflector by round-off only; none is described as a motion.
    let freed = bundled("hexapod-reflector.yaml").edited(|parts| {
        for leg in &mut parts.legs {
            for p in &mut leg.params {
                if ["b1x", "b1y", "b1z", "b3x", "b3z", "b5z"].contains(&p.name.as_str()) {
                    p.identified = true;
                }
            }
        }
    });
    let settings = Settings {
        simulation: SimulationSettings {
            poses: PoseSource::Random,
            ..SimulationSettings::default()
        },
        ..Settings::default()
    };
    let message = run(&freed, &settings)
        .expect_err("rank-deficient")
        .to_string();
    assert!(
        message.contains("cannot see these motions of the reached points: 6 direction(s) moving no reached point;"),
        "{message}"
    );
    let unseen = message
        .split("cannot see these motions of the reached points:")
        .nth(1)
        .and_then(|rest| rest.split("; the least seen").next())
        .expect("the unseen motions");
    assert_eq!(unseen.trim(), "6 direction(s) moving no reached point");
    assert!(
        message.contains("e.g. the attachments or target offsets that define the platform frame"),
        "{message}"
    );
}

/// The predicted σ is sampled on every horizontal slice of the region above the bed: for
/// delta-probe.yaml (a cylinder of radius 0.08 m and height 0.1 m about z = 0.05 m, shrunk to
/// 0.95, the map's grid) 180 points over the slices whose nozzle clears the bed;
/// hexapod-reflector.yaml's region 36. A change of how many slices there are (or of their
/// spacing) changes these counts.
#[test]
fn the_predicted_sigma_is_sampled_on_the_slices_above_the_bed() {
    for (model, expected) in [("delta-probe.yaml", 180), ("hexapod-reflector.yaml", 36)] {
        let mechanism = bundled(model);
        let report = run(&mechanism, &Settings::default()).expect("runs");
        let predicted = report.results[0]
            .instrument
            .as_ref()
            .and_then(|i| i.predicted_position.clone())
            .expect("a predicted σ");
        assert_eq!(predicted.points, expected, "{model}");
    }
}
