//! Kinematics properties on every bundled model: platform FK inverts leg IK over the usable
//! workspace; out-of-reach poses and working-mode changes are errors, never other answers.
use legwise::error::KinematicsError;
use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::platform::forward;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::support::{bundled, bundled_models};

#[test]
fn forward_kinematics_inverts_inverse_kinematics_over_the_workspace() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for mech in bundled_models() {
        let home = mech.home_pose;
        let params = mech.nominal_parameters();
        for _ in 0..100 {
            let pose = mech.workspace.sample(&home, &mut rng).unwrap();
            let readings: Vec<f64> = mech
                .legs
                .iter()
                .map(|leg| predict_reading(leg, &leg.nominal(), &pose, &home).unwrap())
                .collect();
            let back = forward(&mech, &params, &readings).unwrap();
            for c in 0..6 {
                assert!(
                    (back[c] - pose[c]).abs() < 1e-11,
                    "{}: {pose:?} -> {back:?}",
                    mech.name
                );
            }
        }
    }
}

#[test]
fn a_pose_out_of_reach_is_an_error_naming_the_leg() {
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let far = [0.0, 3.0, 0.0, 0.0, 0.0, 0.0];
    let err = predict_reading(leg, &leg.nominal(), &far, &mech.home_pose).unwrap_err();
    assert!(
        matches!(err, KinematicsError::Unreachable { .. }),
        "{err:?}"
    );
    assert!(
        err.to_string()
            .starts_with("leg `leg1` cannot reach the pose"),
        "{err}"
    );
}

#[test]
fn leaving_the_home_working_mode_is_an_error_not_another_branch() {
    // Below the base the elbows-out branch of leg 1 cannot be reached continuously from home:
    // the leg passes a serial singularity (A1, B1, P aligned) on the way.
    let mech = bundled("5r.yaml");
    let leg = &mech.legs[0];
    let below = [-0.5, -0.8, 0.0, 0.0, 0.0, 0.0];
    // |P − A1| = 0.8 m lies inside the reach annulus [0.35, 1.85]: the pose is reachable, but
    // only in the other working mode, and that is what the error must say.
    let err = predict_reading(leg, &leg.nominal(), &below, &mech.home_pose).unwrap_err();
    assert_eq!(err, KinematicsError::BranchChange { leg: "leg1".into() });
    assert_eq!(
        err.to_string(),
        "leg `leg1` reaches the pose only on another branch than its home configuration (working-mode change)"
    );
}

#[test]
fn readings_are_unwrapped_around_home_and_cross_pi_continuously() {
    // ψ of the 5R spans about [1.18, 3.32] rad over the MIW (docs/method.md §9): readings above
    // π must stay above π, not wrap to −π.
    let mech = bundled("5r.yaml");
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (mut lowest, mut highest) = (f64::INFINITY, f64::NEG_INFINITY);
    for _ in 0..2000 {
        let pose = mech.workspace.sample(&mech.home_pose, &mut rng).unwrap();
        for leg in &mech.legs {
            let psi = predict_reading(leg, &leg.nominal(), &pose, &mech.home_pose).unwrap();
            lowest = lowest.min(psi);
            highest = highest.max(psi);
        }
    }
    assert!(highest > std::f64::consts::PI, "highest ψ {highest}");
    assert!(lowest > 1.0 && highest < 3.5, "ψ in [{lowest}, {highest}]");
}
