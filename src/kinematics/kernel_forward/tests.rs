//! Tests of the kernel forward step's private parts: the small solves and the closed-form
//! starts.

use super::{solve_small, KernelForward};
use crate::kinematics::inverse::predict_reading;
use crate::kinematics::kernel::LegKernel;
use crate::model::Mechanism;

/// The bundled model `name` and its reduced forward kinematics at the nominal parameters.
fn nominal(name: &str) -> (Mechanism, KernelForward) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("models")
        .join(name);
    let mechanism = Mechanism::load(&path).unwrap();
    let parameters = mechanism.nominal_parameters();
    let geometries: Vec<_> = mechanism
        .legs
        .iter()
        .zip(&parameters)
        .map(|(leg, phi)| leg.geometry(phi))
        .collect();
    let kernels: Vec<_> = mechanism.legs.iter().map(LegKernel::recognise).collect();
    let forward = KernelForward::new(&mechanism, &geometries, &kernels).unwrap();
    (mechanism, forward)
}

/// Every leg's nominal reading at `pose`.
fn readings_at(mechanism: &Mechanism, pose: &[f64; 6]) -> Vec<f64> {
    let home = mechanism.home_pose;
    let parameters = mechanism.nominal_parameters();
    let legs = mechanism.legs.iter().zip(&parameters);
    legs.map(|(leg, phi)| predict_reading(leg, phi, pose, &home).unwrap())
        .collect()
}

#[test]
fn the_five_bar_starts_at_its_circles_intersection() {
    let (mechanism, forward) = nominal("5r.yaml");
    assert!(forward.starts_in_closed_form());
    let home = mechanism.home_pose;
    for (dx, dy) in [(0.0, 0.0), (0.02, -0.01), (-0.03, 0.015)] {
        let mut pose = home;
        (pose[0], pose[1]) = (home[0] + dx, home[1] + dy);
        let readings = readings_at(&mechanism, &pose);
        // From a start 1 mm away: the pose itself, to round-off.
        let mut start = pose;
        start[0] += 1e-3;
        let reached = forward.circle_start(&readings, &start, 1.0).unwrap();
        let miss = (reached[0] - pose[0]).hypot(reached[1] - pose[1]);
        assert!(miss < 1e-15, "{miss:e} at ({dx}, {dy})");
    }
}

#[test]
fn the_delta_starts_at_its_spheres_intersection() {
    let (mechanism, forward) = nominal("delta.yaml");
    assert!(forward.starts_in_closed_form() && !forward.circles);
    let home = mechanism.home_pose;
    for d in [[0.0, 0.0, 0.0], [0.02, -0.01, 0.01], [-0.03, 0.015, -0.02]] {
        let mut pose = home;
        for k in 0..3 {
            pose[k] += d[k];
        }
        let readings = readings_at(&mechanism, &pose);
        // From a start 1 mm away: the pose itself, to round-off.
        let mut start = pose;
        start[0] += 1e-3;
        start[2] -= 1e-3;
        let reached = forward.sphere_start(&readings, &start, 1.0).unwrap();
        let miss = (0..3).map(|k| (reached[k] - pose[k]).powi(2)).sum::<f64>();
        assert!(miss.sqrt() < 1e-15, "{:e} at {d:?}", miss.sqrt());
        // Newton from there confirms it in one evaluation: the same pose.
        let mut solved = start;
        let size = (1.0, true);
        forward
            .newton(&readings, &mut solved, None, size, None)
            .unwrap();
        assert_eq!(&solved[..3], &reached[..]);
    }
    // A start beyond the step limit, or readings no platform reaches: no closed-form start.
    let readings = vec![mechanism.legs[0].home_joints[0]; 3];
    let mut far = home;
    far[2] += 10.0;
    assert!(forward.sphere_start(&readings, &far, 1e-3).is_none());
    assert!(forward
        .sphere_start(&[5.0, -5.0, 5.0], &home, 1.0)
        .is_none());
}

#[test]
fn a_small_system_is_solved_with_its_column_normalised_determinant() {
    // [[0, 2], [3, 4]] x = [2, 10]: x = [2, 1]; det −6 over column norms 3 and √20.
    let mut a = [[0.0; 6]; 6];
    a[0][1] = 2.0;
    a[1][0] = 3.0;
    a[1][1] = 4.0;
    let mut b = [0.0; 6];
    b[0] = 2.0;
    b[1] = 10.0;
    let (x, determinant) = solve_small(a, b, 2).unwrap();
    assert!(
        (x[0] - 2.0).abs() < 1e-15 && (x[1] - 1.0).abs() < 1e-15,
        "{x:?}"
    );
    let expected = -6.0 / (3.0 * 20f64.sqrt());
    assert!((determinant - expected).abs() < 1e-15, "{determinant}");
    // A singular block: no solution.
    a[1][0] = 0.0;
    a[1][1] = 0.0;
    assert!(solve_small(a, b, 2).is_none());
    // Three rows, by elimination with pivoting: [[0, 1, 0], [2, 0, 0], [0, 0, 4]] x =
    // [1, 4, 8]: x = [2, 1, 2]; det −8 over column norms 2, 1 and 4.
    let mut a = [[0.0; 6]; 6];
    (a[0][1], a[1][0], a[2][2]) = (1.0, 2.0, 4.0);
    let mut b = [0.0; 6];
    (b[0], b[1], b[2]) = (1.0, 4.0, 8.0);
    let (x, determinant) = solve_small(a, b, 3).unwrap();
    assert_eq!(&x[..3], &[2.0, 1.0, 2.0]);
    assert!((determinant + 1.0).abs() < 1e-15, "{determinant}");
    a[2][2] = 0.0;
    assert!(solve_small(a, b, 3).is_none());
    // One row: 2 x = 4 (the column's norm 2); no row: nothing to solve, determinant 1; more
    // rows than the storage: refused.
    let (mut a, mut b) = ([[0.0; 6]; 6], [0.0; 6]);
    (a[0][0], b[0]) = (2.0, 4.0);
    assert_eq!(
        solve_small(a, b, 1),
        Some(([2.0, 0.0, 0.0, 0.0, 0.0, 0.0], 1.0))
    );
    assert_eq!(solve_small(a, b, 0), Some(([0.0; 6], 1.0)));
    assert_eq!(solve_small(a, b, 7), None);
}

/// The rows Newton hands back are the kernels' rows at the pose it returns, bit for bit (what
/// a forward row's derivatives reuse instead of evaluating the legs again), for the models
/// whose forward solve goes through their kernels (a closed-form start, one check; and the
/// hexapod's iterations); at any other pose the rows give nothing.
#[test]
fn newtons_last_rows_are_the_kernels_rows_at_the_pose_returned() {
    let bits = |row: Option<(f64, [f64; 3])>| row.map(|(q, r)| (q.to_bits(), r.map(f64::to_bits)));
    let mut handed_back = 0;
    let models = [
        ("delta.yaml", [0.02, -0.01, 0.01, 0.0, 0.0, 0.0]),
        ("5r.yaml", [0.01, 0.02, 0.0, 0.0, 0.0, 0.0]),
        ("hexapod.yaml", [0.01, -0.02, 0.01, 0.02, -0.01, 0.03]),
    ];
    for (name, moved) in models {
        let (mechanism, forward) = nominal(name);
        let home = mechanism.home_pose;
        let mut pose = home;
        for (value, d) in pose.iter_mut().zip(moved) {
            *value += d;
        }
        let readings = readings_at(&mechanism, &pose);
        for exact in [true, false] {
            let mut reached = home;
            let mut last = None;
            let size = 1.0;
            let solved = forward.newton_rows(
                &readings,
                &mut reached,
                None,
                (size, exact),
                (None, Some(&mut last)),
            );
            assert!(solved.is_some(), "{name}");
            let Some(rows) = last else { continue };
            handed_back += 1;
            let at = forward.rows_at(&reached);
            for l in 0..mechanism.legs.len() {
                let row = rows.leg_at(&reached, l);
                assert!(row.is_some(), "{name}: leg {l}");
                assert_eq!(bits(row), bits(at.leg_at(&reached, l)), "{name}: leg {l}");
                let mut elsewhere = reached;
                elsewhere[0] = f64::from_bits(reached[0].to_bits() + 1);
                assert!(rows.leg_at(&elsewhere, l).is_none(), "{name}: leg {l}");
            }
        }
    }
    assert!(
        handed_back >= 2,
        "{handed_back} solves handed their rows back"
    );
}
