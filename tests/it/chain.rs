//! The leg chain's several implementations (the generic walk, the prepared frames, the
//! Jacobian walk, the backward-accumulated dual chain, the world axes, the platform attachment)
//! against a reference written here with nalgebra's isometries, on random chains whose joint
//! origins have every component non-zero and whose axes are oblique: any slip in an index,
//! a sign or a product of the hand-written 3 × 3 algebra shows as a wrong tip.

use legwise::kinematics::chain::{
    attachment_on, attachment_on_constant, attachment_world, moving_axes, platform_transform,
    platform_transform_f64, tip_and_jacobian, tip_position, ChainFrames, TipChain,
};
use legwise::model::joint::{JointKind, JointModel};
use legwise::model::leg::{LegGeometry, LegModel};
use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use num_dual::{Dual64, DualStruct};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn isometry(origin: &[f64; 6]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(origin[0], origin[1], origin[2]),
        UnitQuaternion::from_euler_angles(origin[3], origin[4], origin[5]),
    )
}

fn motion(joint: &JointModel, q: f64) -> Isometry3<f64> {
    let axis = Unit::new_normalize(joint.axis);
    match joint.kind {
        JointKind::Revolute => Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&axis, q),
        ),
        JointKind::Prismatic => Isometry3::translation(axis.x * q, axis.y * q, axis.z * q),
        JointKind::Fixed => Isometry3::identity(),
    }
}

/// The reference: the tip and, per moving joint, its world axis and position before its motion.
fn reference(leg: &LegModel, origins: &[[f64; 6]], q: &[f64]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
    let mut world = Isometry3::identity();
    let mut axes = Vec::new();
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(origins) {
        world *= isometry(origin);
        if joint.is_moving() {
            axes.push(world.rotation * joint.axis);
            world *= motion(joint, q[next]);
            next += 1;
        }
    }
    (world.translation.vector, axes)
}

fn random_chain(rng: &mut ChaCha8Rng) -> (LegModel, LegGeometry<f64>) {
    let kinds = [JointKind::Revolute, JointKind::Prismatic];
    let mut joints = Vec::new();
    let mut moving = Vec::new();
    // Three moving joints of random kinds, with a fixed joint before, between or after them.
    let fixed_at = rng.random_range(0..4);
    for j in 0..4 {
        let kind = if j == fixed_at {
            JointKind::Fixed
        } else {
            kinds[rng.random_range(0..2)]
        };
        if kind != JointKind::Fixed {
            moving.push(joints.len());
        }
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(0.2..1.0),
        )
        .normalize();
        let origin = std::array::from_fn(|c| {
            let magnitude = if c < 3 { 0.8 } else { 1.5 };
            let value: f64 = rng.random_range(0.1..magnitude);
            if rng.random_bool(0.5) {
                value
            } else {
                -value
            }
        });
        joints.push(JointModel {
            name: format!("J{j}"),
            kind,
            axis,
            origin,
            limits: None,
        });
    }
    let attachment = [0.05, -0.03, 0.02];
    let geometry = LegGeometry {
        origins: joints.iter().map(|j| j.origin).collect(),
        gain: 1.0,
        offset: 0.0,
        attachment,
    };
    let leg = LegModel {
        name: "random".into(),
        joints,
        moving,
        actuated: 0,
        gain: 1.0,
        offset: 0.0,
        attachment,
        params: Vec::new(),
        closure_dims: 3,
        home_joints: vec![0.0; 3],
        branch_sign: 1.0,
    };
    (leg, geometry)
}

fn assert_close(got: &Vector3<f64>, expected: &Vector3<f64>, tolerance: f64, what: &str) {
    assert!(
        (got - expected).norm() <= tolerance,
        "{what}: {got:?} against {expected:?}"
    );
}

#[test]
fn every_chain_walk_gives_the_reference_tip_axes_and_jacobian() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..40 {
        let (leg, geometry) = random_chain(&mut rng);
        let q: Vec<f64> = (0..3).map(|_| rng.random_range(-2.0..2.0)).collect();
        let (tip, axes) = reference(&leg, &geometry.origins, &q);
        assert_close(
            &tip_position(&leg, &geometry, &q),
            &tip,
            1e-13,
            "tip_position",
        );
        let frames = ChainFrames::new(&geometry);
        assert_close(&frames.tip(&leg, &q), &tip, 1e-13, "ChainFrames::tip");
        for (what, (walked, jacobian)) in [
            ("tip_and_jacobian", tip_and_jacobian(&leg, &geometry, &q)),
            (
                "ChainFrames::tip_and_jacobian",
                frames.tip_and_jacobian(&leg, &q),
            ),
        ] {
            assert_close(&walked, &tip, 1e-13, what);
            for k in 0..3 {
                let h = 1e-6;
                let (mut up, mut down) = (q.clone(), q.clone());
                up[k] += h;
                down[k] -= h;
                let difference = (reference(&leg, &geometry.origins, &up).0
                    - reference(&leg, &geometry.origins, &down).0)
                    / (2.0 * h);
                assert_close(&jacobian.column(k).into_owned(), &difference, 1e-8, what);
            }
        }
        let world_axes = moving_axes(&leg, &geometry, &q);
        assert_eq!(world_axes.len(), 3);
        for ((kind, axis), (expected, &joint)) in
            world_axes.iter().zip(axes.iter().zip(&leg.moving))
        {
            assert_eq!(*kind, leg.joints[joint].kind);
            assert_close(axis, expected, 1e-13, "moving_axes");
        }
    }
}

/// The backward-accumulated chain in dual numbers: its value is the reference tip, and its
/// derivative by any origin component whose angles carry derivatives is the reference's
/// central difference. Joints marked constant keep their angles' f64 values.
#[test]
fn the_dual_tip_chain_gives_the_reference_tip_and_its_origin_derivatives() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for _ in 0..20 {
        let (leg, geometry) = random_chain(&mut rng);
        let q: Vec<f64> = (0..3).map(|_| rng.random_range(-2.0..2.0)).collect();
        let (tip, _) = reference(&leg, &geometry.origins, &q);
        let variable: Vec<bool> = (0..leg.joints.len())
            .map(|_| rng.random_bool(0.5))
            .collect();
        for joint in 0..leg.joints.len() {
            for component in 0..6 {
                let mut seeded = LegGeometry {
                    origins: geometry
                        .origins
                        .iter()
                        .map(|o| o.map(Dual64::from))
                        .collect(),
                    gain: Dual64::from(1.0),
                    offset: Dual64::from(0.0),
                    attachment: geometry.attachment.map(Dual64::from),
                };
                seeded.origins[joint][component].eps = 1.0;
                let dual = TipChain::new(&seeded, &variable).tip(&leg, &q);
                let value = dual.map(|v| v.re());
                assert_close(&value, &tip, 1e-13, "TipChain value");
                let h = 1e-6;
                let (mut up, mut down) = (geometry.origins.clone(), geometry.origins.clone());
                up[joint][component] += h;
                down[joint][component] -= h;
                let difference =
                    (reference(&leg, &up, &q).0 - reference(&leg, &down, &q).0) / (2.0 * h);
                let expected = if component < 3 || variable[joint] {
                    difference
                } else {
                    Vector3::zeros()
                };
                let derivative = dual.map(|v| v.eps);
                assert_close(&derivative, &expected, 1e-8, "TipChain derivative");
            }
        }
    }
}

#[test]
fn every_platform_attachment_gives_the_reference_point() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let pose: [f64; 6] =
            std::array::from_fn(|c| rng.random_range(if c < 3 { -1.0..1.0 } else { -1.5..1.5 }));
        let attachment = [
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
        ];
        let expected = isometry(&pose) * Point3::from(attachment);
        let expected = expected.coords;
        assert_close(
            &attachment_world(&pose, &attachment),
            &expected,
            1e-14,
            "attachment_world",
        );
        for platform in [platform_transform(&pose), platform_transform_f64(&pose)] {
            assert_close(
                &attachment_on(&platform, &attachment),
                &expected,
                1e-14,
                "attachment_on",
            );
            assert_close(
                &attachment_on_constant(&platform, &attachment),
                &expected,
                1e-14,
                "attachment_on_constant",
            );
        }
        // A dual attachment moves the point by the rotation's column.
        let mut dual = attachment.map(Dual64::from);
        dual[1].eps = 1.0;
        let moved = attachment_on_constant(&platform_transform(&pose), &dual);
        let column = isometry(&pose).rotation * Vector3::y();
        assert_close(
            &moved.map(|v| v.eps),
            &column,
            1e-14,
            "attachment derivative",
        );
        let moved = attachment_on(&platform_transform(&pose), &dual);
        assert_close(
            &moved.map(|v| v.eps),
            &column,
            1e-14,
            "attachment derivative",
        );
    }
}
