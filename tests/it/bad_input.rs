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
    assert_eq!(set.poses.len(), 10);
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
            "{}: line 12 column 27: unknown field `gian`, expected one of joint, gain, offset",
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

/// urdf-rs re-serialises the XML before parsing it and reports no position, so the message
/// names the URDF file but not the line.
#[test]
fn a_malformed_urdf_names_the_urdf_file() {
    let (_, msg) = model_error("5r_broken_urdf.yaml");
    assert_eq!(
        msg,
        format!(
            "{}: Elements not properly nested",
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
    let err = legwise::workspace::candidates::candidate_pool(&mech, Some(1e-6)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "grid spacing 0.000001 m (workspace.grid or --grid) gives 1.505e12 grid poses; at most \
         2000000 are allowed: use a larger spacing"
    );
}
