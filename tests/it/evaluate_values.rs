//! Values of `evaluate`: the accuracy map's grid (counted here on lattices whose coordinates
//! are exact binary fractions), the points-limit of the grid at and around its thresholds, the
//! joints a map hands to the next one (checked against the closed-form 5R inverse kinematics),
//! and the CSV lines an evaluation reports for measurements that were not read from a file.
use legwise::evaluate::accuracy::{map_grid, reached_poses_from, MAX_MAP_POINTS};
use legwise::evaluate::held_out::evaluate;
use legwise::evaluate::through_instrument::evaluate_observed;
use legwise::kinematics::platform::ForwardKinematics;
use legwise::measure::observations::{Observations, ObservedRow};
use legwise::measure::{MeasuredPose, MeasurementSet};
use legwise::model::region::Region;
use legwise::model::Mechanism;

use crate::accuracy_map::five_bar_ik;
use crate::support::bundled;

/// Lattice spacing of the exact grids: 2⁻¹⁰ m, so that every lattice coordinate `k · G` is
/// exact in binary.
const G: f64 = 1.0 / 1024.0;

/// The 5R model with its workspace region replaced by `region` and its home pose by `home`
/// (all the grid reads of a mechanism).
fn with_region(region: Region, home: [f64; 6]) -> Mechanism {
    bundled("5r.yaml").edited(|parts| {
        parts.workspace.region = region;
        parts.home_pose = home;
    })
}

/// The lattice points `(i, j)` (units of [`G`], from the disc's centre) of a disc of radius
/// `k · G`: `i² + j² ≤ k²`, in the grid's order (rows of increasing `j`, each of increasing
/// `i`). Integer arithmetic only.
fn disc_lattice(k: i64) -> Vec<(i64, i64)> {
    (-k..=k)
        .flat_map(|j| (-k..=k).map(move |i| (i, j)))
        .filter(|&(i, j)| i * i + j * j <= k * k)
        .collect()
}

#[test]
fn the_grid_over_a_disc_is_every_lattice_point_within_the_radius_boundary_included() {
    // Radius 20 G about (0.5, 8 G), across the x axis: the lattice starts at the box corner,
    // so its points are the centre plus (i, j) G, and 12 of them lie exactly on the circle
    // (i² + j² = 400).
    let centre = [0.5, 8.0 * G];
    let home = [0.0, 0.0, 0.125, 0.01, -0.02, 0.03];
    let mechanism = with_region(
        Region::Disc {
            centre,
            radius: 20.0 * G,
        },
        home,
    );
    let grid = map_grid(&mechanism, G, 1.0).unwrap();
    let expected = disc_lattice(20);
    let on_circle = expected
        .iter()
        .filter(|(i, j)| i * i + j * j == 400)
        .count();
    assert_eq!(on_circle, 12);
    assert_eq!(grid.len(), expected.len(), "the Gauss circle count N(20)");
    for (pose, (i, j)) in grid.iter().zip(&expected) {
        let x = centre[0] + *i as f64 * G;
        let y = centre[1] + *j as f64 * G;
        assert!(
            (pose[0] - x).abs() < 1e-15 && (pose[1] - y).abs() < 1e-15,
            "({i}, {j}): {pose:?}"
        );
        assert_eq!(&pose[2..], &home[2..], "other coordinates at home");
    }
}

/// Does the point `p` lie strictly left of (positive), on, or right of (negative) the line
/// from `a` to `b`? Returns the signed distance to that line.
fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
    (ex * (p[1] - a[1]) - ey * (p[0] - a[0])) / ex.hypot(ey)
}

#[test]
fn the_scaled_grid_is_the_lattice_inside_the_region_shrunk_about_its_box_centre() {
    // A scalene triangle away from the origin (no symmetry about its box centre in x or y),
    // shrunk to half about the centre of its bounding box: the map keeps the lattice points
    // (from the box's lower-left corner) inside the homothetic image, computed here forwards.
    let vertices = [[0.2113, 0.4327], [0.7391, 0.5519], [0.3537, 0.9071]];
    let grid_m: f64 = 0.0173;
    let scale = 0.5;
    let mechanism = with_region(
        Region::Polygon {
            vertices: vertices.to_vec(),
        },
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    let lo: [f64; 2] = [0.2113, 0.4327];
    let hi = [0.7391, 0.9071];
    let centre = [(0.2113 + 0.7391) / 2.0, (0.4327 + 0.9071) / 2.0];
    let image: Vec<[f64; 2]> = vertices
        .iter()
        .map(|v| {
            [
                centre[0] + scale * (v[0] - centre[0]),
                centre[1] + scale * (v[1] - centre[1]),
            ]
        })
        .collect();
    let steps = [
        ((hi[0] - lo[0]) / grid_m).floor() as usize,
        ((hi[1] - lo[1]) / grid_m).floor() as usize,
    ];
    let mut expected = Vec::new();
    for j in 0..=steps[1] {
        for i in 0..=steps[0] {
            let p = [lo[0] + i as f64 * grid_m, lo[1] + j as f64 * grid_m];
            let sides: Vec<f64> = (0..3)
                .map(|k| side(image[k], image[(k + 1) % 3], p))
                .collect();
            assert!(
                sides.iter().all(|s| s.abs() > 1e-6),
                "no lattice point near an edge, so round-off cannot decide: {p:?}"
            );
            if sides.iter().all(|&s| s > 0.0) {
                expected.push(p);
            }
        }
    }
    assert!(expected.len() >= 20, "{} points", expected.len());
    let grid = map_grid(&mechanism, grid_m, scale).unwrap();
    let reached: Vec<[f64; 2]> = grid.iter().map(|p| [p[0], p[1]]).collect();
    assert_eq!(
        reached.len(),
        expected.len(),
        "{reached:?} against {expected:?}"
    );
    for (a, b) in reached.iter().zip(&expected) {
        assert!(
            (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12,
            "{a:?} against {b:?}"
        );
    }
}

#[test]
fn a_grid_spacing_that_is_not_a_positive_number_is_refused_as_such() {
    let mechanism = bundled("5r.yaml");
    for grid in [0.0, -0.0, -0.01, f64::INFINITY, f64::NAN] {
        let message = map_grid(&mechanism, grid, 0.95).unwrap_err().to_string();
        assert!(
            message.contains(&format!(
                "--map: expected a positive grid spacing in metres, found {grid}"
            )),
            "{grid}: {message}"
        );
    }
}

#[test]
fn the_scale_may_be_one_and_not_one_ulp_more() {
    // Scale 1 gives the whole region's lattice (counted in
    // `accuracy_map::the_grid_covers_the_scaled_region_only`); one ulp more is refused.
    let mechanism = bundled("5r.yaml");
    assert!(!map_grid(&mechanism, 0.05, 1.0).unwrap().is_empty());
    let above = 1.0f64.next_up();
    let message = map_grid(&mechanism, 0.05, above).unwrap_err().to_string();
    assert!(
        message.contains("--map-scale: expected a fraction of the workspace region in (0, 1]"),
        "{message}"
    );
}

/// A ball of radius 1414 [`G`] about the origin whose top the map's plane (the home height)
/// cuts in a disc of radius √2.5 G: the nine lattice points `(i, j) G`, `|i|, |j| ≤ 1`, at
/// any scale within 0.1 % of one, while the lattice over its bounding box has 2829 × 2829
/// points, just over 4 × [`MAX_MAP_POINTS`]. Returns the mechanism and the home height.
fn thin_slice_of_a_ball() -> (Mechanism, f64) {
    let radius = 1414.0 * G;
    let z = (radius * radius - 2.5 * G * G).sqrt();
    let mechanism = with_region(
        Region::Ball {
            centre: [0.0, 0.0, 0.0],
            radius,
        },
        [0.0, 0.0, z, 0.0, 0.0, 0.0],
    );
    (mechanism, z)
}

#[test]
fn a_lattice_over_four_times_the_limit_is_refused_before_it_is_walked() {
    // (2829 · 2829) · 0.9998² = 8 000 039.9 > 4 · 2 000 000: refused from the lattice size
    // alone, though the region's slice holds nine points. (2828 · 2829) · 0.9998² is below.
    let (mechanism, _) = thin_slice_of_a_ball();
    let message = map_grid(&mechanism, G, 0.9998).unwrap_err().to_string();
    assert!(
        message.contains(&format!(
            "--map: a spacing of {G} m makes a lattice of 8000040 points over the region's \
             bounding box (scaled), more than 4 × {MAX_MAP_POINTS} to walk; choose a coarser grid"
        )),
        "{message}"
    );
}

#[test]
fn a_lattice_of_exactly_four_times_the_limit_is_walked() {
    // This scale makes (2829 · 2829) · s · s exactly 8 000 000 in floating point (checked
    // here, in the order the grid computes it): not more than 4 · MAX_MAP_POINTS, so the
    // lattice is walked and the nine points of the slice come back.
    let scale: f64 = 0.999_797_499_026_578_3;
    let lattice = 2829.0 * 2829.0 * scale * scale;
    assert_eq!(lattice.to_bits(), (4.0 * MAX_MAP_POINTS as f64).to_bits());
    let (mechanism, z) = thin_slice_of_a_ball();
    let grid = map_grid(&mechanism, G, scale).unwrap();
    let expected: Vec<[f64; 6]> = (-1..=1)
        .flat_map(|j| (-1..=1).map(move |i| [i as f64 * G, j as f64 * G, z, 0.0, 0.0, 0.0]))
        .collect();
    assert_eq!(grid.len(), 9, "{grid:?}");
    for (pose, want) in grid.iter().zip(&expected) {
        for (a, b) in pose.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{pose:?} against {want:?}");
        }
    }
}

#[test]
fn a_grid_of_exactly_the_limit_is_accepted_and_one_point_more_is_refused() {
    // Boxes of 2000 × 1000 and 3 × 666 667 lattice points, every one inside (the box's edges
    // are lattice lines): 2 000 000 and 2 000 001 points.
    let at_limit = with_region(
        Region::Box {
            min: [0.0, 0.0],
            max: [1999.0 * G, 999.0 * G],
        },
        [0.0; 6],
    );
    let grid = map_grid(&at_limit, G, 1.0).unwrap();
    assert_eq!(grid.len(), MAX_MAP_POINTS);
    let last = grid[MAX_MAP_POINTS - 1];
    assert!((last[0] - 1999.0 * G).abs() < 1e-15 && (last[1] - 999.0 * G).abs() < 1e-15);
    drop(grid);
    let over = with_region(
        Region::Box {
            min: [0.0, 0.0],
            max: [2.0 * G, 666_666.0 * G],
        },
        [0.0; 6],
    );
    let message = map_grid(&over, G, 1.0).unwrap_err().to_string();
    assert!(
        message.contains(&format!("gives more than {MAX_MAP_POINTS} points")),
        "{message}"
    );
}

/// The difference `a − b` of two angles, wrapped to (−π, π].
fn angle_difference(a: f64, b: f64) -> f64 {
    let d = a - b;
    d.sin().atan2(d.cos())
}

/// Checks a map's joints against the closed-form 5R inverse kinematics (elbows out): at every
/// target where `five_bar_ik` of `phi` gives readings, each leg's slot `i · 2 + l` holds the
/// joints whose actuated angle θ gives that reading, `(θ − γ)/k`.
fn assert_closed_form_joints(
    mechanism: &Mechanism,
    phi: &[Vec<f64>],
    targets: &[[f64; 6]],
    joints: &[Option<[f64; 3]>],
) {
    assert_eq!(
        joints.len(),
        2 * targets.len(),
        "one slot per target and leg"
    );
    for (i, target) in targets.iter().enumerate() {
        let Some(readings) = five_bar_ik(phi, target[0], target[1]) else {
            continue;
        };
        for (l, leg) in mechanism.legs.iter().enumerate() {
            let q = joints[2 * i + l].unwrap_or_else(|| panic!("target {i} leg {l}: no joints"));
            let (k, gamma) = (phi[l][4], phi[l][5]);
            let theta = k * readings[l] + gamma;
            let d = angle_difference(q[leg.actuated], theta);
            assert!(
                d.abs() < 1e-9,
                "target {i} leg {l}: {q:?} against θ = {theta}"
            );
        }
    }
}

#[test]
fn a_map_leaves_each_targets_joints_in_its_own_slot_and_none_where_a_leg_fails() {
    let mechanism = bundled("5r.yaml");
    let phi = mechanism.nominal_parameters();
    let kinematics = ForwardKinematics::new(&mechanism, &phi);
    let at = |x: f64, y: f64| {
        let mut pose = mechanism.home_pose;
        pose[0] = x;
        pose[1] = y;
        pose
    };
    // Three reachable targets, one that only leg 1 (base at x = −0.5 m) reaches, one more
    // reachable, one that leg 1 cannot reach (so leg 2 is not tried).
    let targets = [
        at(0.0, 1.0956521739),
        at(0.05, 1.0956521739),
        at(0.1, 1.0956521739),
        at(-1.5, 0.6),
        at(0.0, 1.2),
        at(1.5, 0.6),
    ];
    let reach = |l: usize, t: &[f64; 6]| {
        let d = (t[0] - phi[l][2]).hypot(t[1] - phi[l][3]);
        d >= phi[l][1] - phi[l][0] && d <= phi[l][0] + phi[l][1]
    };
    assert!(reach(0, &targets[3]) && !reach(1, &targets[3]));
    assert!(!reach(0, &targets[5]));
    let mut joints = Vec::new();
    let reached = reached_poses_from(&mechanism, &phi, &kinematics, &targets, &mut joints);
    // The model commands its own mechanism: every reachable target is reached exactly.
    for (i, (target, pose)) in targets.iter().zip(&reached).enumerate() {
        match five_bar_ik(&phi, target[0], target[1]) {
            Some(_) => {
                let pose = pose.unwrap_or_else(|| panic!("target {i} not reached"));
                assert!(
                    (pose[0] - target[0]).hypot(pose[1] - target[1]) < 1e-9,
                    "{i}"
                );
            }
            None => assert_eq!(*pose, None, "target {i}"),
        }
    }
    assert_closed_form_joints(&mechanism, &phi, &targets, &joints);
    let filled: Vec<bool> = joints.iter().map(Option::is_some).collect();
    let expected = [
        true, true, true, true, true, true, true, false, true, true, false, false,
    ];
    assert_eq!(filled, expected);
    // A single target, with a mis-sized vector from elsewhere: replaced, then filled.
    let mut joints = vec![Some([9.0; 3]); 5];
    let reached = reached_poses_from(&mechanism, &phi, &kinematics, &targets[4..5], &mut joints);
    let pose = reached[0].expect("reached");
    assert!((pose[0] - 0.0).hypot(pose[1] - 1.2) < 1e-9);
    assert_closed_form_joints(&mechanism, &phi, &targets[4..5], &joints);
}

/// The 5R's readings at its home pose, from the closed form.
fn home_readings(mechanism: &Mechanism) -> [f64; 2] {
    let home = mechanism.home_pose;
    five_bar_ik(&mechanism.nominal_parameters(), home[0], home[1]).expect("home is reachable")
}

#[test]
fn measurements_not_read_from_a_file_are_reported_at_the_lines_a_written_file_would_have() {
    // Row i would be line i + 2 of a written file (after the header).
    let mechanism = bundled("5r.yaml");
    let [r1, r2] = home_readings(&mechanism);
    let home = mechanism.home_pose;
    let mut far = home;
    far[0] = 3.0;
    let pose = |leg: Option<usize>, pose: [f64; 6]| MeasuredPose {
        line: None,
        leg,
        pose,
    };
    let data = MeasurementSet::from_rows(
        None,
        2,
        [
            (pose(Some(0), home), vec![Some(r1 + 0.01), None]),
            (pose(None, home), vec![Some(r1), Some(r2)]),
            (pose(None, home), vec![Some(r1), Some(r2)]),
            (pose(Some(0), far), vec![Some(0.0), None]),
        ],
    );
    let evaluation = evaluate(&mechanism, &data).unwrap();
    assert_eq!(evaluation.rows, 4);
    assert_eq!(evaluation.measurements, "simulated");
    let lines: Vec<usize> = evaluation.row_errors.iter().map(|r| r.line).collect();
    assert_eq!(lines, [3, 4], "the full rows, indices 1 and 2");
    for row in &evaluation.row_errors {
        assert!(row.position_error.unwrap() < 1e-9, "{row:?}");
    }
    let [leg1, leg2] = &evaluation.reading_residual[..] else {
        panic!("one residual summary per leg")
    };
    assert_eq!((leg1.rows, &leg1.unreachable[..]), (3, &[5][..]));
    assert_eq!((leg2.rows, &leg2.unreachable[..]), (2, &[][..]));
    // Leg 1's residuals: 0.01 (line 2) and two zeros.
    assert!((leg1.max.unwrap() - 0.01).abs() < 1e-9);
    assert!((leg1.rms.unwrap() - 0.01 / 3f64.sqrt()).abs() < 1e-9);
}

#[test]
fn instrument_rows_not_read_from_a_file_are_reported_at_the_lines_a_written_file_would_have() {
    let mechanism = bundled("5r-tracker.yaml");
    let [r1, r2] = home_readings(&mechanism);
    let row = |leg: Option<usize>, readings: Vec<Option<f64>>| ObservedRow {
        line: None,
        leg,
        observed: vec![0.0, 1.0],
        readings,
        id: None,
        pose: None,
    };
    let data = Observations {
        source: None,
        rows: vec![
            row(Some(0), vec![Some(r1), None]),
            row(None, vec![Some(r1), Some(r2)]),
            row(Some(1), vec![None, Some(r2)]),
            row(None, vec![Some(r1), Some(r2)]),
        ],
        distances: Vec::new(),
    };
    let evaluation = evaluate_observed(&mechanism, &data).unwrap();
    assert_eq!(evaluation.rows, 4);
    let lines: Vec<(usize, Option<usize>)> = evaluation
        .row_errors
        .iter()
        .map(|r| (r.line, r.target))
        .collect();
    assert_eq!(
        lines,
        [(3, Some(0)), (5, Some(0))],
        "the full rows, indices 1 and 3"
    );
}
