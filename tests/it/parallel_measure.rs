//! The parallel (type II) singularity measure recomputed from the models' numbers: for a leg
//! whose passive joints leave one closure direction u (the unit vector from its base joint to
//! its platform joint), the row of the parallel Jacobian is `uᵀ ∂(X·b)/∂X`, normalised to unit
//! length; the measure is the determinant of these rows, signed positive at the home pose.
//! The 5R's rows are unit vectors already (golden.rs checks its closed form); these models'
//! rows carry orientation columns, so the normalisation shows.

use approx::assert_relative_eq;
use legwise::kinematics::singularity::ParallelMeasure;
use nalgebra::{DMatrix, Matrix3, Vector3};

use crate::support::bundled;

fn rotation_x(a: f64) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, 0.0, 0.0, a.cos(), -a.sin(), 0.0, a.sin(), a.cos())
}

fn rotation_y(a: f64) -> Matrix3<f64> {
    Matrix3::new(a.cos(), 0.0, a.sin(), 0.0, 1.0, 0.0, -a.sin(), 0.0, a.cos())
}

fn rotation_z(a: f64) -> Matrix3<f64> {
    Matrix3::new(a.cos(), -a.sin(), 0.0, a.sin(), a.cos(), 0.0, 0.0, 0.0, 1.0)
}

/// `R = Rz(yaw) Ry(pitch) Rx(roll)` and its derivatives by roll, pitch and yaw, by hand.
fn rotation_and_derivatives(roll: f64, pitch: f64, yaw: f64) -> [Matrix3<f64>; 4] {
    let (x, y, z) = (rotation_x(roll), rotation_y(pitch), rotation_z(yaw));
    let dx = Matrix3::new(
        0.0,
        0.0,
        0.0,
        0.0,
        -roll.sin(),
        -roll.cos(),
        0.0,
        roll.cos(),
        -roll.sin(),
    );
    let dy = Matrix3::new(
        -pitch.sin(),
        0.0,
        pitch.cos(),
        0.0,
        0.0,
        0.0,
        -pitch.cos(),
        0.0,
        -pitch.sin(),
    );
    let dz = Matrix3::new(
        -yaw.sin(),
        -yaw.cos(),
        0.0,
        yaw.cos(),
        -yaw.sin(),
        0.0,
        0.0,
        0.0,
        0.0,
    );
    [z * y * x, z * y * dx, z * dy * x, dz * y * x]
}

/// The unsigned measure: the determinant of the unit rows `uᵀ ∂(p + R b)/∂X` over the measured
/// coordinates (`columns` indexes x, y, z, roll, pitch, yaw).
fn closed_form(
    base: &[[f64; 3]],
    platform: &[[f64; 3]],
    pose: &[f64; 6],
    columns: &[usize],
) -> f64 {
    let [rotation, d_roll, d_pitch, d_yaw] = rotation_and_derivatives(pose[3], pose[4], pose[5]);
    let position = Vector3::new(pose[0], pose[1], pose[2]);
    let mut rows = DMatrix::zeros(base.len(), columns.len());
    for (l, (a, b)) in base.iter().zip(platform).enumerate() {
        let b = Vector3::from(*b);
        let u = (position + rotation * b - Vector3::from(*a)).normalize();
        let derivatives = [
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            d_roll * b,
            d_pitch * b,
            d_yaw * b,
        ];
        for (k, &c) in columns.iter().enumerate() {
            rows[(l, k)] = u.dot(&derivatives[c]);
        }
        let norm = rows.row(l).norm();
        rows.row_mut(l).unscale_mut(norm);
    }
    rows.determinant()
}

fn polar(radius: f64, degrees: f64) -> [f64; 3] {
    let a = degrees.to_radians();
    [radius * a.cos(), radius * a.sin(), 0.0]
}

#[test]
fn the_3rpr_parallel_measure_is_the_determinant_of_its_unit_leg_rows() {
    let mechanism = bundled("3rpr.yaml");
    let measure = ParallelMeasure::new(&mechanism, mechanism.nominal_parameters()).unwrap();
    // models/3rpr.yaml: base joints at radius 0.5 m and 90, 210, 330 degrees; platform joints.
    let base = [polar(0.5, 90.0), polar(0.5, 210.0), polar(0.5, 330.0)];
    let platform = [
        [-0.2, 0.0, 0.0],
        [0.1, -0.173_205_080_8, 0.0],
        [0.1, 0.173_205_080_8, 0.0],
    ];
    let columns = [0, 1, 5];
    let home = [0.0; 6];
    let sign = closed_form(&base, &platform, &home, &columns).signum();
    for pose in [
        home,
        [0.1, -0.05, 0.0, 0.0, 0.0, 0.3],
        [-0.15, 0.1, 0.0, 0.0, 0.0, -0.45],
        [0.02, 0.18, 0.0, 0.0, 0.0, 0.1],
    ] {
        let expected = sign * closed_form(&base, &platform, &pose, &columns);
        assert!(
            expected > 0.05,
            "a pose well inside the home mode: {expected}"
        );
        assert_relative_eq!(measure.at(&pose).unwrap(), expected, max_relative = 1e-9);
    }
}

#[test]
fn the_hexapod_parallel_measure_is_the_determinant_of_its_unit_leg_rows() {
    let mechanism = bundled("hexapod.yaml");
    let measure = ParallelMeasure::new(&mechanism, mechanism.nominal_parameters()).unwrap();
    // models/hexapod.yaml: base joints at radius 0.5 m, platform joints at radius 0.25 m.
    let base = [350.0, 10.0, 110.0, 130.0, 230.0, 250.0].map(|d| polar(0.5, d));
    let platform = [310.0, 50.0, 70.0, 170.0, 190.0, 290.0].map(|d| polar(0.25, d));
    let columns = [0, 1, 2, 3, 4, 5];
    let home = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0];
    let sign = closed_form(&base, &platform, &home, &columns).signum();
    for pose in [
        home,
        [0.05, -0.03, 0.65, 0.1, -0.05, 0.2],
        [-0.04, 0.06, 0.55, -0.12, 0.08, -0.15],
    ] {
        let expected = sign * closed_form(&base, &platform, &pose, &columns);
        assert!(
            expected > 1e-3,
            "a pose well inside the home mode: {expected}"
        );
        assert_relative_eq!(measure.at(&pose).unwrap(), expected, max_relative = 1e-8);
    }
}
