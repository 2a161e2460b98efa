//! Spatial instruments (6-DoF frame, 3-D target offsets) on the linear delta (one reflector, the
//! effector translates) and the hexapod (three reflectors, or one camera marker): zero-noise
//! recovery of every identified leg and instrument parameter from a frame perturbed in
//! translation and rotation (library and command line), the Schur-complement step and solve
//! against dense ones, the rank check naming the gauge when everything is freed, and bad
//! spatial blocks named with exit 2 (the simulate → identify round trip of every tracker model
//! is in `instrument_commands.rs`).
use std::path::Path;

use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::Strategy;
use legwise::measure::observe_simulate::simulate_observed;
use legwise::model::Mechanism;
use legwise::solver::bordered::{to_dense, BorderedLeastSquares, DenseView};
use legwise::solver::schur::arrowhead::ArrowheadSystem;
use legwise::solver::{solve, solve_bordered, SolverKind};
use nalgebra::{DMatrix, DVector};
use serde_json::Value;

use crate::cli::{legwise, text};
use crate::instrument_support::{
    assert_recovered, assert_targets_give_the_true_poses, identify_shared, instrument,
    parameter_names, shared, simulation,
};
use crate::support::{bundled, crate_path};

const MODELS: [&str; 2] = ["delta-tracker.yaml", "hexapod-tracker.yaml"];

/// `models/<name>` with `from` replaced by `to` (each must occur), its URDF by absolute path.
fn edited(name: &str, edits: &[(&str, &str)]) -> Mechanism {
    let mut text = std::fs::read_to_string(crate_path(&format!("models/{name}"))).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{name} has no `{from}`");
        text = text.replace(from, to);
    }
    let urdf_name = if name.starts_with("delta") {
        "delta.urdf"
    } else {
        "hexapod.urdf"
    };
    let urdf = std::fs::read_to_string(crate_path(&format!("models/{urdf_name}"))).unwrap();
    Mechanism::parse(&text, Path::new(name), &urdf, Path::new(urdf_name)).unwrap()
}

/// The real frame differs from the nominal one in translation and in rotation.
fn assert_frame_perturbed(mechanism: &Mechanism, real_shared: &[f64]) {
    let instrument = mechanism.instrument.as_ref().unwrap();
    let nominal = instrument.nominal();
    let moved = |range: std::ops::Range<usize>| {
        range
            .map(|k| (real_shared[k] - nominal[k]).abs())
            .fold(0.0, f64::max)
    };
    assert!(moved(0..3) > 1e-3, "{}: translation", mechanism.name);
    assert!(moved(3..6) > 1e-3, "{}: rotation", mechanism.name);
}

#[test]
fn the_spatial_tracker_models_carry_a_six_dof_frame_and_three_dimensional_targets() {
    let delta = bundled("delta-tracker.yaml");
    let instrument = delta.instrument.as_ref().unwrap();
    assert!(instrument.spatial && !instrument.rotates);
    assert_eq!(
        parameter_names(instrument),
        [
            "frame_x",
            "frame_y",
            "frame_z",
            "frame_roll",
            "frame_pitch",
            "frame_yaw",
            "target_x",
            "target_y",
            "target_z"
        ]
    );
    assert_eq!(
        instrument.columns(),
        ["x.reflector", "y.reflector", "z.reflector"]
    );
    let hexapod = bundled("hexapod-tracker.yaml");
    let instrument = hexapod.instrument.as_ref().unwrap();
    assert!(instrument.spatial && instrument.rotates);
    assert_eq!(instrument.parameters.len(), 6 + 3 * 3);
    assert_eq!(instrument.parameters[11].name, "target_z_r2");
    assert_eq!(instrument.columns().len(), 9);
}

#[test]
fn zero_noise_recovers_every_identified_leg_frame_and_offset_of_the_spatial_models() {
    for model in MODELS {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
        assert_frame_perturbed(&mechanism, &experiment.real_shared);
        // The targets give back the true poses at the real instrument.
        assert_targets_give_the_true_poses(&mechanism, &experiment);
        let estimate =
            identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
        assert!(
            estimate.runs[0].converged,
            "{model}: {:?}",
            estimate.runs[0]
        );
        let checked = assert_recovered(&mechanism, &estimate, &experiment, 1e-9);
        assert!(checked >= 17, "{model}: only {checked} identified");
        let rms = instrument(&estimate).rms;
        assert!(rms < 1e-10, "{model}: rms {rms}");
    }
}

#[test]
fn a_camera_marker_measuring_the_hexapod_pose_gives_the_same_zero_noise_recovery() {
    // One pose target instead of the three reflectors: the platform's orientation is the
    // marker's, so only a translation of the platform frame is left to hold (b1); the marker's
    // offset and the other attachments are identified.
    let mechanism = edited(
        "hexapod-tracker.yaml",
        &[
            (
                "    - {name: r1, offset: [0.12, 0.0, 0.03], measures: position, identify: [z], perturbation: 0.002}\n",
                "    - {name: marker, offset: [0.02, -0.03, 0.05], measures: pose, perturbation: 0.002}\n",
            ),
            (
                "    - {name: r2, offset: [-0.06, 0.1, 0.03], measures: position, identify: [x, z], perturbation: 0.002}\n",
                "",
            ),
            (
                "    - {name: r3, offset: [-0.06, -0.1, 0.03], measures: position, perturbation: 0.002}\n",
                "",
            ),
            ("{name: b3x, leg: leg3, attachment: x, identify: false}", "{name: b3x, leg: leg3, attachment: x}"),
            ("{name: b3z, leg: leg3, attachment: z, identify: false}", "{name: b3z, leg: leg3, attachment: z}"),
            ("{name: b5z, leg: leg5, attachment: z, identify: false}", "{name: b5z, leg: leg5, attachment: z}"),
            ("    k1: 1.00048\n", "    k1: 1.00048\n    b3x: 0.08437\n    b3z: 0.00015\n    b5z: -0.00005\n"),
        ],
    );
    let instrument = mechanism.instrument.as_ref().unwrap();
    assert_eq!(
        instrument.columns(),
        [
            "x.marker",
            "y.marker",
            "z.marker",
            "roll.marker",
            "pitch.marker",
            "yaw.marker"
        ]
    );
    let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
    assert_frame_perturbed(&mechanism, &experiment.real_shared);
    let estimate = identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
    assert!(estimate.runs[0].converged);
    assert_recovered(&mechanism, &estimate, &experiment, 1e-9);
}

/// `(JᵀJ + λD²) p = Jᵀr` on the dense Jacobian, by LU of the normal equations.
fn dense_step(
    jacobian: &DMatrix<f64>,
    r: &DVector<f64>,
    lambda: f64,
    scale: &DVector<f64>,
) -> DVector<f64> {
    let mut normal = jacobian.transpose() * jacobian;
    for (i, d) in scale.iter().enumerate() {
        normal[(i, i)] += lambda * d * d;
    }
    normal.lu().solve(&(jacobian.transpose() * r)).unwrap()
}

/// The same step without normal equations: the least-squares solution of `[J; √λ D] p = [r; 0]`
/// by SVD, and the condition number of that stacked matrix.
fn reference_step(
    jacobian: &DMatrix<f64>,
    r: &DVector<f64>,
    lambda: f64,
    scale: &DVector<f64>,
) -> (DVector<f64>, f64) {
    let (m, n) = jacobian.shape();
    let mut stacked = DMatrix::zeros(m + n, n);
    stacked.view_mut((0, 0), (m, n)).copy_from(jacobian);
    for i in 0..n {
        stacked[(m + i, i)] = lambda.sqrt() * scale[i];
    }
    let mut rhs = DVector::zeros(m + n);
    rhs.rows_mut(0, m).copy_from(r);
    let svd = stacked.svd(true, true);
    let condition = svd.singular_values.max() / svd.singular_values.min();
    (svd.solve(&rhs, 0.0).unwrap(), condition)
}

fn relative(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// The damped step by the Schur complement against the dense normal equations (1e-10 where
/// their conditioning allows it: λ ≥ 1e-4 here) and, at every λ, against an SVD solve of the
/// stacked system within the accuracy of any normal-equations solve, `κ² ε` (κ of the stacked
/// matrix; at λ = 1e-6 on the hexapod κ ≈ 5e3, and the dense LU itself is 5e-10 off); then the
/// whole Levenberg–Marquardt solve, Schur against dense, to 1e-10.
#[test]
fn on_the_spatial_models_the_schur_step_and_solve_equal_the_dense_ones() {
    for model in MODELS {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
        let problem =
            IdentificationProblem::through_instrument(&mechanism, &experiment.observations)
                .unwrap();
        // One damped step away from the start, every block and border non-trivial.
        let x = problem.start().map(|v| v * (1.0 + 1e-4));
        let blocks = problem.bordered(&x).unwrap();
        let layout = problem.layout();
        assert!(layout.shared >= 6, "{model}: {layout:?}");
        let (r, jacobian) = to_dense(&layout, &blocks);
        let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
        let scale = DVector::from_fn(layout.unknowns(), |i, _| {
            jacobian.column(i).norm().max(1e-12)
        });
        for lambda in [1e-6, 1e-5, 1e-4, 1e-2, 1.0, 1e2] {
            let schur = system.damped_step(lambda, &scale).unwrap();
            let (reference, condition) = reference_step(&jacobian, &r, lambda, &scale);
            let bound = (condition * condition * f64::EPSILON).max(1e-10);
            let off = relative(&schur, &reference);
            assert!(
                off <= bound,
                "{model} λ {lambda}: {off:e} from SVD, bound {bound:e}"
            );
            if lambda >= 1e-4 {
                let gap = relative(&schur, &dense_step(&jacobian, &r, lambda, &scale));
                assert!(gap <= 1e-10, "{model} λ {lambda}: {gap:e} from dense");
            }
        }
        // The whole solve: Schur-complement LM and dense LM end on the same estimate.
        let schur = solve_bordered(&problem, problem.start()).unwrap();
        let dense = solve(
            &DenseView(&problem),
            problem.start(),
            SolverKind::LevenbergMarquardt,
        )
        .unwrap();
        assert!(schur.converged && dense.converged, "{model}");
        let gap = (&schur.x - &dense.x).amax();
        assert!(gap <= 1e-10, "{model}: Schur and dense differ by {gap:e}");
        assert!((&schur.x - problem.start()).amax() > 1e-4);
    }
}

#[test]
fn freeing_every_base_joint_attachment_and_target_names_the_gauge_of_the_spatial_models() {
    // The hexapod: 48 leg, 6 frame and 9 offset parameters; 6 base-frame and 6 platform-frame
    // directions and the 3 of the reflectors' triangle shape cannot be identified.
    let hexapod = edited(
        "hexapod-tracker.yaml",
        &[
            (", identify: false}", "}"),
            ("    identify: [x, y, z, yaw]\n", ""),
            ("identify: [z], ", ""),
            ("identify: [x, z], ", ""),
        ],
    );
    // The delta: 15 leg, 6 effector-joint, 6 frame parameters; 3 translations and the turn
    // about the towers of base and frame together, and the 6 effector joints against the towers.
    let delta = edited("delta-tracker.yaml", &[(", identify: false}", "}")]);
    for (mechanism, rank, names) in [
        (
            hexapod,
            "rank 48 of 63 parameters",
            ["frame_x", "b1x", "target_y_r1"],
        ),
        (
            delta,
            "rank 17 of 27 parameters",
            ["frame_x", "frame_yaw", "t1x"],
        ),
    ] {
        let experiment = simulate_observed(&mechanism, simulation(0.0)).unwrap();
        let err = identify_shared(&mechanism, &experiment.observations, Strategy::Joint)
            .expect_err("rank-deficient")
            .to_string();
        assert!(err.contains(rank), "{err}");
        for name in names {
            assert!(err.contains(name), "{name}: {err}");
        }
        assert!(err.contains("docs/models.md"), "{err}");
    }
}

/// Every parameter of the joint result in a JSON report: name, identified, estimate, real value
/// (NaN if the report has none).
fn json_parameters(report: &Value) -> Vec<(String, bool, f64, f64)> {
    let joint = &report["results"][0];
    assert!(joint["strategy"].as_str().unwrap().starts_with("joint"));
    let instrument = joint["instrument"]["parameters"].as_array().unwrap();
    let mut all: Vec<&Value> = instrument.iter().collect();
    for leg in joint["legs"].as_array().unwrap() {
        all.extend(leg["parameters"].as_array().unwrap());
    }
    all.iter()
        .map(|p| {
            (
                p["name"].as_str().unwrap().to_string(),
                !p["fixed"].as_bool().unwrap(),
                p["identified"].as_f64().unwrap(),
                p["real"].as_f64().unwrap_or(f64::NAN),
            )
        })
        .collect()
}

#[test]
fn the_command_line_recovers_the_spatial_models_at_zero_noise() {
    for model in MODELS {
        let path = format!("models/{model}");
        let out = legwise(&[
            "identify",
            "--model",
            &path,
            "--poses",
            "random",
            "--noise-scale",
            "0",
            "--json",
            "-",
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        let parameters = json_parameters(&report);
        let mut identified = 0;
        for (name, is_identified, estimate, real) in &parameters {
            assert!(
                (estimate - real).abs() <= 1e-9,
                "{model}: {name} {estimate} but real {real}"
            );
            identified += usize::from(*is_identified);
        }
        assert!(identified >= 17, "{model}: {identified}");
        assert!(parameters.iter().any(|p| p.0 == "frame_yaw" && p.1));
    }
}

#[test]
fn a_bad_spatial_instrument_block_is_named_with_exit_2() {
    let directory = tempfile::tempdir().unwrap();
    let urdf = crate_path("models/hexapod.urdf");
    let base = std::fs::read_to_string(crate_path("models/hexapod-tracker.yaml"))
        .unwrap()
        .replace("urdf: hexapod.urdf", &format!("urdf: {}", urdf.display()));
    let cases = [
        (
            "offset: [-0.06, 0.1, 0.03]",
            "offset: [-0.06, 0.1]",
            "field `instrument.targets[1].offset`: expected [x, y, z] (3 values, metres), found 2 values",
        ),
        (
            "pose: {x: 2.0, y: 1.0, z: 0.4, roll: 0.005, pitch: -0.01, yaw: -2.6}",
            "pose: {x: 2.0, y: 1.0, z: 0.4, tilt: 0.005}",
            "field `instrument.frame.pose.tilt`: `tilt` is not a component of a spatial frame; expected one of x, y, z, roll, pitch, yaw",
        ),
        (
            "    - {name: r3, offset: [-0.06, -0.1, 0.03], measures: position, perturbation: 0.002}\n",
            "",
            "field `instrument.targets`: the platform rotates (roll, pitch or yaw is measured), but the position-only targets `r1`, `r2` do not give its orientation",
        ),
        (
            "offset: [-0.06, -0.1, 0.03]",
            "offset: [0.3, -0.1, 0.03]",
            "field `instrument.targets`: the offsets of the position-only targets `r1`, `r2`, `r3` lie on one line",
        ),
    ];
    for (k, (from, to, expected)) in cases.iter().enumerate() {
        assert!(base.contains(from), "{from}");
        let model = directory.path().join(format!("bad{k}.yaml"));
        std::fs::write(&model, base.replace(from, to)).unwrap();
        let out = legwise(&["identify", "--model", model.to_str().unwrap()]);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains(expected), "{expected}\n{stderr}");
    }
    // A translating platform's target cannot be a pose target.
    let delta = std::fs::read_to_string(crate_path("models/delta-tracker.yaml"))
        .unwrap()
        .replace("measures: position", "measures: pose")
        .replace(
            "urdf: delta.urdf",
            &format!("urdf: {}", crate_path("models/delta.urdf").display()),
        );
    let model = directory.path().join("delta.yaml");
    std::fs::write(&model, delta).unwrap();
    let out = legwise(&["identify", "--model", model.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains(
            "field `instrument.targets[0].measures`: the platform does not rotate (none of roll, \
             pitch, yaw is measured)"
        ),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn with_noise_the_spatial_estimates_are_within_their_sigma_and_the_noise_test_passes() {
    for model in MODELS {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
        let estimate =
            identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
        // The expected residual variances use the noise of x, y, z at every reflector.
        let test = instrument(&estimate)
            .noise_test
            .as_ref()
            .expect("a declared noise");
        assert!(!test.rejected, "{model}: {test:?}");
        assert!((0.5..2.0).contains(&test.sigma_ratio), "{model}: {test:?}");
        for (k, p) in shared(&estimate).iter().enumerate() {
            if let Some(std) = p.std {
                let error = p.estimate - experiment.real_shared[k];
                assert!(
                    error.abs() < 4.0 * std,
                    "{model} {}: error {error} σ {std}",
                    p.name
                );
            }
        }
    }
}

#[test]
fn the_calibrated_spatial_model_carries_the_estimated_frame_and_offsets() {
    let directory = tempfile::tempdir().unwrap();
    let calibrated = directory.path().join("calibrated.yaml");
    let out = legwise(&[
        "identify",
        "--model",
        "models/hexapod-tracker.yaml",
        "--poses",
        "random",
        "--json",
        "-",
        "--calibrated",
        calibrated.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    let parameters = json_parameters(&report);
    let mechanism = Mechanism::load(&calibrated).unwrap();
    let instrument = mechanism.instrument.as_ref().unwrap();
    for p in &instrument.parameters {
        let estimate = parameters.iter().find(|q| q.0 == p.name).unwrap().2;
        assert!(
            (p.nominal - estimate).abs() < 1e-12,
            "{}: {} vs {estimate}",
            p.name,
            p.nominal
        );
    }
    // The estimate moved the frame's yaw (its roll and pitch are held: a levelled tracker) and an offset away from the original nominal.
    let original = bundled("hexapod-tracker.yaml");
    let nominal = original.instrument.as_ref().unwrap().nominal();
    assert!((instrument.parameters[5].nominal - nominal[5]).abs() > 1e-4);
    assert!((instrument.parameters[14].nominal - nominal[14]).abs() > 1e-4);
}
