//! The nearest rotation: closed forms (a rotation, a polar decomposition), agreement with the
//! SVD solution of the same least-squares problem, and the lifted derivative against central
//! differences.

use nalgebra::{Matrix3, Rotation3, Vector3};
use num_dual::{Dual64, DualStruct};

use super::*;

fn rotation(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    Rotation3::from_euler_angles(roll, pitch, yaw).into_inner()
}

fn gap(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).amax()
}

#[test]
fn the_nearest_rotation_of_a_rotation_or_of_its_product_with_a_symmetric_positive_matrix_is_itself()
{
    let r = rotation(0.3, -1.1, 2.9);
    assert!(gap(&nearest_rotation(&r), &r) < 1e-15);
    // Polar decomposition M = R S, S symmetric positive definite: the polar factor is R.
    let s = Matrix3::new(2.0, 0.3, -0.1, 0.3, 0.5, 0.2, -0.1, 0.2, 1.2);
    assert!(s.symmetric_eigenvalues().min() > 0.0);
    assert!(gap(&nearest_rotation(&(r * s)), &r) < 1e-14);
    // The sum of rotations close to one another: between them, and itself for two equal.
    assert!(gap(&nearest_rotation(&(r + r)), &r) < 1e-15);
    // A quaternion and its negative are the same rotation; a scaled one too.
    let q = nalgebra::Vector4::new(0.3, -0.2, 0.9, 0.1);
    assert!(gap(&quaternion_rotation(&q), &quaternion_rotation(&(-2.5 * q))) < 1e-15);
    let unit = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        q[0], q[1], q[2], q[3],
    ));
    assert!(gap(&quaternion_rotation(&q), unit.to_rotation_matrix().matrix()) < 1e-15);
}

#[test]
fn for_points_it_is_the_svd_solution_of_the_orthogonal_procrustes_problem_coplanar_points_too() {
    let truth = rotation(-0.4, 0.25, 1.3);
    // Three coplanar model points (z = 0.03 for all: the centred points are planar), then four
    // points in general position; the measured ones rotated and disturbed.
    for model in [
        vec![
            Vector3::new(0.12, 0.0, 0.03),
            Vector3::new(-0.06, 0.1, 0.03),
            Vector3::new(-0.06, -0.1, 0.03),
        ],
        vec![
            Vector3::new(0.1, 0.02, -0.05),
            Vector3::new(-0.03, 0.11, 0.0),
            Vector3::new(-0.06, -0.1, 0.07),
            Vector3::new(0.01, 0.0, 0.2),
        ],
    ] {
        let n = model.len() as f64;
        let centre = model.iter().sum::<Vector3<f64>>() / n;
        let measured: Vec<Vector3<f64>> = model
            .iter()
            .enumerate()
            .map(|(k, a)| truth * a + 1e-3 * Vector3::new(k as f64 - 1.0, 0.5, -(k as f64)))
            .collect();
        let measured_centre = measured.iter().sum::<Vector3<f64>>() / n;
        let m = model
            .iter()
            .zip(&measured)
            .fold(Matrix3::zeros(), |acc, (a, b)| {
                acc + (b - measured_centre) * (a - centre).transpose()
            });
        // Kabsch: M = U Σ Vᵀ, R = U diag(1, 1, det(U Vᵀ)) Vᵀ.
        let svd = m.svd(true, true);
        let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
        let d = (u * v_t).determinant().signum();
        let kabsch = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
        let horn = nearest_rotation(&m);
        assert!(gap(&horn, &kabsch) < 1e-13, "{horn} vs {kabsch}");
        assert!(gap(&horn, &truth) < 0.05);
    }
}

#[test]
fn the_lifted_derivative_matches_central_differences() {
    let base =
        rotation(0.2, -0.3, 0.7) * Matrix3::new(1.5, 0.2, 0.0, 0.2, 0.9, -0.1, 0.0, -0.1, 0.4);
    let direction = Matrix3::new(0.3, -1.0, 0.2, 0.5, 0.1, -0.7, 0.9, 0.4, -0.2);
    let dual = nearest_rotation(&base.zip_map(&direction, Dual64::new));
    let h = 1e-6;
    let plus = nearest_rotation(&(base + h * direction));
    let minus = nearest_rotation(&(base - h * direction));
    let central = (plus - minus) / (2.0 * h);
    let value = nearest_rotation(&base);
    for i in 0..3 {
        for j in 0..3 {
            let (d, c) = (dual[(i, j)].eps, central[(i, j)]);
            assert!(
                (d - c).abs() <= 1e-6 * central.amax(),
                "({i},{j}): {d} vs {c}"
            );
            assert_eq!(dual[(i, j)].re().to_bits(), value[(i, j)].to_bits());
        }
    }
    assert!(central.amax() > 0.1, "a direction that moves the rotation");
}
