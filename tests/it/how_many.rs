//! `legwise how-many`: the predicted σ over the workspace by number of selected rows; at the
//! model's own count it is what `legwise identify` predicts; bad input is refused by name.
use crate::cli::{assert_fails_with, legwise_succeeds, text};

fn json_of(args: &[&str]) -> serde_json::Value {
    serde_json::from_slice(&legwise_succeeds(args).stdout).unwrap()
}

#[test]
fn at_the_models_own_count_it_is_what_identify_predicts() {
    let model = "models/delta-probe.yaml";
    let identify = json_of(&["identify", "--model", model, "--json", "-"]);
    let expected = &identify["results"][0]["instrument"]["predicted_position"];
    let table = json_of(&[
        "how-many", "--model", model, "--counts", "9,37", "--json", "-",
    ]);
    let at = |k: usize, key: &str| table[k]["predicted"][key].as_f64().unwrap();
    assert_eq!(table[1]["count"], 37);
    for key in ["rms_m", "max_m"] {
        let want = expected[key].as_f64().unwrap();
        assert!(
            (at(1, key) - want).abs() <= 1e-12 * want,
            "{key}: {} vs {want}",
            at(1, key)
        );
    }
    // A quarter of the rows: a larger σ (about twice, as 1/√N).
    assert!(at(0, "rms_m") > 1.5 * at(1, "rms_m"), "{table}");
}

#[test]
fn the_design_sigma_falls_with_the_rows_and_is_identifys_below_twelve_dof() {
    let table = json_of(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "9,18,27,37,49",
        "--json",
        "-",
    ]);
    let design: Vec<f64> = (0..5)
        .map(|k| table[k]["design"]["rms_m"].as_f64().unwrap())
        .collect();
    assert!(design.windows(2).all(|w| w[1] < w[0]), "{design:?}");
    // 9 touches, 6 unknowns: 3 residual degrees of freedom, so identify's σ are the declared
    // noise's too (docs/statistics.md, "Few degrees of freedom").
    let identify = table[0]["predicted"]["rms_m"].as_f64().unwrap();
    assert!(
        (design[0] - identify).abs() <= 1e-6 * identify,
        "{} vs {identify}",
        design[0]
    );
}

#[test]
fn counts_beyond_the_candidates_say_why_and_bad_input_is_refused() {
    let out = legwise_succeeds(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "60",
    ]);
    assert!(
        text(&out.stdout).contains("60 poses requested but the pool has only 49 candidates"),
        "{}",
        text(&out.stdout)
    );
    assert_fails_with(
        &[
            "how-many",
            "--model",
            "models/delta-probe.yaml",
            "--counts",
            "0",
        ],
        "legwise: --counts: expected between 1 and 100000, found 0",
    );
    assert_fails_with(
        &["how-many", "--model", "models/5r-tracker.yaml"],
        "legwise: models/5r-tracker.yaml: field `instrument.kinematics`: the predicted σ over the workspace is a forward fit's or one from measured poses: expected a model seen through the forward kinematics (`instrument.kinematics: forward`) or without an instrument, found an instrument that measures the platform's pose",
    );
}

#[test]
fn the_curve_has_a_marker_per_count_and_series() {
    let dir = tempfile::tempdir().unwrap();
    let plots = dir.path().join("pictures");
    legwise_succeeds(&[
        "how-many",
        "--model",
        "models/delta-probe.yaml",
        "--counts",
        "9,18,37",
        "--plots",
        plots.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(plots.join("how-many.svg")).unwrap();
    // Three counts, three series (the design's RMS and max, identify's RMS).
    assert_eq!(svg.matches("<circle").count(), 9);
    assert!(svg.contains("design σ, RMS") && svg.contains("identify&apos;s σ, RMS"));
}

/// On the 5R (poses measured, no instrument) the curve's identify column at the model's own
/// count is the default fit's covariance carried to the end effector over the workspace,
/// recomputed here with the closed-form 5R: each parameter's effect on the position the real
/// 5R reaches at the commanded readings by central differences of its forward kinematics,
/// `σ² = tr(G C Gᵀ)` per grid point, their RMS over the points to 1e-6.
#[test]
fn on_the_5r_the_curve_is_the_legs_covariance_carried_to_the_end_effector() {
    use legwise::evaluate::accuracy::{map_grid, result_parameters};
    use legwise::measure::simulate::SimulationOptions;
    use legwise::pipeline::{run, Settings, SimulationSettings};
    use legwise::study::how_many::predicted_by_count;
    use nalgebra::DMatrix;

    use crate::accuracy_map::{five_bar_fk, five_bar_ik};

    let mechanism = crate::support::bundled("5r.yaml");
    let points = predicted_by_count(&mechanism, &[9, 18], None).unwrap();
    let predicted = points[1].predicted.as_ref().unwrap();
    let settings = Settings {
        simulation: SimulationSettings {
            options: SimulationOptions {
                poses_per_leg: Some(18),
                ..SimulationOptions::default()
            },
            ..SimulationSettings::default()
        },
        ..Settings::default()
    };
    let report = run(&mechanism, &settings).unwrap();
    let result = &report.results[0];
    let params = result_parameters(&mechanism, result);
    let mut covariance = DMatrix::zeros(12, 12);
    for (l, leg) in result.legs.iter().enumerate() {
        covariance
            .view_mut((6 * l, 6 * l), (6, 6))
            .copy_from(leg.covariance.as_ref().unwrap());
    }
    let grid = map_grid(&mechanism, mechanism.workspace.grid.unwrap(), 0.95).unwrap();
    let mut squares = Vec::new();
    for pose in &grid {
        let Some(readings) = five_bar_ik(&params, pose[0], pose[1]) else {
            continue;
        };
        let mut g = DMatrix::zeros(2, 12);
        for j in 0..12 {
            let h = 1e-7;
            let moved = |step: f64| {
                let mut phi = params.clone();
                phi[j / 6][j % 6] += step;
                five_bar_fk(&phi, readings).unwrap()
            };
            let (up, down) = (moved(h), moved(-h));
            g[(0, j)] = (up[0] - down[0]) / (2.0 * h);
            g[(1, j)] = (up[1] - down[1]) / (2.0 * h);
        }
        squares.push((&g * &covariance * g.transpose()).trace());
    }
    assert_eq!(predicted.points, squares.len());
    let rms = (squares.iter().sum::<f64>() / squares.len() as f64).sqrt();
    assert!(
        (predicted.rms / rms - 1.0).abs() < 1e-6,
        "{} vs closed form {rms}",
        predicted.rms
    );
    // Half the rows: a larger σ.
    assert!(points[0].predicted.as_ref().unwrap().rms > predicted.rms);
}

/// `legwise select` prints what its rows promise: the design's predicted σ over the workspace
/// from the declared noise, the model's own set fitted on them at the nominal model
/// (`design_sigma`); at the model's count it is how-many's design column to the percent (which
/// fits the simulated, noisy experiment instead of the nominal one).
#[test]
fn select_prints_the_design_sigma_how_many_gives_at_its_count() {
    use legwise::study::how_many::{design_sigma, predicted_by_count};
    let mechanism = crate::support::bundled("delta-probe.yaml");
    let criterion = mechanism.selection.criterion;
    let design = design_sigma(&mechanism, 37, criterion, None).unwrap();
    let curve = predicted_by_count(&mechanism, &[37], None).unwrap();
    let from_curve = curve[0].design.as_ref().unwrap();
    for (a, b) in [(design.rms, from_curve.rms), (design.max, from_curve.max)] {
        assert!((a / b - 1.0).abs() < 1e-2, "{a} vs {b}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("poses.csv");
    let printed = legwise_succeeds(&[
        "select",
        "--model",
        "models/delta-probe.yaml",
        "--out",
        out.to_str().unwrap(),
    ]);
    let expected = format!(
        "RMS {:.4} mm, max {:.4} mm",
        design.rms * 1e3,
        design.max * 1e3
    );
    assert!(
        text(&printed.stdout).contains(&expected),
        "{expected}: {}",
        text(&printed.stdout)
    );
}

/// On the hexapod (all six coordinates measured, no instrument), the end effector's position σ
/// at a pose is the covariance carried by central differences of where the real hexapod goes
/// (`reached_pose`: the model's readings at the pose, the forward kinematics of a hexapod with
/// one parameter moved): its position's rows only (x, y, z), not the orientation's, to 1e-5.
#[test]
fn the_position_sigma_of_a_hexapod_is_its_forward_kinematics_carried_covariance() {
    use legwise::evaluate::accuracy::reached_pose;
    use legwise::evaluate::predicted_pose::position_sigmas;
    use nalgebra::DMatrix;

    let mechanism = crate::support::bundled("hexapod.yaml");
    let params = mechanism.nominal_parameters();
    let unknowns: Vec<(usize, usize)> = mechanism
        .identified_legs()
        .into_iter()
        .flat_map(|l| {
            mechanism.legs[l]
                .identified()
                .into_iter()
                .map(move |c| (l, c))
        })
        .collect();
    let n = unknowns.len();
    // Different σ per unknown, and a correlation between the first two.
    let mut covariance = DMatrix::from_fn(n, n, |i, j| {
        if i == j {
            (1e-4 * (1.0 + 0.1 * i as f64)).powi(2)
        } else {
            0.0
        }
    });
    covariance[(0, 1)] = 0.5 * covariance[(0, 0)].sqrt() * covariance[(1, 1)].sqrt();
    covariance[(1, 0)] = covariance[(0, 1)];
    let home = mechanism.home_pose;
    let mut moved = home;
    moved[0] += 0.02;
    moved[1] -= 0.01;
    moved[3] += 0.02;
    let targets = [home, moved];
    let sigmas = position_sigmas(&mechanism, &params, &covariance, &targets).unwrap();
    for (target, sigma) in targets.iter().zip(&sigmas) {
        let mut g = DMatrix::zeros(3, n);
        for (j, &(leg, column)) in unknowns.iter().enumerate() {
            let h = 1e-6;
            let at = |step: f64| {
                let mut real = params.clone();
                real[leg][column] += step;
                reached_pose(&mechanism, &params, &real, target).unwrap()
            };
            let (up, down) = (at(h), at(-h));
            for k in 0..3 {
                g[(k, j)] = (up[k] - down[k]) / (2.0 * h);
            }
        }
        let expected = (&g * &covariance * g.transpose()).trace().sqrt();
        let sigma = sigma.unwrap();
        assert!(
            (sigma / expected - 1.0).abs() < 1e-5,
            "{sigma} vs {expected}"
        );
    }
}
