//! The pose from targets: round trips through [`observe`], closed forms, the least-squares
//! property, and the dual-number derivative against central differences.

use num_dual::{Dual64, DualStruct};

use super::*;
use crate::model::instrument::{SharedParameter, Target};
use crate::model::params::Unit;

fn instrument(targets: &[(&str, Measures, [f64; 2])], rotates: bool) -> Instrument {
    let mut parameters: Vec<SharedParameter> = ["x", "y", "yaw"]
        .iter()
        .zip([1.5, -0.5, 0.3])
        .map(|(c, v)| SharedParameter {
            name: format!("frame_{c}"),
            nominal: v,
            identified: true,
            unit: Unit::Metre,
            perturbation: 0.0,
        })
        .collect();
    for (name, _, offset) in targets {
        for (c, v) in ["x", "y"].iter().zip(offset) {
            parameters.push(SharedParameter {
                name: format!("target_{c}_{name}"),
                nominal: *v,
                identified: true,
                unit: Unit::Metre,
                perturbation: 0.0,
            });
        }
    }
    Instrument {
        parameters,
        targets: targets
            .iter()
            .map(|(name, measures, _)| Target {
                name: name.to_string(),
                measures: *measures,
                spatial: false,
                touch: None,
            })
            .collect(),
        rotates,
        spatial: false,
        forward: false,
        distances: None,
        poses: None,
        tolerance: None,
    }
}

const HOME: [f64; 6] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];

fn two_points() -> Instrument {
    instrument(
        &[
            ("r1", Measures::Position, [0.08, 0.03]),
            ("r2", Measures::Position, [-0.07, 0.03]),
        ],
        true,
    )
}

#[test]
fn the_pose_of_a_rotating_platform_comes_back_from_two_points_three_points_or_one_pose() {
    let setups = [
        two_points(),
        instrument(
            &[
                ("a", Measures::Position, [0.1, 0.0]),
                ("b", Measures::Position, [-0.05, 0.08]),
                ("c", Measures::Position, [-0.05, -0.09]),
            ],
            true,
        ),
        instrument(&[("m", Measures::Pose, [0.02, -0.04])], true),
        instrument(
            &[
                ("m", Measures::Pose, [0.02, -0.04]),
                ("r", Measures::Position, [0.1, 0.1]),
            ],
            true,
        ),
    ];
    let pose = [0.12, -0.07, 0.0, 0.0, 0.0, -0.41];
    for setup in &setups {
        let shared = setup.nominal();
        let observed = observe(setup, &shared, &pose);
        assert_eq!(observed.len(), setup.observed_len());
        let back = platform_pose::<f64>(setup, &shared, &observed, &HOME);
        for c in 0..6 {
            assert!(
                (back[c] - pose[c]).abs() < 1e-14,
                "{c}: {back:?} vs {pose:?}"
            );
        }
    }
}

#[test]
fn a_platform_that_does_not_rotate_keeps_its_home_yaw_and_one_point_gives_its_position() {
    let setup = instrument(&[("p", Measures::Position, [0.0, 0.0])], false);
    let home = [0.0, 1.1, 0.0, 0.0, 0.0, 0.25];
    let pose = [0.3, 0.9, 0.0, 0.0, 0.0, 0.25];
    let shared = setup.nominal();
    let observed = observe(&setup, &shared, &pose);
    // Closed form: the frame's inverse applied to the point.
    let (s, c) = 0.3f64.sin_cos();
    let (dx, dy) = (0.3 - 1.5, 0.9 + 0.5);
    assert!((observed[0] - (c * dx + s * dy)).abs() < 1e-15);
    assert!((observed[1] - (-s * dx + c * dy)).abs() < 1e-15);
    let back = platform_pose::<f64>(&setup, &shared, &observed, &home);
    assert_eq!(back[5].to_bits(), 0.25f64.to_bits());
    assert!((back[0] - 0.3).abs() < 1e-15 && (back[1] - 0.9).abs() < 1e-15);
}

#[test]
fn two_points_give_the_angle_between_the_offset_segment_and_the_measured_one() {
    let setup = two_points();
    let shared = setup.nominal();
    // Measured points chosen freely (not a rigid image: the segment is longer).
    let observed = [0.4, 0.2, 0.1, 0.6];
    let pose = platform_pose::<f64>(&setup, &shared, &observed, &HOME);
    // Offset segment r1 -> r2 points along −x (angle π); measured, in the base frame, the
    // instrument's segment turned by the frame's yaw 0.3.
    let measured_angle = (0.6f64 - 0.2).atan2(0.1 - 0.4) + 0.3;
    let expected = measured_angle - std::f64::consts::PI;
    let wrapped = expected - (expected / std::f64::consts::TAU).round() * std::f64::consts::TAU;
    assert!(
        (pose[5] - wrapped).abs() < 1e-14,
        "{} vs {wrapped}",
        pose[5]
    );
}

#[test]
fn the_fitted_pose_minimises_the_squared_distances_of_the_targets() {
    let setup = instrument(
        &[
            ("a", Measures::Position, [0.1, 0.0]),
            ("b", Measures::Position, [-0.05, 0.08]),
            ("c", Measures::Position, [-0.05, -0.09]),
        ],
        true,
    );
    let shared = setup.nominal();
    let mut observed = observe(&setup, &shared, &[0.1, 0.05, 0.0, 0.0, 0.0, 0.2]);
    for (i, v) in observed.iter_mut().enumerate() {
        *v += 1e-3 * [0.7, -1.1, 0.4, 0.9, -0.3, -0.8][i];
    }
    let fitted = platform_pose::<f64>(&setup, &shared, &observed, &HOME);
    let cost = |pose: &[f64; 6]| -> f64 {
        let predicted = observe(&setup, &shared, pose);
        predicted
            .iter()
            .zip(&observed)
            .map(|(a, b)| (a - b).powi(2))
            .sum()
    };
    let best = cost(&fitted);
    for (c, h) in [(0, 1e-4), (1, 1e-4), (5, 1e-3)] {
        for sign in [-1.0, 1.0] {
            let mut moved = fitted;
            moved[c] += sign * h;
            assert!(cost(&moved) > best, "moving coordinate {c} lowers the cost");
        }
    }
}

#[test]
fn the_dual_derivative_with_respect_to_the_shared_parameters_matches_central_differences() {
    for setup in [
        two_points(),
        instrument(&[("m", Measures::Pose, [0.02, -0.04])], true),
        instrument(&[("p", Measures::Position, [0.01, 0.02])], false),
    ] {
        let shared = setup.nominal();
        let observed: Vec<f64> = observe(&setup, &shared, &[0.1, -0.2, 0.0, 0.0, 0.0, 0.35])
            .iter()
            .enumerate()
            .map(|(i, v)| v + 1e-3 * (i as f64 - 1.5))
            .collect();
        for k in 0..shared.len() {
            let seeded: Vec<Dual64> = shared
                .iter()
                .enumerate()
                .map(|(j, &v)| {
                    let d = Dual64::from_re(v);
                    if j == k {
                        d.derivative()
                    } else {
                        d
                    }
                })
                .collect();
            let dual = platform_pose(&setup, &seeded, &observed, &HOME);
            let h = 1e-6;
            let at = |delta: f64| {
                let mut moved = shared.clone();
                moved[k] += delta;
                platform_pose::<f64>(&setup, &moved, &observed, &HOME)
            };
            let (plus, minus) = (at(h), at(-h));
            for c in 0..6 {
                let central = (plus[c] - minus[c]) / (2.0 * h);
                assert!(
                    (dual[c].eps - central).abs() < 1e-8,
                    "∂P{c}/∂s{k}: dual {} vs central {central}",
                    dual[c].eps
                );
                let value = platform_pose::<f64>(&setup, &shared, &observed, &HOME)[c];
                assert_eq!(dual[c].re().to_bits(), value.to_bits());
            }
        }
    }
}
