//! Leg inverse kinematics on cases whose answer is checked independently (the closure equations
//! evaluated at the returned joints, and the branch sign): a pose only continuation from home
//! reaches, a seed exactly at a serial singularity, the unwrap of revolute joints around the
//! seed, `wrap_angle`, a leg scaled by powers of ten (the same angles), and overflowing or
//! non-finite inputs.
use legwise::error::KinematicsError;
use legwise::kinematics::chain::{attachment_world, tip_and_jacobian, tip_position};
use legwise::kinematics::inverse::{newton, solve_leg, solve_leg_from, wrap_angle, LegSolution};
use legwise::model::leg::LegModel;
use std::f64::consts::{PI, TAU};

use crate::support::bundled;

/// The solution closes the leg on `pose` and sits on the home branch (its Jacobian determinant
/// has the sign of home's).
fn assert_closes_on_the_home_branch(leg: &LegModel, pose: &[f64; 6], solution: &LegSolution) {
    let geometry = leg.geometry(&leg.nominal());
    let tip = tip_position(leg, &geometry, &solution.q);
    let target = attachment_world(pose, &geometry.attachment);
    for k in 0..leg.closure_dims {
        assert!(
            (tip[k] - target[k]).abs() < 1e-12,
            "{}: tip {tip} vs target {target} at {pose:?}",
            leg.name
        );
    }
    let (_, jacobian) = tip_and_jacobian(leg, &geometry, &solution.q);
    let d = leg.closure_dims;
    let block = nalgebra::DMatrix::from_fn(d, d, |r, c| jacobian[(r, c)]);
    assert!(
        block.determinant() * leg.branch_sign > 0.0,
        "{}: off the home branch at {pose:?}",
        leg.name
    );
    assert!(solution.normalised_determinant * leg.branch_sign > 0.0);
}

/// A 5R pose beyond the reach of direct Newton from the home joints (it leaves the home
/// working mode), which continuation along the segment from home reaches.
#[test]
fn continuation_reaches_a_pose_direct_newton_does_not() {
    let mech = bundled("5r.yaml");
    let home = mech.home_pose;
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    // Found by scanning a grid around the base: below and to the left of A1 the direct
    // Newton iteration leaves the working mode, the continuation stays on it.
    for (x, y) in [
        (-0.88, 0.2),
        (-1.36, -0.12),
        (-1.2, -0.2),
        (-0.16, -0.44),
        (0.0, -0.6),
    ] {
        let pose = [x, y, 0.0, 0.0, 0.0, 0.0];
        assert!(solve_leg_from(leg, &geometry, &pose, &leg.home_joints).is_err());
        let solution = solve_leg(leg, &geometry, &pose, &home).unwrap();
        assert_closes_on_the_home_branch(leg, &pose, &solution);
    }
}

#[test]
fn wrap_angle_lands_in_the_half_open_window() {
    let cases = [
        (0.0, 0.0),
        (1.0, 1.0),
        (-1.0, -1.0),
        (PI, PI),
        (-PI, PI),
        (3.0 * PI, PI),
        (-3.0 * PI, PI),
        (TAU, 0.0),
        (-1.5 * PI, 0.5 * PI),
        (1.5 * PI, -0.5 * PI),
        (7.0, 7.0 - TAU),
        (-7.0, TAU - 7.0),
        (20.0, 20.0 - 3.0 * TAU),
    ];
    for (angle, wrapped) in cases {
        let got = wrap_angle(angle);
        assert!(
            (got - wrapped).abs() < 1e-12,
            "wrap_angle({angle}) = {got}, expected {wrapped}"
        );
        assert!(got > -PI && got <= PI, "wrap_angle({angle}) = {got}");
    }
}

#[test]
fn newton_from_a_seed_exactly_at_a_serial_singularity_is_an_error() {
    // Leg 1 of the 5R fully stretched (elbow joint B1 at 0): the closure Jacobian's columns are
    // parallel. The pose is the tip there, so Newton stops at once, on the singular Jacobian.
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    let seed = [2.0, 0.0];
    let tip = tip_position(leg, &geometry, &seed);
    let pose = [tip[0], tip[1], 0.0, 0.0, 0.0, 0.0];
    let err = newton(leg, &geometry, &pose, &seed).unwrap_err();
    assert_eq!(err, KinematicsError::Singular { leg: "leg1".into() });
    // Slightly folded, the same leg solves.
    let folded = [2.0, -0.3];
    let tip = tip_position(leg, &geometry, &folded);
    let pose = [tip[0], tip[1], 0.0, 0.0, 0.0, 0.0];
    let solution = newton(leg, &geometry, &pose, &folded).unwrap();
    assert!((solution.q[1] + 0.3).abs() < 1e-12);
}

/// Newton's result is unwrapped into the 2π window centred on the seed: seeds half a turn away
/// from the solution in the actuated joint still give joints within π of the seed, closing
/// the leg.
#[test]
fn revolute_joints_are_unwrapped_around_the_seed() {
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    let pose = mech.home_pose;
    let mut solved = 0;
    for k in 0..24 {
        let turn = -PI + TAU * k as f64 / 24.0;
        let seed = [leg.home_joints[0] + turn, leg.home_joints[1] + 0.5 * turn];
        let Ok(solution) = newton(leg, &geometry, &pose, &seed) else {
            continue;
        };
        solved += 1;
        let tip = tip_position(leg, &geometry, &solution.q);
        assert!((tip[0] - pose[0]).abs() < 1e-12 && (tip[1] - pose[1]).abs() < 1e-12);
        for (q, s) in solution.q.iter().zip(&seed) {
            assert!(
                (q - s).abs() <= PI + 1e-12,
                "seed {seed:?} gave {:?}",
                solution.q
            );
        }
    }
    assert!(solved > 12, "{solved}");
}

/// Every length of a leg and of the pose scaled by `scale` (joint origins, attachment,
/// position): revolute angles do not change, prismatic strokes scale. The convergence test is
/// relative to the target's size, so a leg measured in kilometres or in millimetres converges
/// to the same angles as in metres.
#[test]
fn a_leg_scaled_by_powers_of_ten_reaches_the_same_angles() {
    use legwise::model::joint::JointKind;
    for model in ["5r.yaml", "3rpr.yaml", "delta.yaml", "hexapod.yaml"] {
        let mech = bundled(model);
        let leg = &mech.legs[0];
        let geometry = leg.geometry(&leg.nominal());
        let pose = mech.home_pose.map(|v| v + 0.01);
        let reference = solve_leg(leg, &geometry, &pose, &mech.home_pose).unwrap();
        for scale in [1e-3, 1e4] {
            let mut scaled = geometry.clone();
            for origin in &mut scaled.origins {
                for value in &mut origin[..3] {
                    *value *= scale;
                }
            }
            scaled.attachment = scaled.attachment.map(|v| v * scale);
            let lengths =
                |p: &[f64; 6]| std::array::from_fn(|i| p[i] * if i < 3 { scale } else { 1.0 });
            let solution = solve_leg(leg, &scaled, &lengths(&pose), &lengths(&mech.home_pose))
                .unwrap_or_else(|e| panic!("{model} at scale {scale}: {e}"));
            for (k, &joint) in leg.moving.iter().enumerate() {
                let expected = match leg.joints[joint].kind {
                    JointKind::Prismatic => reference.q[k] * scale,
                    _ => reference.q[k],
                };
                assert!(
                    (solution.q[k] - expected).abs() <= 1e-9 * expected.abs().max(1.0),
                    "{model} at scale {scale}: joint {k} {} instead of {expected}",
                    solution.q[k]
                );
            }
        }
    }
}

/// Finite inputs too large to compute with are an overflow naming the largest magnitude; a NaN
/// among them is a non-finite input.
#[test]
fn a_huge_finite_pose_is_an_overflow_and_a_nan_is_a_non_finite_input() {
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    let huge = [1e308, 1e308, 0.0, 0.0, 0.0, 0.0];
    match solve_leg(leg, &geometry, &huge, &mech.home_pose) {
        Err(KinematicsError::Overflow { leg: name, largest }) => {
            assert_eq!(name, leg.name);
            assert!((largest - 1e308).abs() <= 1e292, "largest {largest:e}");
        }
        other => panic!("expected an overflow, got {other:?}"),
    }
    let nan = [f64::NAN, 0.5, 0.0, 0.0, 0.0, 0.0];
    assert!(matches!(
        solve_leg(leg, &geometry, &nan, &mech.home_pose),
        Err(KinematicsError::NonFinite { .. })
    ));
}
