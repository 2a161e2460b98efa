//! The prismatic legs' closed-form kernels against the generic chain, on random geometries:
//! distance legs (one revolute about `±z` then a prismatic joint in the plane; two revolutes
//! about random axes through one point then a prismatic joint along a random axis in space,
//! with or without a fixed offset along it) and carriage legs (a prismatic joint along a random
//! line, a universal joint of random axes, a random rigid rod). At random configurations about
//! a random home, the kernel's solution (joints, closure inverse, determinant), its actuated
//! row, the reading and its derivatives with respect to every parameter and to the pose equal
//! Newton's and the chain's derivative step to 1e-12; poses out of reach are refused alike.
//! `LEGWISE_KERNEL_SEED` (1) and `LEGWISE_KERNEL_CASES` (256) as in `kernels.rs`.
use legwise::identify::jacobian::PreparedLeg;
use legwise::kinematics::chain::tip_position;
use legwise::kinematics::chain::{attachment_world, tip_and_jacobian};
use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::kernel::LegKernel;
use legwise::kinematics::reading::ReadingPredictor;
use legwise::model::joint::{JointKind, JointModel};
use legwise::model::leg::LegModel;
use legwise::model::params::{ParamTarget, Parameter, Unit};
use nalgebra::{Const, Vector3, U1};
use num_dual::DualSVec64;
use proptest::prelude::*;

use crate::kernels::config;

/// Which pattern a random leg is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    PlanarDistance,
    SpatialDistance,
    Carriage,
}

/// One random leg: its chain `(kind, origin, axis)` base to tip, and the rest.
#[derive(Debug, Clone)]
struct Random {
    kind: Kind,
    joints: Vec<(JointKind, [f64; 6], [f64; 3])>,
    gain: f64,
    offset: f64,
    attachment: [f64; 3],
    platform: [f64; 3],
    home: [f64; 3],
}

/// A unit vector from two angles.
fn unit(a: f64, b: f64) -> [f64; 3] {
    [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()]
}

fn angles() -> impl Strategy<Value = [f64; 3]> {
    (-3.0..3.0f64, -1.5..1.5f64, -3.0..3.0f64).prop_map(|(a, b, c)| [a, b, c])
}

fn position() -> impl Strategy<Value = [f64; 3]> {
    (-0.3..0.3f64, -0.3..0.3f64, -0.3..0.3f64).prop_map(|(x, y, z)| [x, y, z])
}

fn direction() -> impl Strategy<Value = [f64; 3]> {
    (-3.0..3.0f64, -1.5..1.5f64).prop_map(|(a, b)| unit(a, b))
}

fn origin(t: [f64; 3], r: [f64; 3]) -> [f64; 6] {
    [t[0], t[1], t[2], r[0], r[1], r[2]]
}

fn random_leg() -> impl Strategy<Value = Random> {
    let kind = prop_oneof![
        Just(Kind::PlanarDistance),
        Just(Kind::SpatialDistance),
        Just(Kind::Carriage)
    ];
    (
        kind,
        (
            position(),
            angles(),
            position(),
            angles(),
            angles(),
            angles(),
        ),
        (
            direction(),
            direction(),
            direction(),
            any::<bool>(),
            0.3..1.0f64,
        ),
        (
            0.5..2.0f64,
            prop_oneof![Just(1.0), Just(-1.0)],
            -0.3..0.3f64,
        ),
        (position(), (-0.5..0.5f64, -0.5..0.5f64, -3.0..3.0f64)),
        (-3.0..3.0f64, -3.0..3.0f64, 0.4..1.2f64, any::<bool>()),
    )
        .prop_map(
            |(kind, (p0, r0, p1, r1, r2, r3), axes, actuator, platform, home)| {
                let (a1, a2, a3, extra, length) = axes;
                let (revolute, prismatic) = (JointKind::Revolute, JointKind::Prismatic);
                let sign = if home.3 { 1.0 } else { -1.0 };
                let mut joints = Vec::new();
                let homes = match kind {
                    Kind::PlanarDistance => {
                        let z = [0.0, 0.0, 1.0];
                        let flat = |r: [f64; 3]| [0.0, 0.0, r[2]];
                        joints.push((JointKind::Fixed, origin(p0, flat(r0)), z));
                        joints.push((revolute, origin(p1, flat(r1)), [0.0, 0.0, sign]));
                        let along = unit(a1[0].atan2(a1[1]), 0.0);
                        joints.push((prismatic, origin([0.0; 3], flat(r2)), along));
                        if extra {
                            let t = along.map(|v| v * 0.1 * length);
                            joints.push((JointKind::Fixed, origin(t, [0.0; 3]), z));
                        }
                        [home.0, sign * home.2, 0.0]
                    }
                    Kind::SpatialDistance => {
                        joints.push((JointKind::Fixed, origin(p0, r0), [0.0, 0.0, 1.0]));
                        joints.push((revolute, origin(p1, r1), a1));
                        joints.push((revolute, origin([0.0; 3], r2), a2));
                        joints.push((prismatic, origin([0.0; 3], r3), a3));
                        if extra {
                            let t = a3.map(|v| v * 0.1 * length);
                            joints.push((JointKind::Fixed, origin(t, [0.0; 3]), [0.0, 0.0, 1.0]));
                        }
                        [home.0, home.1, sign * home.2]
                    }
                    Kind::Carriage => {
                        joints.push((prismatic, origin(p0, r0), a3));
                        if extra {
                            joints.push((JointKind::Fixed, origin(p1, r1), [0.0, 0.0, 1.0]));
                        }
                        joints.push((revolute, origin(p1, r2), a1));
                        joints.push((revolute, origin([0.0; 3], r3), a2));
                        let rod = unit(r1[0], r1[1]).map(|v| v * length);
                        joints.push((JointKind::Fixed, origin(rod, r0), [0.0, 0.0, 1.0]));
                        [sign * 0.2, home.0, home.1]
                    }
                };
                let (gain, gain_sign, offset) = actuator;
                let (attachment, (x, y, yaw)) = platform;
                Random {
                    kind,
                    joints,
                    gain: gain * gain_sign,
                    offset,
                    attachment,
                    platform: [x, y, yaw],
                    home: homes,
                }
            },
        )
}

/// The leg model of `r`: the parameters every origin component the pattern lets move
/// (translations before the first revolute and of a carriage's rod and offsets, every
/// rotation in space, x, y and yaw in the plane), the gain, the offset and the attachment.
fn leg_model(r: &Random) -> LegModel {
    let joints: Vec<JointModel> = r
        .joints
        .iter()
        .enumerate()
        .map(|(j, (kind, origin, axis))| JointModel {
            name: format!("J{j}"),
            kind: *kind,
            axis: Vector3::from(*axis),
            origin: *origin,
            limits: None,
        })
        .collect();
    let moving: Vec<usize> = (0..joints.len())
        .filter(|&j| joints[j].kind != JointKind::Fixed)
        .collect();
    let first_revolute = moving
        .iter()
        .copied()
        .find(|&j| joints[j].kind == JointKind::Revolute)
        .expect("a revolute");
    let mut params = Vec::new();
    for (j, joint) in joints.iter().enumerate() {
        let components: Vec<usize> = match r.kind {
            Kind::PlanarDistance if j <= first_revolute => vec![0, 1, 5],
            Kind::PlanarDistance if joint.kind == JointKind::Fixed => vec![],
            Kind::PlanarDistance => vec![5],
            Kind::SpatialDistance if j <= first_revolute => (0..6).collect(),
            Kind::SpatialDistance if joint.kind == JointKind::Fixed => vec![],
            Kind::SpatialDistance => vec![3, 4, 5],
            Kind::Carriage if j > first_revolute && joint.kind == JointKind::Revolute => {
                vec![3, 4, 5]
            }
            Kind::Carriage => (0..6).collect(),
        };
        for component in components {
            let unit = if component < 3 {
                Unit::Metre
            } else {
                Unit::Radian
            };
            params.push(Parameter {
                name: format!("J{j}.{component}"),
                target: ParamTarget::JointOrigin {
                    joint: j,
                    component,
                },
                nominal: joint.origin[component],
                identified: true,
                unit,
                derived: None,
                prior: None,
            });
        }
    }
    let scalar = |name: &str, target, nominal, unit| Parameter {
        name: name.into(),
        target,
        nominal,
        identified: true,
        unit,
        derived: None,
        prior: None,
    };
    params.push(scalar("gain", ParamTarget::Gain, r.gain, Unit::One));
    params.push(scalar("offset", ParamTarget::Offset, r.offset, Unit::Metre));
    for component in 0..3 {
        let target = ParamTarget::Attachment { component };
        params.push(scalar("b", target, r.attachment[component], Unit::Metre));
    }
    let dims = if r.kind == Kind::PlanarDistance { 2 } else { 3 };
    let actuated = moving
        .iter()
        .position(|&j| joints[j].kind == JointKind::Prismatic)
        .expect("a prismatic joint");
    let mut leg = LegModel {
        name: "random".into(),
        joints,
        moving,
        actuated,
        gain: r.gain,
        offset: r.offset,
        attachment: r.attachment,
        params,
        closure_dims: dims,
        home_joints: r.home[..dims].to_vec(),
        branch_sign: 1.0,
    };
    leg.branch_sign = determinant_at(&leg, &r.home).signum();
    leg
}

/// The normalised determinant of the closure Jacobian at joints `q` (nominal parameters).
fn determinant_at(leg: &LegModel, q: &[f64]) -> f64 {
    let dims = leg.closure_dims;
    let (_, jacobian) = tip_and_jacobian(leg, &leg.geometry(&leg.nominal()), &q[..dims]);
    let mut block = nalgebra::Matrix3::identity();
    for c in 0..dims {
        let norm = (0..dims)
            .map(|r| jacobian[(r, c)].powi(2))
            .sum::<f64>()
            .sqrt();
        for r in 0..dims {
            block[(r, c)] = jacobian[(r, c)] / norm;
        }
    }
    block.determinant()
}

/// The platform pose whose attachment point is the chain's tip at joints `q`.
fn pose_reaching(leg: &LegModel, r: &Random, q: &[f64]) -> [f64; 6] {
    let dims = leg.closure_dims;
    let (tip, _) = tip_and_jacobian(leg, &leg.geometry(&leg.nominal()), &q[..dims]);
    let [roll, pitch, yaw] = if dims == 2 {
        [0.0, 0.0, r.platform[2]]
    } else {
        r.platform
    };
    let mut pose = [0.0, 0.0, 0.0, roll, pitch, yaw];
    let offset = attachment_world(&pose, &r.attachment);
    for k in 0..3 {
        pose[k] = tip[k] - offset[k];
    }
    pose
}

/// The sign the kernel reads its solution's side from: `ρ + s` of a distance leg (its
/// prismatic joint's value plus the offsets along its axis), the rod's component along the
/// carriage's world direction of a carriage leg (the rod from the universal joint's centre,
/// the tip of the chain without its rod, to the tip).
fn side(leg: &LegModel, q: &[f64]) -> bool {
    let n = leg.closure_dims;
    let geometry = leg.geometry(&leg.nominal());
    if leg.actuated == 0 {
        let (tip, jacobian) = tip_and_jacobian(leg, &geometry, &q[..3]);
        let mut rodless = geometry.clone();
        let last = rodless.origins.len() - 1;
        rodless.origins[last][..3].fill(0.0);
        let centre = tip_position(leg, &rodless, &q[..3]);
        (tip - centre).dot(&jacobian.column(0)).is_sign_positive()
    } else {
        let a = leg.joints[leg.moving[n - 1]].axis;
        let s: f64 = leg.joints[leg.moving[n - 1] + 1..]
            .iter()
            .map(|j| j.origin[0] * a[0] + j.origin[1] * a[1] + j.origin[2] * a[2])
            .sum();
        (q[n - 1] + s).is_sign_positive()
    }
}

/// `a` and `b` equal to `tolerance` relative to `scale` (at least 1).
fn close(a: f64, b: f64, scale: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance * scale.max(1.0)
}

proptest! {
    #![proptest_config(config())]

    /// Solutions, actuated rows, readings and derivatives equal the generic chain's at
    /// reachable poses of the working mode and the home side.
    #[test]
    fn the_prismatic_kernels_equal_the_generic_chain(
        r in random_leg(),
        moves in proptest::collection::vec((-0.4..0.4f64, -0.4..0.4f64, -0.2..0.2f64), 4),
    ) {
        let leg = leg_model(&r);
        let n = leg.closure_dims;
        prop_assume!(determinant_at(&leg, &r.home).abs() > 0.2);
        let recognised = LegKernel::recognise(&leg);
        let expected = match r.kind {
            Kind::Carriage => matches!(recognised, Some(LegKernel::Carriage(_))),
            _ => matches!(recognised, Some(LegKernel::Distance(_))),
        };
        prop_assert!(expected, "{:?} recognised as {recognised:?}", r.kind);
        let phi = leg.nominal();
        let columns: Vec<usize> = (0..phi.len()).collect();
        let kernel = PreparedLeg::new(&leg, &phi, &columns);
        let generic = PreparedLeg::generic(&leg, &phi, &columns);
        let home = pose_reaching(&leg, &r, &r.home);
        let closed = recognised.expect("recognised").prepare(&leg.geometry(&phi));
        let home_side = side(&leg, &r.home);
        let mut compared = 0;
        for (d0, d1, d2) in moves {
            let mut q = r.home;
            let steps = [d0, d1, d2];
            for k in 0..n {
                let prismatic = leg.joints[leg.moving[k]].kind == JointKind::Prismatic;
                q[k] += if prismatic { 0.5 * steps[k] } else { steps[k] };
            }
            let determinant = determinant_at(&leg, &q);
            if determinant.abs() < 0.05 || !leg.on_home_branch(determinant) || side(&leg, &q) != home_side {
                continue;
            }
            let pose = pose_reaching(&leg, &r, &q);
            let world = attachment_world(&pose, &r.attachment);
            let seed = [r.home[0], r.home[1], r.home[2]];
            let mine = closed.solve(&world, &seed);
            prop_assert!(mine.is_some(), "the kernel handed back {q:?}");
            let mine = mine.unwrap();
            prop_assert_eq!(kernel.solve_warm(&pose, &home, None), Ok(mine));
            let Ok(theirs) = generic.solve_warm(&pose, &home, None) else {
                continue;
            };
            compared += 1;
            for k in 0..n {
                prop_assert!(close(mine.q[k], theirs.q[k], 1.0, 1e-12), "q{k}: {mine:?} vs {theirs:?}");
            }
            prop_assert_eq!(
                mine.normalised_determinant.is_sign_positive(),
                theirs.normalised_determinant.is_sign_positive()
            );
            prop_assert!(close(mine.normalised_determinant, theirs.normalised_determinant, 1.0, 1e-12));
            // As kernels.rs: the generic inverse carries Newton's round-off amplified by the
            // conditioning.
            let inverse_scale = theirs.closure_inverse.amax();
            let conditioning = 1.0 / theirs.normalised_determinant.abs();
            for (a, b) in mine.closure_inverse.iter().zip(theirs.closure_inverse.iter()) {
                prop_assert!(close(*a, *b, inverse_scale * conditioning, 1e-12), "{mine:?} vs {theirs:?}");
            }
            let (actuated, row) = closed.actuated_row(&world).expect("solved above");
            let a = leg.actuated;
            prop_assert!(close(actuated, mine.q[a], 1.0, 1e-15));
            for k in 0..3 {
                let generic_row = theirs.closure_inverse[(a, k)];
                prop_assert!(
                    close(row[k], generic_row, inverse_scale * conditioning, 1e-12),
                    "actuated row {row:?} vs {theirs:?}"
                );
            }
            let reading = closed.reading(&leg.geometry(&phi), &world, &mine).expect("solved");
            let solved = kernel.reading_of(&mine);
            prop_assert!(close(reading, solved, solved.abs(), 1e-15), "{reading} vs {solved}");
            let mut g_mine = vec![0.0; columns.len()];
            let mut g_theirs = vec![0.0; columns.len()];
            let r_mine = kernel.reading_and_gradient_of(&pose, &mine, &mut g_mine);
            let r_theirs = generic.reading_and_gradient_of(&pose, &theirs, &mut g_theirs);
            prop_assert!(close(r_mine, reading, reading.abs(), 1e-15), "{r_mine} vs {reading}");
            prop_assert!(close(r_mine, r_theirs, r_theirs.abs(), 1e-12), "{r_mine} vs {r_theirs}");
            let simulated = ReadingPredictor::new(&leg, &phi).predict(&pose, &home);
            let generic_reading = predict_reading::<f64>(&leg, &phi, &pose, &home);
            prop_assert!(
                close(simulated.clone().unwrap(), generic_reading.clone().unwrap(), r_theirs.abs(), 1e-12),
                "simulated {simulated:?} vs {generic_reading:?}"
            );
            let scale = g_theirs.iter().fold(0.0f64, |m, g| m.max(g.abs()));
            for (j, (a, b)) in g_mine.iter().zip(&g_theirs).enumerate() {
                prop_assert!(close(*a, *b, scale, 1e-12), "∂ψ/∂{}: {a} vs {b}", leg.params[j].name);
            }
            // The columns no joint origin is among (gain, offset, attachment) take the kernel
            // frame's numbers from the f64 kernel, without lanes: the same derivatives, bit for
            // bit, as a pass that composes the frame in duals (these frames do not divide).
            let origin = |c: &usize| matches!(leg.params[*c].target, ParamTarget::JointOrigin { .. });
            let fixed: Vec<usize> = columns.iter().copied().filter(|c| !origin(c)).collect();
            let mut g_fixed = vec![0.0; fixed.len()];
            PreparedLeg::new(&leg, &phi, &fixed).reading_and_gradient_of(&pose, &mine, &mut g_fixed);
            for (k, &c) in fixed.iter().enumerate() {
                prop_assert_eq!(g_fixed[k].to_bits(), g_mine[c].to_bits(), "∂ψ/∂{}", leg.params[c].name);
            }
            let measured: Vec<usize> = if n == 2 { vec![0, 1, 5] } else { (0..6).collect() };
            let p_mine = kernel.pose_gradient_of(&pose, &mine, &measured);
            let p_theirs = generic.pose_gradient_of(&pose, &theirs, &measured);
            let scale = p_theirs.iter().fold(0.0f64, |m, g| m.max(g.abs()));
            for (a, b) in p_mine.iter().zip(&p_theirs) {
                prop_assert!(close(*a, *b, scale, 1e-12), "∂ψ/∂P: {p_mine:?} vs {p_theirs:?}");
            }
        }
        prop_assume!(compared > 0);
    }

    /// A kernel's frame numbers taken alone ([`LegKernel::frame_scalars`], what a derivative
    /// pass needs) are those of the whole prepared frame, bit for bit, in f64 and in duals
    /// seeded on three random parameters (values and every lane).
    #[test]
    fn the_frame_numbers_alone_are_the_prepared_frames(
        r in random_leg(),
        seeded in proptest::collection::vec(0..64usize, 3),
    ) {
        let leg = leg_model(&r);
        let kernel = LegKernel::recognise(&leg).expect("recognised");
        let phi = leg.nominal();
        let bits = |x: &DualSVec64<3>| (x.re.to_bits(), x.eps.unwrap_generic(Const::<3>, U1).map(f64::to_bits));
        let geometry = leg.geometry(&phi);
        let alone = kernel.frame_scalars(&geometry).map(f64::to_bits);
        prop_assert_eq!(alone, kernel.prepare(&geometry).frame_scalars().map(f64::to_bits));
        let mut dual: Vec<DualSVec64<3>> = phi.iter().map(|&v| DualSVec64::from_re(v)).collect();
        for (lane, &k) in seeded.iter().enumerate() {
            let k = k % phi.len();
            dual[k] = DualSVec64::from_re(phi[k]).derivative(lane);
        }
        let geometry = leg.geometry(&dual);
        let alone = kernel.frame_scalars(&geometry).map(|x| bits(&x));
        let whole = kernel.prepare(&geometry).frame_scalars().map(|x| bits(&x));
        prop_assert_eq!(alone, whole);
    }

    /// A carriage leg's target farther from the carriage line than the rod is long is refused
    /// by the kernel (left to the generic solve) and by both solves with the same error kind.
    #[test]
    fn out_of_reach_carriages_are_refused_the_same_way(r in random_leg().prop_filter("a carriage leg", |r| r.kind == Kind::Carriage), angle in -3.0..3.0f64, along in -0.5..0.5f64) {
        let leg = leg_model(&r);
        prop_assume!(determinant_at(&leg, &r.home).abs() > 0.2);
        let phi = leg.nominal();
        let geometry = leg.geometry(&phi);
        let kernel = LegKernel::recognise(&leg).expect("a carriage leg");
        // The carriage line: the rodless chain's tip at two carriage values.
        let mut rodless = geometry.clone();
        let last = rodless.origins.len() - 1;
        let rod = Vector3::from([0, 1, 2].map(|k| rodless.origins[last][k])).norm();
        rodless.origins[last][..3].fill(0.0);
        let centre = |q0: f64| tip_position(&leg, &rodless, &[q0, 0.0, 0.0]);
        let (k0, v) = (centre(0.0), (centre(1.0) - centre(0.0)).normalize());
        let across = v.cross(&Vector3::new(angle.cos(), angle.sin(), 0.3)).normalize();
        let target = k0 + v * along + across * (rod + 0.05);
        let mut pose = [0.0; 6];
        let offset = attachment_world(&pose, &r.attachment);
        for k in 0..3 {
            pose[k] = target[k] - offset[k];
        }
        let home = pose_reaching(&leg, &r, &r.home);
        let world = attachment_world(&pose, &r.attachment);
        prop_assert!(kernel.prepare(&geometry).solve(&world, &[0.0; 3]).is_none());
        let mine = PreparedLeg::new(&leg, &phi, &[]).solve_warm(&pose, &home, None);
        let theirs = PreparedLeg::generic(&leg, &phi, &[]).solve_warm(&pose, &home, None);
        let (Err(mine), Err(theirs)) = (mine, theirs) else {
            return Err(TestCaseError::fail("an unreachable pose was solved"));
        };
        prop_assert_eq!(std::mem::discriminant(&mine), std::mem::discriminant(&theirs));
        let simulated = ReadingPredictor::new(&leg, &phi).predict(&pose, &home);
        let generic = predict_reading::<f64>(&leg, &phi, &pose, &home);
        let (Err(simulated), Err(generic)) = (simulated, generic) else {
            return Err(TestCaseError::fail("an unreachable pose was simulated"));
        };
        prop_assert_eq!(std::mem::discriminant(&simulated), std::mem::discriminant(&generic));
    }
}
