//! Bad spatial input gives one clear message naming the file and field, exit status 2: a chain
//! with too many unknowns, a missing coordinate (in the model's home pose, in the measurement
//! header), a degenerate platform. Each message is compared whole.
use crate::cli::{legwise, text};
use crate::spatial::edited;
use crate::support::crate_path;

/// The hexapod's attachments all moved to `point` (the platform frame's origin, or a line).
fn hexapod_attachments(points: &dyn Fn(usize) -> String) -> String {
    let model = std::fs::read_to_string(crate_path("models/hexapod.yaml")).unwrap();
    let mut leg = 0;
    model
        .lines()
        .map(|line| {
            if line.trim_start().starts_with("attachment:") {
                let start = line.find('[').unwrap();
                let end = line.find(']').unwrap();
                leg += 1;
                format!("{}{}{}", &line[..start], points(leg - 1), &line[end + 1..])
            } else {
                line.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

const DEGENERATE: &str = "field `legs[*].attachment`: the platform is degenerate at the home \
     pose: its parallel (type II) measure is 0.0e0 (0: the platform moves with every actuator \
     locked); the attachment points must not coincide or line up, and the legs must not all \
     meet in one point or lie in one plane with the platform";

#[test]
fn a_degenerate_hexapod_platform_is_refused_with_the_whole_message_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        crate_path("models/hexapod.urdf"),
        dir.path().join("hexapod.urdf"),
    )
    .unwrap();
    let path = dir.path().join("hexapod.yaml");
    // Every platform joint at the platform's centre: the platform turns freely about it.
    std::fs::write(&path, hexapod_attachments(&|_| "[0.0, 0.0, 0.0]".into())).unwrap();
    let out = legwise(&["identify", "--model", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty());
    assert_eq!(
        text(&out.stderr),
        format!("legwise: {}: {DEGENERATE}\n", path.display())
    );
}

#[test]
fn a_spatial_home_pose_without_a_measured_coordinate_is_refused() {
    let error = edited("hexapod.yaml", &[("z: 0.6, ", "")], &[])
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        "hexapod.yaml: field `home.pose.z`: missing: the home pose needs every measured coordinate"
    );
    let error = edited("delta.yaml", &[(", z: 0.05}", "}")], &[])
        .unwrap_err()
        .to_string();
    assert_eq!(
        error,
        "delta.yaml: field `home.pose.z`: missing: the home pose needs every measured coordinate"
    );
}

#[test]
fn a_delta_measurement_file_without_z_names_the_column() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("no-z.csv");
    std::fs::write(&csv, "leg,x,y,C1,C2,C3\n,0,0,0.3,0.3,0.3\n").unwrap();
    let out = legwise(&[
        "identify",
        "--model",
        "models/delta.yaml",
        "--measurements",
        csv.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        text(&out.stderr),
        format!(
            "legwise: {}: header: missing column `z`; expected the columns leg, x, y, z, C1, C2, C3\n",
            csv.display()
        )
    );
}
