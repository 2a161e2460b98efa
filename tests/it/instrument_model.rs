//! The model file's `instrument` block: the bundled tracker models load with their shared
//! parameters, and each defect of the block is an error naming the field.
use std::path::Path;

use legwise::model::instrument::Measures;
use legwise::model::Mechanism;

use crate::instrument_support::parameter_names;
use crate::support::{bundled, crate_path};

/// The 3-RPR tracker model's text with `from` replaced by `to` (which must occur).
fn edited(from: &str, to: &str) -> String {
    let text = std::fs::read_to_string(crate_path("models/3rpr-tracker.yaml")).unwrap();
    assert!(text.contains(from), "the model has no `{from}`");
    text.replace(from, to)
}

/// The error of loading `text` as a model with the 3-RPR's URDF.
fn error(text: &str) -> String {
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    Mechanism::parse(text, Path::new("m.yaml"), &urdf, Path::new("3rpr.urdf"))
        .expect_err("the model must be rejected")
        .to_string()
}

const TARGETS: &str =
    "    - {name: r1, offset: [0.08, 0.03], measures: position, perturbation: 0.002}
    - {name: r2, offset: [-0.07, 0.03], measures: position, identify: [y], perturbation: 0.002}";

#[test]
fn the_tracker_models_carry_their_frame_and_targets_as_named_shared_parameters() {
    let rpr = bundled("3rpr-tracker.yaml");
    let instrument = rpr.instrument.as_ref().expect("an instrument");
    assert_eq!(
        parameter_names(instrument),
        [
            "frame_x",
            "frame_y",
            "frame_yaw",
            "target_x_r1",
            "target_y_r1",
            "target_x_r2",
            "target_y_r2"
        ]
    );
    let identified: Vec<bool> = instrument.parameters.iter().map(|p| p.identified).collect();
    assert_eq!(identified, [true, true, true, true, true, false, true]);
    assert_eq!(
        instrument.nominal(),
        [1.5, -0.5, 0.3, 0.08, 0.03, -0.07, 0.03]
    );
    assert_eq!(instrument.columns(), ["x.r1", "y.r1", "x.r2", "y.r2"]);
    assert!(instrument.rotates);
    let five = bundled("5r-tracker.yaml");
    let instrument = five.instrument.as_ref().expect("an instrument");
    assert!(!instrument.rotates);
    assert_eq!(instrument.targets[0].measures, Measures::Position);
    assert_eq!(
        parameter_names(instrument),
        ["frame_x", "frame_y", "frame_yaw", "target_x", "target_y"]
    );
    // Without the block, nothing changes.
    assert!(bundled("3rpr.yaml").instrument.is_none());
}

#[test]
fn a_rotating_platform_measured_by_one_position_only_target_is_rejected_with_the_reason() {
    let text = edited(
        TARGETS,
        "    - {name: r1, offset: [0.08, 0.03], measures: position}",
    );
    assert_eq!(
        error(&text),
        "m.yaml: field `instrument.targets`: the platform rotates (yaw is measured), but the \
         single position-only target `r1` does not give its orientation: add a second \
         position-only target at another offset, or measure the target's pose (`measures: pose`)"
    );
}

#[test]
fn one_pose_target_is_enough_for_a_rotating_platform() {
    let text = edited(
        TARGETS,
        "    - {name: m, offset: [0.08, 0.03], measures: pose}",
    );
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    let mechanism =
        Mechanism::parse(&text, Path::new("m.yaml"), &urdf, Path::new("3rpr.urdf")).unwrap();
    let instrument = mechanism.instrument.as_ref().unwrap();
    assert_eq!(instrument.columns(), ["x.m", "y.m", "yaw.m"]);
}

#[test]
fn two_targets_at_the_same_offset_are_rejected() {
    let text = edited("offset: [-0.07, 0.03]", "offset: [0.08, 0.03]");
    assert_eq!(
        error(&text),
        "m.yaml: field `instrument.targets`: targets `r1` and `r2` have the same offset: their \
         positions do not give the platform's orientation; place them apart"
    );
}

#[test]
fn each_defect_of_the_block_names_its_field() {
    let cases = [
        (
            edited("name: r2", "name: r1"),
            "field `instrument.targets[1].name`: target `r1` is defined twice",
        ),
        (
            edited("name: r2", "name: \"r 2\""),
            "field `instrument.targets[1].name`: `r 2` cannot name measurement columns",
        ),
        (
            edited("measures: position, perturbation", "measures: point, perturbation"),
            "field `instrument.targets[0].measures`: `point` is not one of position, pose",
        ),
        (
            edited("offset: [0.08, 0.03]", "offset: [0.08, 0.03, 0.0]"),
            "field `instrument.targets[0].offset`: expected [x, y] (2 values, metres), found 3 values",
        ),
        (
            edited("identify: [y], perturbation", "identify: [y, z], perturbation"),
            "field `instrument.targets[1].identify[1]`: `z` is not one of x, y",
        ),
        (
            edited("identify: [y], perturbation", "identify: [y, y], perturbation"),
            "field `instrument.targets[1].identify[1]`: `y` is listed twice",
        ),
        (
            edited("[y], perturbation: 0.002", "[y], perturbation: -0.002"),
            "field `instrument.targets[1].perturbation`: expected a non-negative standard deviation",
        ),
        (
            edited("pose: {x: 1.5, y: -0.5, yaw: 0.3}", "pose: {x: 1.5, z: 0.1}"),
            "field `instrument.frame.pose.z`: `z` is not a component of a planar frame; expected one of x, y, yaw",
        ),
        (
            edited("perturbation: {length: 0.005, angle: 0.005}", "perturbation: {length: 0.005, angle: -1.0}"),
            "field `instrument.frame.perturbation.angle`: expected a non-negative standard deviation",
        ),
        (
            edited(TARGETS, "    []"),
            "field `instrument.targets`: expected at least one target the instrument measures",
        ),
        (
            edited("{name: k1, leg: leg1", "{name: frame_x, leg: leg1"),
            "field `parameters`: `frame_x` names an instrument parameter: rename the leg parameter",
        ),
        (
            edited("  poses_per_leg: 18", "  real: {frame_q: 1.0}\n  poses_per_leg: 18"),
            "field `simulation.real.frame_q`: no parameter has this name",
        ),
    ];
    for (text, expected) in cases {
        let message = error(&text);
        assert!(
            message.contains(expected),
            "{message}\n  expected: {expected}"
        );
    }
    // The frame's real value is a simulation parameter like the others.
    let text = edited(
        "  poses_per_leg: 18",
        "  real: {frame_x: 1.501}\n  poses_per_leg: 18",
    );
    let urdf = std::fs::read_to_string(crate_path("models/3rpr.urdf")).unwrap();
    assert!(Mechanism::parse(&text, Path::new("m.yaml"), &urdf, Path::new("3rpr.urdf")).is_ok());
}

#[test]
fn a_pose_target_on_a_platform_that_does_not_rotate_and_an_unknown_key_are_rejected() {
    let text = std::fs::read_to_string(crate_path("models/5r-tracker.yaml")).unwrap();
    let urdf = std::fs::read_to_string(crate_path("models/5r.urdf")).unwrap();
    let load = |text: &str| {
        Mechanism::parse(text, Path::new("m.yaml"), &urdf, Path::new("5r.urdf"))
            .expect_err("rejected")
            .to_string()
    };
    let message = load(&text.replace("measures: position", "measures: pose"));
    assert!(
        message.contains(
            "field `instrument.targets[0].measures`: the platform does not rotate (yaw is not \
             measured): its targets are measured by `position`"
        ),
        "{message}"
    );
    let message = load(&text.replace("  targets:", "  colour: red\n  targets:"));
    assert!(message.contains("colour"), "{message}");
}
