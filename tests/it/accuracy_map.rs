//! The accuracy map (the paper's Fig. 4): a model's IK commands each grid pose, the real
//! mechanism moves by forward kinematics. Checked against a closed-form 5R solution, the
//! reference figures of the 5R with the Table 2 real values, and on the 3-RPR with orientation.
use legwise::evaluate::accuracy::{accuracy_map, map_grid, result_parameters, ErrorStats};
use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::simulate::{real_parameters, simulate, SimulationOptions};
use legwise::solver::SolverKind;

use crate::support::bundled;

/// Table 2 real parameters of the 5R, per leg `[l, L, Ax, Ay, k, gamma]`.
fn five_bar_real() -> Vec<Vec<f64>> {
    let mechanism = bundled("5r.yaml");
    real_parameters(&mechanism, mechanism.simulation.as_ref().unwrap(), 0)
}

/// Closed-form 5R inverse kinematics, elbows out: the readings for the target (x, y).
pub(crate) fn five_bar_ik(phi: &[Vec<f64>], x: f64, y: f64) -> Option<[f64; 2]> {
    let mut readings = [0.0; 2];
    for (leg, sign) in [(0, 1.0), (1, -1.0)] {
        let [l, big_l, ax, ay, k, gamma] = phi[leg][..] else {
            unreachable!()
        };
        let (dx, dy) = (x - ax, y - ay);
        let d = dx.hypot(dy);
        let cosine = (l * l + d * d - big_l * big_l) / (2.0 * l * d);
        if cosine.abs() > 1.0 {
            return None;
        }
        // Leg 1's elbow to the left of A1->P, leg 2's to the right.
        let theta = dy.atan2(dx) + sign * cosine.acos();
        readings[leg] = (theta - gamma) / k;
    }
    Some(readings)
}

/// Closed-form 5R forward kinematics, assembly mode up (P to the left of B1->B2); `None` when
/// the distal links cannot meet.
pub(crate) fn five_bar_fk(phi: &[Vec<f64>], readings: [f64; 2]) -> Option<[f64; 2]> {
    let elbow = |leg: usize| {
        let [l, _, ax, ay, k, gamma] = phi[leg][..] else {
            unreachable!()
        };
        let theta = k * readings[leg] + gamma;
        [ax + l * theta.cos(), ay + l * theta.sin()]
    };
    let (b1, b2) = (elbow(0), elbow(1));
    let (r1, r2) = (phi[0][1], phi[1][1]);
    let (ux, uy) = (b2[0] - b1[0], b2[1] - b1[1]);
    let d = ux.hypot(uy);
    let along = (d * d + r1 * r1 - r2 * r2) / (2.0 * d);
    let h2 = r1 * r1 - along * along;
    if h2 < 0.0 {
        return None;
    }
    let h = h2.sqrt();
    let (ex, ey) = (ux / d, uy / d);
    Some([b1[0] + along * ex - h * ey, b1[1] + along * ey + h * ex])
}

#[test]
fn five_bar_map_agrees_with_the_closed_form_point_by_point() {
    let mechanism = bundled("5r.yaml");
    let real = five_bar_real();
    let nominal = mechanism.nominal_parameters();
    let map = accuracy_map(&mechanism, &nominal, &real, 0.02, 0.95, "test").unwrap();
    let mut non_assemblable = 0;
    for point in &map.points {
        let [x, y, ..] = point.pose;
        let reached = five_bar_ik(&nominal, x, y).and_then(|r| five_bar_fk(&real, r));
        match (reached, point.position_error) {
            (Some(p), Some(error)) => {
                let expected = (p[0] - x).hypot(p[1] - y);
                assert!(
                    (error - expected).abs() < 1e-9,
                    "({x}, {y}): {error} vs closed form {expected}"
                );
            }
            (None, None) => non_assemblable += 1,
            (reached, error) => panic!("({x}, {y}): closed form {reached:?}, map {error:?}"),
        }
        assert_eq!(
            point.orientation_error, None,
            "the 5R measures no orientation"
        );
    }
    assert!(
        non_assemblable > 0,
        "the 0.95 map touches the unassemblable bottom"
    );
    assert_eq!(map.non_assemblable, non_assemblable);
    assert!(map.orientation_error.is_none());
}

#[test]
fn five_bar_before_map_reproduces_the_reference_figures() {
    // 1 cm grid over 0.95 of the MIW disc, nominal model commanding the Table 2 robot.
    let mechanism = bundled("5r.yaml");
    let map = accuracy_map(
        &mechanism,
        &mechanism.nominal_parameters(),
        &five_bar_real(),
        0.01,
        0.95,
        "test",
    )
    .unwrap();
    assert_eq!(map.points.len(), 11_810);
    assert_eq!(map.non_assemblable, 174);
    let p = map.position_error;
    assert!((p.rms - 13.8e-3).abs() < 0.1e-3, "RMS {} m", p.rms);
    assert!((p.median - 9.5e-3).abs() < 0.1e-3, "median {} m", p.median);
    assert!((p.max - 96e-3).abs() < 1e-3, "max {} m", p.max);
}

#[test]
fn five_bar_after_maps_are_a_few_tenths_of_a_millimetre_for_both_strategies() {
    let mechanism = bundled("5r.yaml");
    let experiment = simulate(&mechanism, SimulationOptions::default()).unwrap();
    for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
        let result = identify(
            &mechanism,
            &experiment.measurements,
            strategy,
            SolverKind::LevenbergMarquardt,
        )
        .unwrap();
        let identified = result_parameters(&mechanism, &result);
        let map = accuracy_map(&mechanism, &identified, &experiment.real, 0.02, 0.95, "t").unwrap();
        assert_eq!(map.non_assemblable, 0, "{strategy:?}");
        let rms = map.position_error.rms;
        assert!(rms > 1e-5 && rms < 0.5e-3, "{strategy:?}: RMS {rms} m");
    }
}

#[test]
fn three_rpr_map_measures_orientation_and_vanishes_with_the_real_model() {
    let mechanism = bundled("3rpr.yaml");
    let real = real_parameters(&mechanism, mechanism.simulation.as_ref().unwrap(), 7);
    let before = accuracy_map(
        &mechanism,
        &mechanism.nominal_parameters(),
        &real,
        0.04,
        0.95,
        "t",
    )
    .unwrap();
    assert!(before.points.len() > 50);
    let orientation = before.orientation_error.expect("the 3-RPR measures yaw");
    assert!(orientation.rms > 1e-4, "{orientation:?}");
    assert!(before.position_error.rms > 1e-4);
    for point in &before.points {
        assert!(
            point.pose[5].abs() < 1e-300,
            "a constant-orientation map at the home yaw"
        );
        assert_eq!(
            point.position_error.is_some(),
            point.orientation_error.is_some()
        );
    }
    // Commanded by the real model itself, the real mechanism reaches every target exactly.
    let exact = accuracy_map(&mechanism, &real, &real, 0.04, 0.95, "t").unwrap();
    assert_eq!(exact.non_assemblable, 0);
    assert!(
        exact.position_error.max < 1e-9,
        "{:?}",
        exact.position_error
    );
    assert!(exact.orientation_error.unwrap().max < 1e-9);
}

#[test]
fn the_grid_covers_the_scaled_region_only() {
    let mechanism = bundled("5r.yaml");
    let (centre, radius) = ([0.0, 1.0956521739], 0.6456521739);
    for scale in [0.5, 0.95, 1.0] {
        let grid = map_grid(&mechanism, 0.05, scale).unwrap();
        for pose in &grid {
            let distance = (pose[0] - centre[0]).hypot(pose[1] - centre[1]);
            assert!(distance <= scale * radius + 1e-12);
        }
        // Lattice points in the disc, counted directly (the lattice starts at the box corner).
        let steps = (2.0 * radius / 0.05f64).floor() as i64;
        let expected = (0..=steps)
            .flat_map(|j| (0..=steps).map(move |i| (i, j)))
            .filter(|&(i, j)| {
                let x = centre[0] - radius + i as f64 * 0.05;
                let y = centre[1] - radius + j as f64 * 0.05;
                (x - centre[0]).hypot(y - centre[1]) <= scale * radius + 1e-12
            })
            .count();
        assert_eq!(grid.len(), expected, "scale {scale}");
    }
}

#[test]
fn bad_map_settings_are_refused_with_the_flag_named() {
    let mechanism = bundled("5r.yaml");
    for (grid, scale, flag) in [
        (0.0, 0.95, "--map:"),
        (f64::NAN, 0.95, "--map:"),
        (0.01, 0.0, "--map-scale:"),
        (0.01, 1.5, "--map-scale:"),
        (1e-5, 0.95, "coarser grid"),
    ] {
        let message = map_grid(&mechanism, grid, scale).unwrap_err().to_string();
        assert!(message.contains(flag), "{grid} {scale}: {message}");
    }
}

#[test]
fn error_statistics_of_a_known_set() {
    let stats = ErrorStats::of(&[4.0, 1.0, 3.0, 2.0]).unwrap();
    assert!((stats.rms - 7.5f64.sqrt()).abs() < 1e-15);
    assert!((stats.median - 2.5).abs() < 1e-15);
    // 95th percentile: position 0.95 * 3 = 2.85 between the sorted values 3 and 4.
    assert!((stats.p95 - 3.85).abs() < 1e-15);
    assert!((stats.max - 4.0).abs() < 1e-15);
    assert!(ErrorStats::of(&[]).is_none());
    assert!(ErrorStats::of(&[1.0, f64::NAN]).is_none());
}

#[test]
fn a_map_from_a_measurement_file_is_refused_before_any_work() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_legwise"))
        .args(["identify", "--model", "models/5r.yaml"])
        .args(["--measurements", "tests/data/valid.csv", "--map", "0.01"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty(), "refused before identifying");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--map: the accuracy map needs the real parameters"),
        "{stderr}"
    );
}

/// The prepared, warm-started map ([`reached_poses`]) gives the poses of the point-by-point
/// [`reached_pose`] (forward kinematics from home with continuation) to round-off, on every
/// bundled model whose grid the real mechanism reaches, for the nominal model commanding.
#[test]
fn warm_started_map_poses_equal_the_point_by_point_ones() {
    use legwise::evaluate::accuracy::{reached_pose, reached_poses};
    use legwise::kinematics::platform::ForwardKinematics;
    for name in ["5r.yaml", "3rpr.yaml", "delta.yaml", "hexapod.yaml"] {
        let mechanism = bundled(name);
        let simulation = mechanism.simulation.as_ref().unwrap();
        let real = real_parameters(&mechanism, simulation, simulation.seed);
        let nominal = mechanism.nominal_parameters();
        let grid = map_grid(
            &mechanism,
            0.1 * mechanism.workspace.region.bounds().1[0].abs().max(0.05),
            0.95,
        )
        .unwrap();
        let kinematics = ForwardKinematics::new(&mechanism, &real);
        let warm = reached_poses(&mechanism, &nominal, &kinematics, &grid);
        let mut reached = 0;
        for (target, warm) in grid.iter().zip(&warm) {
            let cold = reached_pose(&mechanism, &nominal, &real, target);
            match (cold, warm) {
                (Some(cold), Some(warm)) => {
                    reached += 1;
                    for (a, b) in cold.iter().zip(warm) {
                        assert!(
                            (a - b).abs() < 1e-12,
                            "{name} at {target:?}: {cold:?} against {warm:?}"
                        );
                    }
                }
                (None, None) => {}
                _ => panic!("{name} at {target:?}: {cold:?} against {warm:?}"),
            }
        }
        assert!(
            reached * 10 >= grid.len() * 9 && grid.len() >= 20,
            "{name}: {reached} of {}",
            grid.len()
        );
    }
}
