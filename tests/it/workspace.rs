//! The usable workspace: the MIW of the bundled 5R (docs/method.md §8, §9).
use legwise::workspace::miw::{maximal_inscribed_workspace, MiwOptions};

use crate::support::bundled;

#[test]
fn the_5r_maximal_inscribed_workspace_matches_the_closed_form() {
    let mech = bundled("5r.yaml");
    let options = MiwOptions {
        rays: 360,
        ..MiwOptions::for_mechanism(&mech)
    };
    let miw = maximal_inscribed_workspace(&mech, options).unwrap();
    assert!(miw.centre[0].abs() < 1e-4, "centre {:?}", miw.centre);
    assert!(
        (miw.centre[1] - 1.0956522).abs() < 1e-4,
        "centre {:?}",
        miw.centre
    );
    assert!(
        (miw.radius - 0.6456522).abs() < 1e-4,
        "radius {}",
        miw.radius
    );
}

#[test]
fn the_5r_candidate_pool_is_the_grid_inside_the_usable_disc() {
    use legwise::selection::candidates::candidate_pool;
    let mech = bundled("5r.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // The lattice from the usable disc's lower-left corner, counted independently.
    let (centre, radius) = ([0.0, 1.0956521739], 0.95 * 0.6456521739);
    let lattice = (0..=61)
        .flat_map(|i| (0..=61).map(move |j| (i, j)))
        .filter(|&(i, j)| {
            let x = -radius + 0.02 * i as f64 - centre[0];
            let y = centre[1] - radius + 0.02 * j as f64 - centre[1];
            x * x + y * y <= radius * radius - 1e-12
        })
        .count();
    assert_eq!(pool.inside, lattice);
    // docs/method.md §9: about 2950 (3268 at f = 1, which this alignment reproduces exactly).
    assert!(
        pool.inside.abs_diff(2953) <= 1,
        "{} grid points",
        pool.inside
    );
    assert_eq!(
        pool.candidates.len() + pool.unreachable + pool.near_serial + pool.near_parallel,
        pool.inside
    );
    assert_eq!(
        pool.candidates.len(),
        pool.inside,
        "every point of the usable disc is feasible"
    );
    // The usable disc's closest approach to the type-II singularity is its bottom point, where
    // docs/method.md §9 gives min |s_II| = 0.058; no candidate is closer.
    use legwise::kinematics::singularity::ParallelMeasure;
    let nominal = mech.nominal_parameters();
    let measure = ParallelMeasure::new(&mech, nominal).unwrap();
    let bottom = measure
        .at(&[0.0, centre[1] - radius, 0.0, 0.0, 0.0, 0.0])
        .unwrap();
    assert!(
        (bottom - 0.058).abs() < 1e-3,
        "s_II at the bottom point {bottom}"
    );
    let smallest = pool
        .candidates
        .iter()
        .filter_map(|c| c.parallel)
        .fold(f64::INFINITY, f64::min);
    assert!(
        smallest >= bottom,
        "min parallel measure over the pool {smallest}"
    );
}

#[test]
fn the_3rpr_candidate_pool_varies_the_orientation() {
    use legwise::selection::candidates::candidate_pool;
    let mech = bundled("3rpr.yaml");
    let pool = candidate_pool(&mech, None).unwrap();
    // docs/method.md §10: a 0.05 m grid in the 0.2 m disc (49 points) × 9 orientations.
    assert_eq!(pool.inside, 441);
    assert_eq!(
        pool.candidates.len(),
        441,
        "the disc is type-II-free for |yaw| <= 30 deg"
    );
    let yaws: std::collections::BTreeSet<i64> = pool
        .candidates
        .iter()
        .map(|c| (c.pose[5] * 1e6).round() as i64)
        .collect();
    assert_eq!(yaws.len(), 9);
}

/// The 5R's serial singular curves are circles about the base joints A1 = (−0.5, 0) and
/// A2 = (0.5, 0): radius l + L = 1.85 m (a leg stretched) and L − l = 0.35 m (folded). Every
/// traced point lies on one of them to far better than the grid spacing (no staircase).
#[test]
fn the_5r_serial_curves_are_the_reach_circles_not_a_staircase() {
    use legwise::workspace::miw::SingularityMargin;
    use legwise::workspace::singular::singular_curves;
    let mech = bundled("5r.yaml");
    let margin = SingularityMargin::new(&mech).unwrap();
    let (lo, hi) = ([-2.0, -1.2], [2.0, 2.8]);
    let cells = 50;
    let curves = singular_curves(&margin, (lo, hi), [0.0, 1.0956522], cells);
    let (serial, parallel) = (curves.serial, curves.parallel);
    let spacing = 4.0 / cells as f64;
    let mut points = 0;
    let mut worst: f64 = 0.0;
    for p in serial.iter().flatten() {
        let off = [-0.5, 0.5]
            .iter()
            .flat_map(|ax| {
                let r = ((p[0] - ax).powi(2) + p[1].powi(2)).sqrt();
                [(r - 1.85).abs(), (r - 0.35).abs()]
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(off);
        points += 1;
    }
    assert!(points > 60, "{points} points");
    assert!(
        worst < 1e-3 * spacing,
        "farthest point {worst} m off the reach circles (grid {spacing} m)"
    );
    assert!(!parallel.is_empty());
}

/// `legwise workspace --poses FILE --out PICTURE.png`: a PNG by the extension, the pose file's
/// rows drawn per leg (the `select` layout, readings empty), and the SVG variant names them.
#[test]
fn workspace_draws_a_pose_file_on_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.csv");
    std::fs::write(
        &poses,
        "leg,x,y,A1,A2\nleg1,0.1,1.0,,\nleg1,-0.2,1.2,,\nleg2,0.3,0.9,,\n,0.0,1.1,,\n",
    )
    .unwrap();
    let run = |out: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_legwise"))
            .args([
                "workspace",
                "--model",
                "models/5r.yaml",
                "--rays",
                "16",
                "--poses",
            ])
            .arg(&poses)
            .arg("--out")
            .arg(out)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let svg_path = dir.path().join("ws.svg");
    let out = run(&svg_path);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    for wanted in [
        "x (m)",
        "y (m)",
        "leg1 poses of poses.csv (2)",
        "leg2 poses of poses.csv (1)",
        "shared poses of poses.csv (1)",
        "parallel (type II) singularity: the platform gains a freedom",
    ] {
        assert!(svg.contains(wanted), "`{wanted}` missing");
    }
    let png_path = dir.path().join("ws.png");
    let out = run(&png_path);
    assert_eq!(out.status.code(), Some(0));
    assert!(std::fs::read(&png_path).unwrap().starts_with(b"\x89PNG"));
    // The pose file is an input: never overwritten by the picture.
    let out = run(&poses);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("ending in .svg or .png"), "{stderr}");
}
