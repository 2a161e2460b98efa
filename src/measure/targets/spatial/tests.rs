//! The spatial pose from targets: closed forms of the report, round trips through `observe`
//! (three coplanar position targets, a pose target, both, a platform that does not rotate), the
//! least-squares property, and the dual-number derivatives against central differences.

use nalgebra::{Matrix3, Vector3};
use num_dual::{Dual64, DualStruct};

use super::*;
use crate::measure::targets::{observe, platform_pose, platform_pose_from};
use crate::model::instrument::{SharedParameter, Target, SPATIAL_FRAME, SPATIAL_OFFSET};
use crate::model::params::Unit;

const FRAME: [f64; 6] = [1.2, -0.7, 0.4, 0.05, -0.08, 2.1];

fn instrument(targets: &[(&str, Measures, [f64; 3])], rotates: bool) -> Instrument {
    let parameter = |name: String, nominal: f64| SharedParameter {
        name,
        nominal,
        identified: true,
        unit: Unit::Metre,
        perturbation: 0.0,
    };
    let mut parameters: Vec<SharedParameter> = SPATIAL_FRAME
        .iter()
        .zip(FRAME)
        .map(|(c, v)| parameter(format!("frame_{c}"), v))
        .collect();
    for (name, _, offset) in targets {
        for (c, v) in SPATIAL_OFFSET.iter().zip(offset) {
            parameters.push(parameter(format!("target_{c}_{name}"), *v));
        }
    }
    Instrument {
        parameters,
        targets: targets
            .iter()
            .map(|(name, measures, _)| Target {
                name: name.to_string(),
                measures: *measures,
                spatial: true,
                touch: None,
            })
            .collect(),
        rotates,
        spatial: true,
        forward: false,
        distances: None,
        poses: None,
        tolerance: None,
    }
}

fn three_points() -> Instrument {
    instrument(
        &[
            ("r1", Measures::Position, [0.12, 0.0, 0.03]),
            ("r2", Measures::Position, [-0.06, 0.1, 0.03]),
            ("r3", Measures::Position, [-0.06, -0.1, 0.03]),
        ],
        true,
    )
}

fn marker() -> Instrument {
    instrument(&[("m", Measures::Pose, [0.02, -0.04, 0.05])], true)
}

fn mixed() -> Instrument {
    instrument(
        &[
            ("r", Measures::Position, [0.1, 0.1, 0.0]),
            ("m", Measures::Pose, [0.02, -0.04, 0.05]),
        ],
        true,
    )
}

fn translating() -> Instrument {
    instrument(&[("p", Measures::Position, [0.01, 0.02, -0.03])], false)
}

const HOME: [f64; 6] = [0.0, 0.0, 0.6, 0.0, 0.0, 0.0];
const POSE: [f64; 6] = [0.03, -0.02, 0.62, 0.11, -0.07, 0.13];

/// `Rz(yaw) Ry(pitch) Rx(roll)` written out.
fn rz_ry_rx(roll: f64, pitch: f64, yaw: f64) -> Matrix3<f64> {
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let (sy, cy) = yaw.sin_cos();
    let rz = Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    rz * ry * rx
}

#[test]
fn the_report_is_the_target_in_the_frame_and_the_angles_are_the_pose_convention() {
    let setup = mixed();
    let observed = observe(&setup, &setup.nominal(), &POSE);
    assert_eq!(observed.len(), 9);
    let frame = rz_ry_rx(FRAME[3], FRAME[4], FRAME[5]);
    let platform = rz_ry_rx(POSE[3], POSE[4], POSE[5]);
    let p = Vector3::new(POSE[0], POSE[1], POSE[2]);
    let f = Vector3::new(FRAME[0], FRAME[1], FRAME[2]);
    let expected = frame.transpose() * (p + platform * Vector3::new(0.1, 0.1, 0.0) - f);
    for c in 0..3 {
        assert!((observed[c] - expected[c]).abs() < 1e-15);
    }
    // The marker's angles give back R_fᵀ R_P.
    let [r, pi, y] = [observed[6], observed[7], observed[8]];
    assert!((rz_ry_rx(r, pi, y) - frame.transpose() * platform).amax() < 1e-15);
    // And `angles` inverts the convention.
    let back = angles(&rz_ry_rx(0.3, -1.2, -2.8));
    for (a, b) in back.iter().zip([0.3, -1.2, -2.8]) {
        assert!((a - b).abs() < 1e-14);
    }
}

#[test]
fn the_pose_comes_back_from_three_coplanar_points_a_marker_both_or_one_point_of_a_translating_platform(
) {
    for (setup, pose) in [
        (three_points(), POSE),
        (marker(), POSE),
        (mixed(), POSE),
        (translating(), [0.03, -0.02, 0.62, 0.0, 0.0, 0.0]),
    ] {
        let shared = setup.nominal();
        let observed = observe(&setup, &shared, &pose);
        assert_eq!(observed.len(), setup.observed_len());
        let back = platform_pose::<f64>(&setup, &shared, &observed, &HOME);
        for c in 0..6 {
            assert!(
                (back[c] - pose[c]).abs() < 1e-14,
                "{c}: {back:?} vs {pose:?}"
            );
        }
    }
    // Yaw near ±π is taken on the turn nearest home.
    let setup = three_points();
    let pose = [0.0, 0.0, 0.6, 0.1, 0.2, 3.1];
    let observed = observe(&setup, &setup.nominal(), &pose);
    let home = [0.0, 0.0, 0.6, 0.0, 0.0, -3.0];
    let back = platform_pose::<f64>(&setup, &setup.nominal(), &observed, &home);
    assert!(
        (back[5] - (3.1 - std::f64::consts::TAU)).abs() < 1e-13,
        "{back:?}"
    );
}

#[test]
fn the_fitted_pose_minimises_the_squared_distances_of_three_disturbed_points() {
    let setup = three_points();
    let shared = setup.nominal();
    let mut observed = observe(&setup, &shared, &POSE);
    for (i, v) in observed.iter_mut().enumerate() {
        *v += 1e-3 * [0.7, -1.1, 0.4, 0.9, -0.3, -0.8, 0.2, 0.5, -0.6][i];
    }
    let fitted = platform_pose::<f64>(&setup, &shared, &observed, &HOME);
    let cost = |pose: &[f64; 6]| -> f64 {
        observe(&setup, &shared, pose)
            .iter()
            .zip(&observed)
            .map(|(a, b)| (a - b).powi(2))
            .sum()
    };
    let best = cost(&fitted);
    assert!(best > 1e-7, "the points are not a rigid image");
    for c in 0..6 {
        for sign in [-1.0, 1.0] {
            let mut moved = fitted;
            moved[c] += sign * 1e-4;
            assert!(cost(&moved) > best, "moving coordinate {c} lowers the cost");
        }
    }
}

fn seeded(values: &[f64], k: usize) -> Vec<Dual64> {
    values
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
        .collect()
}

#[test]
fn the_dual_derivatives_with_respect_to_the_shared_parameters_and_the_report_match_central_differences(
) {
    for setup in [three_points(), marker(), mixed(), translating()] {
        let shared = setup.nominal();
        let observed: Vec<f64> = observe(&setup, &shared, &POSE)
            .iter()
            .enumerate()
            .map(|(i, v)| v + 1e-3 * (i as f64 - 3.5))
            .collect();
        let value = platform_pose::<f64>(&setup, &shared, &observed, &HOME);
        let h = 1e-6;
        let mut checked = 0;
        // With respect to each shared parameter, then each reported coordinate.
        for (k, wrt_shared) in (0..shared.len())
            .map(|k| (k, true))
            .chain((0..observed.len()).map(|k| (k, false)))
        {
            let dual = if wrt_shared {
                platform_pose(&setup, &seeded(&shared, k), &observed, &HOME)
            } else {
                let lifted: Vec<Dual64> = shared.iter().map(|&v| Dual64::from(v)).collect();
                platform_pose_from(&setup, &lifted, &seeded(&observed, k), &HOME)
            };
            let at = |delta: f64| {
                let (mut s, mut m) = (shared.clone(), observed.clone());
                if wrt_shared {
                    s[k] += delta;
                } else {
                    m[k] += delta;
                }
                platform_pose::<f64>(&setup, &s, &m, &HOME)
            };
            let (plus, minus) = (at(h), at(-h));
            let central: Vec<f64> = (0..6).map(|c| (plus[c] - minus[c]) / (2.0 * h)).collect();
            let scale = central.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-3);
            for c in 0..6 {
                assert!(
                    (dual[c].eps - central[c]).abs() <= 1e-6 * scale,
                    "∂P{c}/∂{}{k}: dual {} vs central {}",
                    if wrt_shared { "s" } else { "m" },
                    dual[c].eps,
                    central[c]
                );
                assert!((dual[c].re() - value[c]).abs() < 1e-14);
            }
            checked += central.iter().filter(|v| v.abs() > 1e-3).count();
        }
        assert!(checked > 10, "the derivatives are not all zero");
    }
}

/// The report's shortcuts — a platform that does not turn leaves its offsets as they are, and a
/// target reporting some coordinates has only those computed — give the full product's
/// numbers bit for bit, values and derivatives (dual lanes on the pose's z, the frame's roll and
/// the target's z offset), for every subset of coordinates, turning and not.
#[test]
fn the_report_s_shortcuts_are_the_full_product_bit_for_bit() {
    use num_dual::DualSVec64;
    type D = DualSVec64<3>;
    let lanes = |v: &D| -> Vec<u64> {
        let eps = v.eps.unwrap_generic(nalgebra::Const::<3>, nalgebra::U1);
        std::iter::once(v.re.to_bits())
            .chain(eps.iter().map(|e| e.to_bits()))
            .collect()
    };
    for mask in 1u8..8 {
        let setup = instrument(
            &[("n", Measures::Coordinates(mask), [0.0, 0.0, -0.02])],
            false,
        );
        let mut shared: Vec<D> = setup.nominal().iter().map(|&v| D::from_re(v)).collect();
        shared[Instrument::FRAME + 3] = shared[Instrument::FRAME + 3].derivative(1);
        let offset = setup.offset_index(0);
        shared[offset + 2] = shared[offset + 2].derivative(2);
        let frame = Frame::new(&shared);
        for pose in [HOME, POSE] {
            let mut seeded: [D; 6] = pose.map(D::from_re);
            seeded[2] = seeded[2].derivative(0);
            let platform = platform_rotation(&seeded);
            let mut fast = Vec::new();
            observe_framed(&setup, (&shared, &frame), (&platform, &seeded), &mut fast);
            // The full product, every coordinate, then the reported ones picked.
            let t = Vector3::new(shared[offset], shared[offset + 1], shared[offset + 2]);
            let p = Vector3::new(seeded[0], seeded[1], seeded[2]);
            let m = frame.transposed * (p + platform * t - frame.origin);
            let full: Vec<D> = setup.targets[0]
                .pose_indices()
                .iter()
                .map(|&c| m[c])
                .collect();
            assert_eq!(fast.len(), full.len(), "mask {mask}");
            for (a, b) in fast.iter().zip(&full) {
                assert_eq!(
                    lanes(a),
                    lanes(b),
                    "mask {mask}, pose {pose:?}: {a} against {b}"
                );
            }
        }
    }
}
