//! Joint limits: the URDF `<limit lower upper>` of a prismatic or revolute joint bounds the
//! workspace computations (candidate poses, MIW rays), checked against leg lengths computed here
//! from the hexapod's definition; a malformed limit is refused with the joint named.
use legwise::model::joint::JointKind;
use legwise::selection::candidates::candidate_pool;

use crate::cli::{legwise, text};
use crate::spatial::{edited, platform_point};
use crate::support::bundled;

/// The hexapod's six leg lengths `|p + R·b − a|` at `pose`, nominal geometry (a at 0.5 m,
/// b at 0.25 m, at the angles of the definition).
fn hexapod_lengths(pose: &[f64; 6]) -> Vec<f64> {
    let on_circle = |r: f64, degrees: f64| {
        let a = degrees.to_radians();
        [r * a.cos(), r * a.sin(), 0.0]
    };
    let base = [350.0, 10.0, 110.0, 130.0, 230.0, 250.0];
    let platform = [310.0, 50.0, 70.0, 170.0, 190.0, 290.0];
    base.iter()
        .zip(platform)
        .map(|(&a, b)| {
            let a = on_circle(0.5, a);
            let point = platform_point(pose, on_circle(0.25, b));
            (0..3)
                .map(|k| (point[k] - a[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect()
}

#[test]
fn urdf_limits_are_read_for_prismatic_and_revolute_joints_only() {
    let hexapod = bundled("hexapod.yaml");
    for leg in &hexapod.legs {
        for joint in &leg.joints {
            match joint.kind {
                JointKind::Prismatic => {
                    assert_eq!(joint.limits, Some([0.5, 0.9]), "{}", joint.name)
                }
                _ => assert_eq!(joint.limits, None, "{} is continuous", joint.name),
            }
        }
    }
    let delta = bundled("delta.yaml");
    assert_eq!(delta.legs[0].joints[0].limits, Some([0.0, 1.0]));
    // A revolute joint's range is read too; a `<limit>` without a range is none.
    let mechanism = edited(
        "hexapod.yaml",
        &[],
        &[
            (
                "<joint name=\"U1b\" type=\"continuous\">",
                "<joint name=\"U1b\" type=\"revolute\"><limit lower=\"-0.5\" upper=\"0.5\" effort=\"1\" velocity=\"1\"/>",
            ),
            (
                "<limit lower=\"0.5\" upper=\"0.9\" effort=\"1000\" velocity=\"0.1\"/>\n  </joint>\n  <link name=\"cross2\"/>",
                "<limit lower=\"0\" upper=\"0\" effort=\"1000\" velocity=\"0.1\"/>\n  </joint>\n  <link name=\"cross2\"/>",
            ),
        ],
    )
    .unwrap();
    let joints = &mechanism.legs[0].joints;
    assert_eq!(joints[1].limits, Some([-0.5, 0.5]));
    assert_eq!(joints[2].limits, None, "lower = upper: no range");
    // Lower above upper.
    let error = edited(
        "hexapod.yaml",
        &[],
        &[(
            "<limit lower=\"0.5\" upper=\"0.9\" effort=\"1000\" velocity=\"0.1\"/>\n  </joint>\n  <link name=\"cross2\"/>",
            "<limit lower=\"0.9\" upper=\"0.5\" effort=\"1000\" velocity=\"0.1\"/>\n  </joint>\n  <link name=\"cross2\"/>",
        )],
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        error,
        "hexapod.yaml: field `legs[0].chain[2]`: joint `P1` has <limit lower=\"0.9\" upper=\"0.5\">; expected lower <= upper"
    );
}

#[test]
fn candidates_beyond_a_stroke_are_rejected_and_counted() {
    // The bundled stroke 0.5–0.9 m holds every grid pose (legs 0.56–0.84 m): none rejected.
    let coarse = [
        ("grid: 0.025", "grid: 0.05"),
        ("range_levels: 5", "range_levels: 3"),
    ];
    let bundled_stroke = edited("hexapod.yaml", &coarse, &[]).unwrap();
    let pool = candidate_pool(&bundled_stroke, None).unwrap();
    assert_eq!(pool.inside, 27 * 27);
    assert_eq!(pool.beyond_limits, 0);
    // A stroke of 0.6–0.9 m: the grid poses with a leg shorter than 0.6 m (counted here from
    // the leg lengths) are rejected, every other is kept.
    let short = "<limit lower=\"0.6\" upper=\"0.9\" effort=\"1000\" velocity=\"0.1\"/>";
    let narrowed = edited(
        "hexapod.yaml",
        &coarse,
        &[(
            "<limit lower=\"0.5\" upper=\"0.9\" effort=\"1000\" velocity=\"0.1\"/>",
            short,
        )],
    )
    .unwrap();
    let narrowed_pool = candidate_pool(&narrowed, None).unwrap();
    let outside = |pose: &[f64; 6]| {
        hexapod_lengths(pose)
            .iter()
            .any(|l| !(0.6..=0.9).contains(l))
    };
    let expected = pool.candidates.iter().filter(|c| outside(&c.pose)).count();
    assert!(
        expected > 0 && expected < pool.candidates.len(),
        "{expected}"
    );
    let kept: Vec<[f64; 6]> = pool
        .candidates
        .iter()
        .map(|c| c.pose)
        .filter(|p| !outside(p))
        .collect();
    let narrowed_poses: Vec<[f64; 6]> = narrowed_pool.candidates.iter().map(|c| c.pose).collect();
    assert_eq!(narrowed_poses, kept);
    // Rejected before the singularity screening, so possibly more than among the feasible ones.
    assert!(narrowed_pool.beyond_limits >= expected);
    let p = &narrowed_pool;
    assert_eq!(
        p.candidates.len() + p.unreachable + p.beyond_limits + p.near_serial + p.near_parallel,
        p.inside
    );
}

#[test]
fn the_spatial_workspace_rays_all_end_at_a_boundary() {
    // With the strokes honoured, no ray of either spatial model runs to the reach cap.
    for model in ["models/delta.yaml", "models/hexapod.yaml"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("w.svg");
        let run = legwise(&[
            "workspace",
            "--model",
            model,
            "--rays",
            "64",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stdout = text(&run.stdout);
        assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
        assert!(stdout.contains("radius"), "{stdout}");
        assert!(!stdout.contains("met no boundary"), "{model}: {stdout}");
    }
}

/// A planar model's rays stop at its strokes too: the 3-RPR's URDF limits its legs to 0–1 m,
/// and the MIW's nearest boundary point is where a leg (|p + R·b − a| from the model's base
/// and platform points, computed here) is 1 m long. (Without the limits the MIW radius was
/// 0.5385 m; its candidate poses, legs 0.24–0.82 m, are unchanged.)
#[test]
fn the_3rpr_miw_stops_where_a_leg_reaches_its_1_m_stroke() {
    use legwise::workspace::miw::{maximal_inscribed_workspace, MiwOptions};
    let mechanism = bundled("3rpr.yaml");
    let options = MiwOptions {
        rays: 360,
        ..MiwOptions::for_mechanism(&mechanism)
    };
    let miw = maximal_inscribed_workspace(&mechanism, options).unwrap();
    let c = miw.centre;
    let distance = |p: &[f64; 2]| (p[0] - c[0]).hypot(p[1] - c[1]);
    let nearest = miw
        .boundary
        .iter()
        .min_by(|a, b| distance(a).total_cmp(&distance(b)))
        .unwrap();
    let yaw = mechanism.home_pose[5];
    let lengths: Vec<f64> = mechanism
        .legs
        .iter()
        .map(|leg| {
            let a = leg.joints[0].origin;
            let b = leg.attachment;
            let (s, co) = yaw.sin_cos();
            let tip = [
                nearest[0] + co * b[0] - s * b[1],
                nearest[1] + s * b[0] + co * b[1],
            ];
            (tip[0] - a[0]).hypot(tip[1] - a[1])
        })
        .collect();
    let longest = lengths.iter().copied().fold(0.0, f64::max);
    assert!(
        (longest - 1.0).abs() < 1e-9,
        "{nearest:?}: legs {lengths:?}"
    );
    assert!((miw.radius - 0.4615).abs() < 1e-3, "radius {}", miw.radius);
}
