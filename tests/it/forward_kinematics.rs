//! Platform forward kinematics beyond the round trip of kinematics.rs: the same answer for a
//! mechanism in kilometres or millimetres, and a warm start that lands in the other assembly
//! mode is refused for the home mode's answer.
use legwise::kinematics::inverse::{joints, predict_reading, solve_leg};
use legwise::kinematics::platform::{forward, Configuration, ForwardKinematics};
use legwise::model::joint::JointKind;
use legwise::model::params::Unit;
use legwise::model::Mechanism;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::support::{bundled, bundled_models};

/// `mechanism` with every length multiplied by `scale`: joint origins, platform joints,
/// prismatic offsets and home values, length parameters and the home pose's position.
fn scaled(mechanism: &Mechanism, scale: f64) -> Mechanism {
    mechanism.edited(|scaled| {
        for value in &mut scaled.home_pose[..3] {
            *value *= scale;
        }
        for leg in &mut scaled.legs {
            for joint in &mut leg.joints {
                for value in &mut joint.origin[..3] {
                    *value *= scale;
                }
            }
            leg.attachment = leg.attachment.map(|v| v * scale);
            if !leg.actuated_is_revolute() {
                leg.offset *= scale;
            }
            for (k, &joint) in leg.moving.iter().enumerate() {
                if leg.joints[joint].kind == JointKind::Prismatic {
                    leg.home_joints[k] *= scale;
                }
            }
            for parameter in &mut leg.params {
                if parameter.unit == Unit::Metre {
                    parameter.nominal *= scale;
                }
            }
        }
    })
}

/// Every leg's reading at `pose` with nominal parameters, on the branch continued from `home`.
fn nominal_readings(mechanism: &Mechanism, pose: &[f64; 6], home: &[f64; 6]) -> Vec<f64> {
    mechanism
        .legs
        .iter()
        .map(|leg| predict_reading(leg, &leg.nominal(), pose, home).unwrap())
        .collect()
}

/// The 3-RPR driven by its base revolutes instead of its prismatic joints (gain 1, offset
/// 0.2 rad): the forward kinematics then has a passive prismatic joint per leg, a length that
/// must be neither wrapped like an angle nor limited in steps of 0.5 rad.
fn actuated_at_the_base(mechanism: &Mechanism) -> Mechanism {
    use legwise::model::params::ParamTarget;
    mechanism.edited(|revolute| {
        revolute.name = format!("{} driven at the base", mechanism.name);
        for leg in &mut revolute.legs {
            leg.actuated = 0;
            for parameter in &mut leg.params {
                if parameter.target == ParamTarget::Offset {
                    parameter.unit = Unit::Radian;
                }
            }
        }
    })
}

/// The forward kinematics of the mechanism scaled by 1e-3 and 1e4 gives the scaled poses: for
/// every bundled model at every sampled pose, and for the base-driven 3-RPR at the sampled poses
/// it reaches unscaled (its type-II locus is not the bundled model's, so its home mode does not
/// cover the whole sampled workspace).
#[test]
fn a_mechanism_scaled_by_powers_of_ten_reaches_the_scaled_poses() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut models: Vec<(Mechanism, bool)> =
        bundled_models().into_iter().map(|m| (m, true)).collect();
    models.push((actuated_at_the_base(&bundled("3rpr.yaml")), false));
    for (mechanism, everywhere) in models {
        let mut poses: Vec<[f64; 6]> = (0..10)
            .map(|_| {
                mechanism
                    .workspace
                    .sample(&mechanism.home_pose, &mut rng)
                    .unwrap()
            })
            .collect();
        let params = mechanism.nominal_parameters();
        let home = mechanism.home_pose;
        let reached = |pose: &[f64; 6]| {
            forward(
                &mechanism,
                &params,
                &nominal_readings(&mechanism, pose, &home),
            )
            .is_ok_and(|back| (0..6).all(|c| (back[c] - pose[c]).abs() <= 1e-11))
        };
        if everywhere {
            assert!(poses.iter().all(reached), "{}", mechanism.name);
        } else {
            poses.retain(reached);
            assert!(
                poses.len() >= 5,
                "{}: {} poses reached",
                mechanism.name,
                poses.len()
            );
        }
        for scale in [1e-3, 1e4] {
            let big = scaled(&mechanism, scale);
            let home = big.home_pose;
            for pose in &poses {
                let pose: [f64; 6] =
                    std::array::from_fn(|c| pose[c] * if c < 3 { scale } else { 1.0 });
                let readings = nominal_readings(&big, &pose, &home);
                let back = forward(&big, &big.nominal_parameters(), &readings)
                    .unwrap_or_else(|e| panic!("{} at scale {scale}: {e}", mechanism.name));
                for c in 0..6 {
                    let unit = if c < 3 { scale } else { 1.0 };
                    assert!(
                        (back[c] - pose[c]).abs() <= 1e-11 * unit,
                        "{} at scale {scale}: {pose:?} -> {back:?}",
                        mechanism.name
                    );
                }
            }
        }
    }
}

/// The 5R's two assembly modes for one pair of readings: the platform point P (home mode) and
/// its mirror image across the line through the elbows B1, B2. A start in the mirror mode
/// converges there, is refused, and the home mode's pose is returned.
#[test]
fn a_warm_start_in_the_other_assembly_mode_gives_the_home_modes_pose() {
    let mechanism = bundled("5r.yaml");
    let params = mechanism.nominal_parameters();
    let home = mechanism.home_pose;
    let pose = [0.1, 1.0, 0.0, 0.0, 0.0, 0.0];
    // models/5r.urdf: base joints A at (∓0.5, 0), proximal links 0.75 m, distal 1.1 m.
    let mut elbows = Vec::new();
    let mut actuated = Vec::new();
    for leg in &mechanism.legs {
        let q = solve_leg(leg, &leg.geometry(&leg.nominal()), &pose, &home)
            .unwrap()
            .q;
        let base = leg.joints[0].origin;
        elbows.push([base[0] + 0.75 * q[0].cos(), base[1] + 0.75 * q[0].sin()]);
        actuated.push(q[0]);
    }
    let readings = nominal_readings(&mechanism, &pose, &home);
    let (b1, b2) = (elbows[0], elbows[1]);
    let along = [b2[0] - b1[0], b2[1] - b1[1]];
    let t = ((pose[0] - b1[0]) * along[0] + (pose[1] - b1[1]) * along[1])
        / (along[0] * along[0] + along[1] * along[1]);
    let foot = [b1[0] + t * along[0], b1[1] + t * along[1]];
    let mirror = [2.0 * foot[0] - pose[0], 2.0 * foot[1] - pose[1]];
    let start_joints = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| {
            let b = elbows[l];
            let absolute = (mirror[1] - b[1]).atan2(mirror[0] - b[0]);
            let relative = legwise::kinematics::inverse::wrap_angle(
                absolute - actuated[l] - leg.home_joints[1],
            ) + leg.home_joints[1];
            joints(&[actuated[l], relative])
        })
        .collect();
    let kinematics = ForwardKinematics::new(&mechanism, &params);
    let mut start = Configuration {
        pose: [mirror[0], mirror[1], 0.0, 0.0, 0.0, 0.0],
        joints: start_joints,
    };
    let reached = kinematics.solve_near(&readings, &mut start).unwrap();
    assert!(
        (start.pose[0] - mirror[0]).abs() < 1e-12 && (start.pose[1] - mirror[1]).abs() < 1e-12,
        "Newton from the mirror start stays in the mirror mode: {:?} against {mirror:?}",
        start.pose
    );
    for c in 0..2 {
        assert!(
            (reached[c] - pose[c]).abs() < 1e-12,
            "the home mode's pose {pose:?}, not {reached:?}"
        );
    }
}

/// A start near the answer converges from there and is left at the converged configuration;
/// a start without joints is solved from home.
#[test]
fn a_warm_start_near_the_answer_is_left_at_the_converged_configuration() {
    let mechanism = bundled("3rpr.yaml");
    let params = mechanism.nominal_parameters();
    let home = mechanism.home_pose;
    let pose = [0.05, -0.04, 0.0, 0.0, 0.0, 0.2];
    let readings = nominal_readings(&mechanism, &pose, &home);
    let kinematics = ForwardKinematics::new(&mechanism, &params);
    let nearby = [
        pose[0] + 1e-3,
        pose[1] - 1e-3,
        0.0,
        0.0,
        0.0,
        pose[5] + 1e-3,
    ];
    let mut start = Configuration {
        pose: nearby,
        joints: mechanism
            .legs
            .iter()
            .map(|leg| {
                let q = solve_leg(leg, &leg.geometry(&leg.nominal()), &nearby, &home)
                    .unwrap()
                    .q;
                joints(&q)
            })
            .collect(),
    };
    let reached = kinematics.solve_near(&readings, &mut start).unwrap();
    for c in 0..6 {
        assert!((reached[c] - pose[c]).abs() < 1e-12, "{reached:?}");
    }
    assert_eq!(
        start.pose.map(f64::to_bits),
        reached.map(f64::to_bits),
        "the start holds the converged pose"
    );
    let mut empty = Configuration {
        pose: nearby,
        joints: Vec::new(),
    };
    let from_home = kinematics.solve_near(&readings, &mut empty).unwrap();
    for c in 0..6 {
        assert!((from_home[c] - pose[c]).abs() < 1e-12, "{from_home:?}");
    }
    assert_eq!(
        empty.pose.map(f64::to_bits),
        nearby.map(f64::to_bits),
        "a start without joints is not used"
    );
}

/// The 5R's type-II singularity on its symmetry axis: the platform point P = (0, 0.45) on the
/// line through the elbows B1 = (−1.1, 0.45) and B2 = (1.1, 0.45) (|B − A| = 0.75 with
/// A = (∓0.5, 0), |P − B| = 1.1).
const SINGULAR: [f64; 6] = [0.0, 0.45, 0.0, 0.0, 0.0, 0.0];

/// Readings taken on the singularity: the two assembly modes meet there (a double root), and
/// the answer is the singular pose only to about the square root of the closure's round-off,
/// from the home mode's side.
#[test]
fn readings_on_the_type_two_singularity_give_the_singular_pose_to_the_square_root_of_round_off() {
    let mechanism = bundled("5r.yaml");
    let home = mechanism.home_pose;
    let readings = nominal_readings(&mechanism, &SINGULAR, &home);
    let reached = forward(&mechanism, &mechanism.nominal_parameters(), &readings).unwrap();
    let distance = (reached[0] - SINGULAR[0]).hypot(reached[1] - SINGULAR[1]);
    assert!(distance < 1e-6, "{reached:?}");
    assert!(
        reached[1] > SINGULAR[1],
        "approached from the home mode's side: {reached:?}"
    );
}

/// A home pose on the singularity has no assembly mode to keep: every solve is refused.
#[test]
fn a_home_pose_on_the_type_two_singularity_is_refused() {
    use legwise::error::KinematicsError;
    let mechanism = bundled("5r.yaml");
    let home = mechanism.home_pose;
    let mechanism = mechanism.edited(|parts| {
        for leg in &mut parts.legs {
            let q = solve_leg(leg, &leg.geometry(&leg.nominal()), &SINGULAR, &home)
                .unwrap()
                .q;
            leg.home_joints = q;
        }
        parts.home_pose = SINGULAR;
    });
    let params = mechanism.nominal_parameters();
    let kinematics = ForwardKinematics::new(&mechanism, &params);
    let readings = nominal_readings(&mechanism, &home, &SINGULAR);
    let err = kinematics.solve(&readings).unwrap_err();
    assert!(
        matches!(err, KinematicsError::AssemblyModeChange),
        "{err:?}"
    );
    // The home readings themselves: the home configuration is already converged there.
    let at_home = nominal_readings(&mechanism, &SINGULAR, &SINGULAR);
    let err = kinematics.solve(&at_home).unwrap_err();
    assert!(
        matches!(err, KinematicsError::AssemblyModeChange),
        "{err:?}"
    );
}

/// A platform point on the world origin: the 5R's world frame moved up by 1 m, so that the
/// pose (0, 1) of the bundled model is the origin and every leg's target there is (0, 0). The
/// tolerances still have a size (1e-3 of the longest leg): the pose solves.
#[test]
fn a_platform_point_on_the_world_origin_still_has_a_tolerance() {
    let mechanism = bundled("5r.yaml");
    let home = mechanism.home_pose;
    let origin = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    // Shift the world so that `origin` becomes (0, 0): the base joints move by −origin.
    let mechanism = mechanism.edited(|parts| {
        for leg in &mut parts.legs {
            leg.joints[0].origin[1] -= origin[1];
            for parameter in &mut leg.params {
                if let legwise::model::params::ParamTarget::JointOrigin {
                    joint: 0,
                    component: 1,
                } = parameter.target
                {
                    parameter.nominal -= origin[1];
                }
            }
        }
        parts.home_pose = [home[0], home[1] - origin[1], 0.0, 0.0, 0.0, 0.0];
    });
    let shifted_home = mechanism.home_pose;
    let readings = nominal_readings(&mechanism, &[0.0; 6], &shifted_home);
    let reached = forward(&mechanism, &mechanism.nominal_parameters(), &readings).unwrap();
    assert!(
        reached[0].abs() < 1e-12 && reached[1].abs() < 1e-12,
        "{reached:?}"
    );
}
