//! Bad input never panics and never yields NaN: each defect gives a one-line error naming the
//! file and the line or field. One test per defect; the fixtures are in `tests/data/` (see its
//! README). The full message is asserted wherever it is deterministic.
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use legwise::error::Error;
use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::file::read;
use legwise::model::Mechanism;
use legwise::solver::SolverKind;

use crate::support::{bundled, crate_path};

/// Absolute path of a fixture in `tests/data/`.
fn data(name: &str) -> PathBuf {
    crate_path(&format!("tests/data/{name}"))
}

/// The message, after checking it is one line without NaN.
fn message(err: &Error) -> String {
    let text = err.to_string();
    assert!(!text.contains('\n'), "not one line: {text:?}");
    assert!(!text.contains("NaN"), "mentions NaN: {text:?}");
    text
}

/// Loads a fixture model that must fail; returns its path and the message.
fn model_error(name: &str) -> (PathBuf, String) {
    let path = data(name);
    let err = Mechanism::load(&path).expect_err("the model must be rejected");
    (path.clone(), message(&err))
}

/// Reads a fixture CSV for the bundled 5R and identifies from it (divide and conquer,
/// Gauss–Newton); returns its path and the message of the error that must occur.
fn measurement_error(name: &str) -> (PathBuf, String) {
    let mech = bundled("5r.yaml");
    let path = data(name);
    let err = read(&path, &mech)
        .and_then(|set| {
            identify(
                &mech,
                &set,
                Strategy::DivideAndConquer,
                SolverKind::GaussNewton,
            )
        })
        .expect_err("the measurements must be rejected");
    (path.clone(), message(&err))
}

/// The OS's message for reading a missing file.
fn not_found(path: &Path) -> String {
    std::fs::read_to_string(path)
        .expect_err("the file must not exist")
        .to_string()
}

// ---- controls: the fixtures differ from valid input by their one defect ----

#[test]
fn the_control_model_copy_loads() {
    let mech = Mechanism::load(&data("5r_ok.yaml")).expect("control model loads");
    assert_eq!(mech.legs.len(), 2);
}

#[test]
fn the_control_csv_identifies_the_nominal_parameters() {
    let mech = bundled("5r.yaml");
    let set = read(&data("valid.csv"), &mech).expect("control CSV reads");
    assert_eq!(set.len(), 10);
    let result = identify(
        &mech,
        &set,
        Strategy::DivideAndConquer,
        SolverKind::GaussNewton,
    )
    .expect("control CSV identifies");
    for (leg, estimate) in mech.legs.iter().zip(&result.legs) {
        for (param, p) in leg.params.iter().zip(&estimate.parameters) {
            assert!(
                (p.estimate - param.nominal).abs() < 1e-9,
                "{}: {} vs nominal {}",
                p.name,
                p.estimate,
                param.nominal
            );
        }
    }
}

// ---- the model file ----

#[test]
fn a_missing_model_file_names_the_file() {
    let path = data("no_such_model.yaml");
    let err = Mechanism::load(&path).expect_err("missing model");
    assert_eq!(
        message(&err),
        format!("{}: {}", path.display(), not_found(&path))
    );
}

#[test]
fn a_yaml_syntax_error_names_the_line_and_column() {
    let (path, msg) = model_error("5r_syntax_error.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 12 column 6: while parsing a block mapping, did not find expected key",
            path.display()
        )
    );
}

#[test]
fn an_unknown_field_is_named_with_its_line_and_the_expected_fields() {
    let (path, msg) = model_error("5r_unknown_field.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 12 column 27: legs[0].actuator: unknown field `gian`, expected one of \
             joint, gain, offset",
            path.display()
        )
    );
}

#[test]
fn a_missing_urdf_names_the_field_and_the_urdf_path() {
    let (path, msg) = model_error("5r_missing_urdf.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: field `urdf`: URDF file `{}` not found",
            path.display(),
            data("no_such_robot.urdf").display()
        )
    );
}

#[test]
fn a_chain_joint_not_in_the_urdf_names_the_chain_entry() {
    let (path, msg) = model_error("5r_chain_joint_not_in_urdf.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: field `legs[1].chain[2]`: joint `Q2` is not in the URDF `5r.urdf`",
            path.display()
        )
    );
}

/// urdf-rs silently gives a joint without `<axis>` the axis x: a planar model catches it.
#[test]
fn a_revolute_joint_off_the_plane_is_named() {
    let (path, msg) = model_error("5r_missing_axis.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: field `legs[0].chain`: joint `A1` has world axis (1.000, 0.000, 0.000) at home; a \
             planar model (z not measured) needs revolute axes along z and prismatic axes in the \
             x-y plane (check its <axis> in the URDF)",
            path.display()
        )
    );
}

#[test]
fn a_parameter_on_a_joint_not_in_the_urdf_names_the_parameter_entry() {
    let (path, msg) = model_error("5r_parameter_joint_not_in_urdf.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: field `parameters[7].joint`: joint `C2` is not in the URDF `5r.urdf`",
            path.display()
        )
    );
}

/// The streaming pre-scan finds the unclosed `<joint>` of line 9 when `</robot>` closes.
#[test]
fn a_malformed_urdf_names_the_urdf_file_and_line() {
    let (_, msg) = model_error("5r_broken_urdf.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 9: not well-formed XML: ill-formed document: expected `</joint>`, but \
             `</robot>` was found",
            data("broken.urdf").display()
        )
    );
}

// ---- the measurement CSV ----

#[test]
fn a_missing_csv_names_the_file() {
    let mech = bundled("5r.yaml");
    let path = data("no_such_measurements.csv");
    let err = read(&path, &mech).expect_err("missing CSV");
    assert_eq!(
        message(&err),
        format!("{}: {}", path.display(), not_found(&path))
    );
}

#[test]
fn a_non_numeric_cell_names_the_line_and_column() {
    let (path, msg) = measurement_error("non_numeric.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 3, column `y`: expected a finite number in metres, found `1.1695e`",
            path.display()
        )
    );
}

#[test]
fn a_nan_cell_names_the_line_and_column() {
    let mech = bundled("5r.yaml");
    let path = data("nan_cell.csv");
    let err = read(&path, &mech).expect_err("NaN cell");
    // The only place NaN may appear: quoting the offending cell.
    assert_eq!(
        err.to_string(),
        format!(
            "{}: line 4, column `A1`: expected a finite number in SI units (radians or metres), found `NaN`",
            path.display()
        )
    );
}

#[test]
fn a_duplicated_column_is_rejected() {
    let (path, msg) = measurement_error("duplicate_column.csv");
    assert_eq!(
        msg,
        format!("{}: header: column `A2` appears twice", path.display())
    );
}

#[test]
fn a_missing_column_is_named_with_the_expected_header() {
    let (path, msg) = measurement_error("missing_column.csv");
    assert_eq!(
        msg,
        format!(
            "{}: header: missing column `A2`; expected the columns leg, x, y, A1, A2",
            path.display()
        )
    );
}

#[test]
fn a_header_only_csv_names_line_2() {
    let (path, msg) = measurement_error("header_only.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 2: no measurement rows after the header",
            path.display()
        )
    );
}

#[test]
fn an_unknown_leg_names_the_line_and_the_legs() {
    let (path, msg) = measurement_error("unknown_leg.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 3, column `leg`: unknown leg `leg3`; expected one of leg1, leg2 or empty",
            path.display()
        )
    );
}

#[test]
fn a_short_row_names_the_line_and_the_field_count() {
    let (path, msg) = measurement_error("short_row.csv");
    assert_eq!(
        msg,
        format!("{}: line 3: expected 5 fields, found 4", path.display())
    );
}

// ---- identification ----

#[test]
fn an_unreachable_pose_names_the_csv_line() {
    let (path, msg) = measurement_error("unreachable.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 5: leg `leg1` cannot reach the pose (closure residual 1.204e0 m after 40 Newton iterations)",
            path.display()
        )
    );
}

#[test]
fn too_few_poses_are_rank_deficient_and_name_the_parameter() {
    let (path, msg) = measurement_error("five_poses.csv");
    assert_eq!(
        msg,
        format!(
            "{}: leg `leg1`: rank-deficient identification: rank 5 of 6 parameters; cannot be \
             identified: gamma1 (only 5 measurements for 6 parameters)",
            path.display()
        )
    );
}

/// All of leg1's poses are 1.2 m from A1: θ₁ − atan2(P − A1) is the same at every pose, so
/// the columns of l1, L1 and gamma1 are proportional (rank 4). Which two of the three are
/// named, and the basis of the 2-D null space, are decided by rounding: the test checks the
/// names belong to that triple rather than pinning them.
#[test]
fn poses_at_one_distance_from_the_base_joint_are_rank_deficient_and_name_the_parameters() {
    let (path, msg) = measurement_error("same_distance.csv");
    let prefix = format!(
        "{}: leg `leg1`: rank-deficient identification: rank 4 of 6 parameters; cannot be identified: ",
        path.display()
    );
    let rest = msg
        .strip_prefix(prefix.as_str())
        .unwrap_or_else(|| panic!("unexpected message: {msg}"));
    let (named, directions) = rest
        .split_once(" (null-space directions, column-scaled: ")
        .unwrap_or_else(|| panic!("no null-space directions: {msg}"));
    let triple: BTreeSet<&str> = ["l1", "L1", "gamma1"].into();
    let named: BTreeSet<&str> = named.split(", ").collect();
    assert_eq!(named.len(), 2, "{msg}");
    assert!(named.is_subset(&triple), "{msg}");
    let directions = directions
        .strip_suffix(')')
        .unwrap_or_else(|| panic!("unterminated: {msg}"));
    let directions: Vec<&str> = directions.split("; ").collect();
    assert_eq!(directions.len(), 2, "{msg}");
    // Each direction reads `c name (± c name)…` over the triple, first weight positive; the
    // two are orthonormal (right singular vectors), up to the weights below 0.05 that are not
    // printed.
    let vectors: Vec<[f64; 3]> = directions
        .iter()
        .map(|direction| {
            let words: Vec<&str> = direction.split_whitespace().collect();
            let mut vector = [0.0; 3];
            let mut sign = 1.0;
            let mut i = 0;
            while i < words.len() {
                if i > 0 {
                    sign = match words[i] {
                        "+" => 1.0,
                        "-" => -1.0,
                        other => panic!("`{other}` in {msg}"),
                    };
                    i += 1;
                }
                let weight: f64 = words[i].parse().unwrap_or_else(|_| panic!("{msg}"));
                assert!(weight > 0.0 && weight <= 1.0, "{msg}");
                let slot = ["l1", "L1", "gamma1"]
                    .iter()
                    .position(|n| *n == words[i + 1]);
                vector[slot.unwrap_or_else(|| panic!("`{}` in {msg}", words[i + 1]))] =
                    sign * weight;
                i += 2;
            }
            vector
        })
        .collect();
    let dot = |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    for v in &vectors {
        assert!((dot(v, v) - 1.0).abs() < 0.01, "{msg}");
    }
    assert!(dot(&vectors[0], &vectors[1]).abs() < 0.1, "{msg}");
}

/// A spacing far too fine for the region is refused before any grid is built.
#[test]
fn a_candidate_grid_too_fine_is_refused() {
    let mech = bundled("5r.yaml");
    let err = legwise::selection::candidates::candidate_pool(&mech, Some(1e-6)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "grid spacing 0.000001 m (workspace.grid or --grid) gives 1.505e12 grid poses; at most \
         2000000 are allowed: use a larger spacing"
    );
}

// ---- issue 8: crashes, silent wrong answers and misleading messages ----

/// Runs the built `legwise ARGS` in the crate root; returns (exit code, stdout, stderr).
fn legwise(args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the legwise binary runs");
    let text = |b: &[u8]| String::from_utf8(b.to_vec()).expect("UTF-8 output");
    (out.status.code(), text(&out.stdout), text(&out.stderr))
}

/// The binary exits 2 with exactly `expected` (one line) on stderr and nothing on stdout.
fn assert_cli_fails_with(args: &[&str], expected: &str) {
    let (code, stdout, stderr) = legwise(args);
    assert_eq!(code, Some(2), "{args:?}: stderr {stderr:?}");
    assert_eq!(stderr, format!("legwise: {expected}\n"), "{args:?}");
    assert_eq!(stdout, "", "{args:?}");
}

const ALL_FIXED: &str = "tests/data/5r_all_fixed.yaml: field `parameters`: every parameter has \
    `identify: false`: there is nothing to select poses for or to identify; set `identify: true` \
    (the default) on the parameters to identify";

/// Every parameter fixed: pose selection (both strategies) refuses at once; it used to panic
/// (traditional) or return no poses at all (divide and conquer).
#[test]
fn every_parameter_fixed_is_refused_by_pose_selection() {
    use legwise::model::mechanism::SelectionCriterion;
    use legwise::selection::design::ExperimentDesign;
    let mech = Mechanism::load(&data("5r_all_fixed.yaml")).expect("the model itself is valid");
    assert!(mech.identified_legs().is_empty());
    for shared in [false, true] {
        let err = ExperimentDesign::select(&mech, None, 18, SelectionCriterion::D, shared)
            .expect_err("nothing to select");
        assert_eq!(
            message(&err),
            format!(
                "{}: field `parameters`: every parameter has `identify: false`: there is nothing \
                 to select poses for or to identify; set `identify: true` (the default) on the \
                 parameters to identify",
                data("5r_all_fixed.yaml").display()
            )
        );
    }
}

/// The CLI: `identify` (simulated), `simulate` and `select` (both strategies) exit 2 with one
/// line, and no file is written (`select` wrote a header-only CSV and exited 0).
#[test]
fn every_parameter_fixed_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("poses.csv");
    let out = out.to_str().expect("UTF-8 path");
    let model = "tests/data/5r_all_fixed.yaml";
    let runs: [&[&str]; 4] = [
        &["identify", "--model", model],
        &["simulate", "--model", model, "--out", out],
        &["select", "--model", model, "--out", out],
        &[
            "select",
            "--model",
            model,
            "--out",
            out,
            "--strategy",
            "traditional",
        ],
    ];
    for args in runs {
        assert_cli_fails_with(args, ALL_FIXED);
        assert!(!Path::new(out).exists(), "{args:?} wrote {out}");
    }
}

/// 30 000 nested elements overflowed urdf-rs's recursive parser (an abort); the pre-scan
/// refuses the 101st level and names its line.
#[test]
fn a_urdf_nested_too_deep_is_refused_before_parsing() {
    let (_, msg) = model_error("5r_deep_nesting.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 37: element <x> is nested 101 levels deep; at most 100 are accepted (a URDF \
             needs fewer than 10)",
            data("deep_nesting.urdf").display()
        )
    );
    assert_cli_fails_with(
        &["workspace", "--model", "tests/data/5r_deep_nesting.yaml"],
        "tests/data/deep_nesting.urdf: line 37: element <x> is nested 101 levels deep; at most \
         100 are accepted (a URDF needs fewer than 10)",
    );
}

#[test]
fn a_duplicate_urdf_joint_is_called_a_duplicate_with_both_lines() {
    let (_, msg) = model_error("5r_duplicate_joint.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 25: joint `B1` is declared twice (first on line 16); joint names must be \
             unique",
            data("duplicate_joint.urdf").display()
        )
    );
}

#[test]
fn a_joint_on_an_undeclared_link_is_refused_with_its_line() {
    let (_, msg) = model_error("5r_undeclared_link.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: line 19: joint `P1`: its child link `tip1` is not declared (no <link \
             name=\"tip1\"> in the file)",
            data("undeclared_link.urdf").display()
        )
    );
}

/// `/dev/zero` exists: it was reported "not found" (and reading it would never end).
#[cfg(unix)]
#[test]
fn a_urdf_that_is_a_device_says_what_it_is() {
    let (path, msg) = model_error("5r_urdf_dev_zero.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: field `urdf`: URDF file `/dev/zero`: not a regular file (it is a character \
             device); expected a text file",
            path.display()
        )
    );
    assert_cli_fails_with(
        &["workspace", "--model", "/dev/zero"],
        "/dev/zero: not a regular file (it is a character device); expected a text file",
    );
}

/// A URDF in millimetres: the legs add up to 500 + 750 + 1100 = 2350 "m" while the workspace
/// disc (centre (0, 1.0957), radius 0.6457) reaches √(0.6457² + 1.7413²) = 1.8572 m from the
/// base origin: 1265 times. It used to fail at pose selection with "select more poses".
#[test]
fn a_urdf_in_millimetres_is_named_as_a_unit_problem() {
    let (path, msg) = model_error("5r_urdf_millimetres.yaml");
    let reach = (0.6456521739f64.powi(2) + (1.0956521739f64 + 0.6456521739).powi(2)).sqrt();
    assert_eq!(
        msg,
        format!(
            "{}: field `urdf`: `5r_millimetres.urdf`: the URDF joint origins of leg `leg1` add \
             up to 2350 m while the workspace region reaches {reach:.4} m: the leg is {:.0} \
             times the size of the workspace, so the URDF and the model file seem to use \
             different length units (millimetres vs metres?); legwise expects every length in \
             metres",
            path.display(),
            2350.0 / reach
        )
    );
}

/// The 5R with a nominal gain `k1` of `value`, which a model file may not hold (see
/// `a_model_value_beyond_a_million_is_refused_naming_the_field`): the checks after loading
/// still guard a mechanism edited in code.
fn with_gain_k1(value: f64) -> Mechanism {
    bundled("5r.yaml").edited(|parts| {
        parts.legs[0].gain = value;
        let k1 = parts.legs[0].params.iter_mut().find(|p| p.name == "k1");
        k1.expect("k1").nominal = value;
    })
}

/// A model file's value beyond 1e6 in magnitude (metres, radians, gain) is refused when the
/// model loads, naming the field: a gain of 1e308 or 1e300 used to surface as an overflow or a
/// rank deficiency far away.
#[test]
fn a_model_value_beyond_a_million_is_refused_naming_the_field() {
    for (file, value) in [
        ("5r_gain_1e308.yaml", "1e308"),
        ("5r_gain_1e300.yaml", "1e300"),
    ] {
        let (path, msg) = model_error(file);
        assert_eq!(
            msg,
            format!(
                "{}: field `legs[0].actuator.gain`: {value} is not a plausible value; legwise \
                 reads metres, radians and gains, and expects magnitudes up to 1e6",
                path.display()
            )
        );
    }
}

/// A nominal gain of 1e300: ∂ψ/∂k = −(θ − γ)/k² underflows to 0, so k1 (alone) cannot be
/// identified. The column norms of the other columns (~1e-300) underflowed too, and the
/// pivoting named l1.
#[test]
fn a_gain_of_1e300_names_k1_not_l1() {
    use legwise::model::mechanism::SelectionCriterion;
    use legwise::selection::design::ExperimentDesign;
    let mech = with_gain_k1(1e300);
    let err = ExperimentDesign::select(&mech, None, 18, SelectionCriterion::D, false)
        .expect_err("k1 is unidentifiable");
    assert_eq!(
        message(&err),
        "leg `leg1`: rank-deficient identification: rank 5 of 6 parameters; cannot be \
         identified: k1 — the candidate pool cannot identify them (null-space directions, \
         column-scaled: 1.000 k1)"
    );
}

/// A leg1 pose 1e-12 m beyond l1 + L1 = 1.85 m from A1 = (−0.5, 0) was called a working-mode
/// change; it is out of reach by the residual (≈ 1e-12 m).
#[test]
fn a_pose_just_beyond_reach_is_unreachable_not_a_branch_change() {
    let (path, msg) = measurement_error("beyond_reach.csv");
    let prefix = format!(
        "{}: line 12: leg `leg1` cannot reach the pose (closure residual ",
        path.display()
    );
    let rest = msg
        .strip_prefix(prefix.as_str())
        .unwrap_or_else(|| panic!("unexpected message: {msg}"));
    let residual: f64 = rest
        .split_whitespace()
        .next()
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("no residual in {msg}"));
    assert!((0.5e-12..2e-12).contains(&residual), "{msg}");
    // Newton's 40 iterations, then the 80 spent at the reach limit to tell "on it" from
    // "beyond it", all of them run here (the residual stalls without becoming singular).
    assert!(rest.ends_with(" m after 120 Newton iterations)"), "{msg}");
}

/// A leg1 pose exactly 1.85 m from A1 (the leg stretched) was accepted; it is a serial
/// singularity.
#[test]
fn a_pose_exactly_at_a_serial_singularity_is_refused() {
    let (path, msg) = measurement_error("serial_singularity.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 12: leg `leg1` is at a serial (type I) singularity at this pose",
            path.display()
        )
    );
}

/// The kinematics at the two poses above, leg1 alone, with the nominal parameters.
#[test]
fn the_reach_limit_is_classified_by_the_inverse_kinematics() {
    use legwise::error::KinematicsError;
    use legwise::kinematics::inverse::solve_leg;
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    let pose = |y: f64| [-0.5, y, 0.0, 0.0, 0.0, 0.0];
    let at = solve_leg(leg, &geometry, &pose(1.85), &mech.home_pose);
    assert!(
        matches!(at, Err(KinematicsError::Singular { .. })),
        "{at:?}"
    );
    let beyond = solve_leg(leg, &geometry, &pose(1.85 + 1e-12), &mech.home_pose);
    assert!(
        matches!(beyond, Err(KinematicsError::Unreachable { .. })),
        "{beyond:?}"
    );
    // 1 mm inside the limit is still an ordinary pose on the home branch.
    let inside = solve_leg(leg, &geometry, &pose(1.849), &mech.home_pose).expect("reachable");
    let (l, big_l) = (0.75, 1.10);
    // Law of cosines at the elbow: |A1P|² = l² + L² + 2 l L cos(elbow).
    let elbow = ((1.849f64.powi(2) - l * l - big_l * big_l) / (2.0 * l * big_l)).acos();
    assert!(
        (inside.q[1].abs() - elbow).abs() < 1e-9,
        "{:?} vs {elbow}",
        inside.q
    );
}

/// x = 1e308 is finite (the CSV accepts it) but absurd: it was called "non-finite". The
/// plausibility check names it, in scientific notation, with the likely unit mistake.
#[test]
fn a_finite_but_huge_coordinate_is_named_with_its_line_and_column() {
    let (path, msg) = measurement_error("huge_coordinate.csv");
    assert_eq!(
        msg,
        format!(
            "{}: line 12, column `x`: 1e308 m is more than 100 times the mechanism's size \
             (2.350 m) from the home pose (0 m): positions in millimetres instead of metres?",
            path.display()
        )
    );
}

/// Gauss–Newton on readings in degrees jumps to absurd parameters, where a pose fails: the
/// message blamed the data ("cannot reach the pose", no line); it now says the solver
/// diverged, with the trial parameters and the measurement line.
#[test]
fn a_diverging_gauss_newton_names_the_trial_parameters_not_the_data() {
    let (code, _, stderr) = legwise(&[
        "identify",
        "--model",
        "models/5r.yaml",
        "--measurements",
        "tests/data/readings_in_degrees.csv",
        "--solver",
        "gn",
    ]);
    // A failed run (2 or 3 by the exit-code policy), never a panic (101).
    assert!(matches!(code, Some(2 | 3)), "{code:?}: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.starts_with(
            "legwise: legs leg1: solver failed: the solver diverged: at its trial parameters (l1 = "
        ),
        "{stderr}"
    );
    assert!(stderr.contains("), measurement line "), "{stderr}");
    assert!(
        stderr.contains(
            "the step left the plausible parameters (the pose is usable at the starting ones)"
        ),
        "{stderr}"
    );
}

/// A nominal gain of 1e308 is finite, but the Jacobian overflows: it was "candidate 64 has a
/// non-finite entry".
#[test]
fn a_gain_of_1e308_is_named_as_an_overflow_of_the_nominal_parameters() {
    use legwise::model::mechanism::SelectionCriterion;
    use legwise::selection::design::ExperimentDesign;
    let mech = with_gain_k1(1e308);
    let err = ExperimentDesign::select(&mech, None, 18, SelectionCriterion::D, false)
        .expect_err("the Jacobian overflows");
    let msg = message(&err);
    let prefix = format!(
        "{}: the identification Jacobian overflows at candidate pose x=",
        mech.model_path.display()
    );
    assert!(msg.starts_with(&prefix), "{msg}");
    assert!(
        msg.ends_with(
            ": the nominal parameters are too large to compute with (largest: k1 = 1e308)"
        ),
        "{msg}"
    );
}

/// The unit a bad cell is expected in follows the coordinate: metres for x, y, z and radians for
/// roll, pitch, yaw (a model may measure any of the six; the bundled planar ones measure three).
#[test]
fn a_bad_coordinate_cell_names_the_unit_of_its_coordinate() {
    let mech = bundled("5r.yaml").edited(|parts| parts.measured = (0..6).collect());
    let readings = ",".repeat(mech.actuated_names().len());
    let header = format!(
        "leg,x,y,z,roll,pitch,yaw,{}",
        mech.actuated_names().join(",")
    );
    let path = Path::new("m.csv");
    for (i, (name, unit)) in [
        ("x", "metres"),
        ("y", "metres"),
        ("z", "metres"),
        ("roll", "radians"),
        ("pitch", "radians"),
        ("yaw", "radians"),
    ]
    .into_iter()
    .enumerate()
    {
        let mut cells = ["0"; 6];
        cells[i] = "abc";
        let text = format!("{header}\n,{}{readings}\n", cells.join(","));
        let err = legwise::measure::file::parse(&text, path, &mech).expect_err("bad cell");
        assert_eq!(
            message(&err),
            format!(
                "m.csv: line 2, column `{name}`: expected a finite number in {unit}, found `abc`"
            )
        );
    }
}

/// A measurement file that opens but cannot be read (a directory) is an I/O error naming the
/// file, not a complaint about its rows.
#[test]
fn a_measurement_file_that_cannot_be_read_is_an_io_error_naming_it() {
    let mechanism = bundled("5r.yaml");
    let directory = tempfile::tempdir().unwrap();
    let err = read(directory.path(), &mechanism).unwrap_err();
    assert!(
        matches!(&err, legwise::error::Error::Io { path, .. } if path == directory.path()),
        "{err:?}"
    );
    assert!(
        err.to_string()
            .contains(&directory.path().display().to_string()),
        "{err}"
    );
}

/// Two parameters of the same largest magnitude (k1 = 1e308, k2 = −1e308): the message names
/// the first of them in model order.
#[test]
fn an_overflow_names_the_first_of_equally_large_parameters() {
    use legwise::model::mechanism::SelectionCriterion;
    use legwise::selection::design::ExperimentDesign;
    let mech = with_gain_k1(1e308).edited(|parts| {
        let k2 = parts.legs[1]
            .params
            .iter_mut()
            .find(|p| p.name == "k2")
            .expect("k2");
        k2.nominal = -1e308;
    });
    let err = ExperimentDesign::select(&mech, None, 18, SelectionCriterion::D, false)
        .expect_err("the Jacobian overflows");
    let msg = message(&err);
    assert!(
        msg.ends_with(
            ": the nominal parameters are too large to compute with (largest: k1 = 1e308)"
        ),
        "{msg}"
    );
}
