//! The 3-D MIW of the spatial models: its ball lies in the singularity-free region (points on
//! its surface, in directions the computation did not use, checked with the legs' inverse
//! kinematics and the parallel measure directly), it is tight (just past the nearest crossing
//! a point is outside), and `legwise workspace` draws its picture.
use legwise::kinematics::inverse::solve_leg;
use legwise::kinematics::singularity::ParallelMeasure;
use legwise::model::Mechanism;
use legwise::workspace::miw::SingularityMargin;
use legwise::workspace::miw3d::{slice, spatial_inscribed_workspace, Miw3dOptions};
use legwise::workspace::singular::singular_curves;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cli::{legwise, text};
use crate::spatial::MODELS;
use crate::support::{bundled, svg_texts};

/// The actuated joints' strokes declared in the URDFs (the delta's carriage heights, the
/// hexapod's leg lengths, metres).
fn stroke(file: &str) -> [f64; 2] {
    if file == "delta.yaml" {
        [0.0, 1.0]
    } else {
        [0.5, 0.9]
    }
}

/// The actuated joint of every leg at `pose` from the closed forms (nominal geometry): the
/// delta's carriage height `h = k·s + h0`, the hexapod's leg length `ρ = k·s + rho0`.
fn actuated_joints(file: &str, mechanism: &Mechanism, pose: &[f64; 6]) -> Vec<f64> {
    let model = MODELS.iter().find(|m| m.file == file).unwrap();
    mechanism
        .legs
        .iter()
        .map(|leg| {
            let phi = leg.nominal();
            let (gain, offset) = if file == "delta.yaml" {
                (phi[3], phi[4])
            } else {
                (phi[6], phi[7])
            };
            gain * (model.reading)(&phi, pose) + offset
        })
        .collect()
}

/// Inside the singularity-free region of the home modes at point `p` (home orientation): every
/// leg reaches on its home branch with its serial determinant of the home sign and its actuated
/// joint within its stroke (from the closed forms), and the parallel measure is positive.
fn inside(file: &str, mechanism: &Mechanism, p: [f64; 3]) -> bool {
    let mut pose = mechanism.home_pose;
    pose[..3].copy_from_slice(&p);
    let [lower, upper] = stroke(file);
    if actuated_joints(file, mechanism, &pose)
        .iter()
        .any(|q| !(lower..=upper).contains(q))
    {
        return false;
    }
    let params = mechanism.nominal_parameters();
    let serial_ok = mechanism.legs.iter().zip(&params).all(|(leg, phi)| {
        solve_leg(leg, &leg.geometry(phi), &pose, &mechanism.home_pose)
            .is_ok_and(|s| s.normalised_determinant * leg.branch_sign > 0.0)
    });
    serial_ok
        && ParallelMeasure::new(mechanism, params)
            .and_then(|m| m.at(&pose))
            .is_ok_and(|v| v > 0.0)
}

#[test]
fn the_3d_miw_ball_lies_in_the_singularity_free_region_and_is_tight() {
    for (file, rays) in [("delta.yaml", 300), ("hexapod.yaml", 100)] {
        let mechanism = bundled(file);
        let options = Miw3dOptions {
            rays,
            ..Miw3dOptions::for_mechanism(&mechanism)
        };
        let miw = spatial_inscribed_workspace(&mechanism, options).unwrap();
        let c = miw.centre;
        let home = [0.0, 0.0, mechanism.home_pose[2]];
        assert!(
            (0..3).all(|k| (c[k] - home[k]).abs() < 1e-15),
            "{file}: centre {c:?}"
        );
        assert!(miw.radius > 0.0 && miw.radius.is_finite(), "{file}");
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        for _ in 0..200 {
            // A random direction (normalised Gaussian-free: rejection in the unit cube).
            let d = loop {
                let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
                let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                if n > 0.1 && n <= 1.0 {
                    break v.map(|x| x / n);
                }
            };
            let p = std::array::from_fn(|k| c[k] + miw.radius * d[k]);
            assert!(
                inside(file, &mechanism, p),
                "{file}: surface point {p:?} outside"
            );
        }
        // The nearest crossing, 2% farther out, is outside: the ball is not far too small.
        let nearest = miw
            .boundary
            .iter()
            .min_by(|a, b| {
                let da: f64 = (0..3).map(|k| (a[k] - c[k]).powi(2)).sum();
                let db: f64 = (0..3).map(|k| (b[k] - c[k]).powi(2)).sum();
                da.total_cmp(&db)
            })
            .unwrap();
        let beyond = std::array::from_fn(|k| c[k] + 1.02 * (nearest[k] - c[k]));
        assert!(
            !inside(file, &mechanism, beyond),
            "{file}: {beyond:?} inside"
        );
        let nearest_distance = (0..3)
            .map(|k| (nearest[k] - c[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            miw.radius <= nearest_distance && miw.radius >= 0.9 * nearest_distance,
            "{file}: radius {} vs nearest crossing {nearest_distance}",
            miw.radius
        );
    }
}

#[test]
fn workspace_on_the_spatial_models_draws_three_labelled_slices() {
    for (model, z) in [("delta", "0.05"), ("hexapod", "0.6")] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("w.svg");
        let path = format!("models/{model}.yaml");
        let run = legwise(&[
            "workspace",
            "--model",
            &path,
            "--rays",
            "200",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stdout = text(&run.stdout);
        assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
        assert!(stdout.contains("3-D MIW"), "{stdout}");
        assert!(
            stdout.contains("picture: the slices z = ")
                && stdout.contains("(x-y), y = 0.0000000 m (x-z) and x = 0.0000000 m (y-z)"),
            "{stdout}"
        );
        let texts = svg_texts(&std::fs::read_to_string(&out).unwrap());
        let count = |wanted: &str| texts.iter().filter(|t| *t == wanted).count();
        // Three panels: x–y, x–z, y–z, each axis in metres, each captioned by its cut.
        assert_eq!(count("x (m)"), 2, "{texts:?}");
        assert_eq!(count("y (m)"), 2, "{texts:?}");
        assert_eq!(count("z (m)"), 2, "{texts:?}");
        for caption in [
            format!("slice z = {z} m"),
            "slice y = 0 m".into(),
            "slice x = 0 m".into(),
        ] {
            assert_eq!(count(&caption), 1, "{caption}: {texts:?}");
        }
        // The serial curves are drawn (the delta's rods horizontal, both models' strokes), and
        // named with the joint limits; the ball's cross-section is named with its radius.
        let radius: f64 = stdout
            .lines()
            .find_map(|l| l.trim().strip_prefix("radius"))
            .and_then(|r| r.trim().strip_suffix(" m"))
            .and_then(|r| r.parse().ok())
            .unwrap_or_else(|| panic!("{stdout}"));
        let radius = format!("radius {radius:.4} m");
        assert!(texts
            .iter()
            .any(|t| t.starts_with("serial (type I) singularity or joint limit")));
        assert!(
            texts
                .iter()
                .any(|t| t.starts_with("3-D MIW: a ball about") && t.contains(&radius)),
            "{texts:?}"
        );
    }
}

#[test]
fn the_vertical_slices_end_where_the_region_does() {
    for file in ["delta.yaml", "hexapod.yaml"] {
        let mechanism = bundled(file);
        let options = Miw3dOptions::for_mechanism(&mechanism);
        let home = mechanism.home_pose;
        for axes in [[0, 1], [0, 2], [1, 2]] {
            let boundary = slice(&mechanism, options, axes, 24).unwrap();
            assert_eq!(boundary.len(), 24);
            for b in &boundary {
                let at = |t: f64| -> [f64; 3] {
                    let mut p = [home[0], home[1], home[2]];
                    p[axes[0]] += t * (b[0] - home[axes[0]]);
                    p[axes[1]] += t * (b[1] - home[axes[1]]);
                    p
                };
                assert!(
                    inside(file, &mechanism, at(0.995)),
                    "{file} {axes:?}: {b:?}"
                );
                assert!(
                    !inside(file, &mechanism, at(1.005)),
                    "{file} {axes:?}: {b:?}"
                );
            }
        }
    }
}

/// The hexapod's legs never meet a serial singularity in its slices: every point of the serial
/// curves of its x–z slice is where a leg length (from the closed form) reaches an end of its
/// 0.5–0.9 m stroke.
#[test]
fn the_hexapod_slice_curves_are_its_stroke_ends() {
    let mechanism = bundled("hexapod.yaml");
    let margin = SingularityMargin::new(&mechanism).unwrap().in_plane([0, 2]);
    let curves = singular_curves(&margin, ([-0.6, 0.3], [0.6, 0.9]), [0.0, 0.6], 40);
    let points: Vec<[f64; 2]> = curves.serial.iter().flatten().copied().collect();
    assert!(points.len() > 40, "{}", points.len());
    assert!(
        curves.parallel.is_empty(),
        "no parallel singularity in the slice"
    );
    for p in points {
        let pose = [p[0], 0.0, p[1], 0.0, 0.0, 0.0];
        let lengths = actuated_joints("hexapod.yaml", &mechanism, &pose);
        let off = lengths
            .iter()
            .map(|l| (l - 0.5).abs().min((l - 0.9).abs()))
            .fold(f64::INFINITY, f64::min);
        assert!(off < 1e-6, "{p:?}: legs {lengths:?}");
    }
}

/// The hexapod has no parallel-singularity curve in its slices: its legend's rows follow each
/// other (region, serial curves, MIW), without the empty row the missing entry left.
#[test]
fn the_legend_has_no_empty_row_for_a_curve_not_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("hexapod.svg");
    let result = crate::cli::legwise(&[
        "workspace",
        "--model",
        "models/hexapod.yaml",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(
        result.status.code(),
        Some(0),
        "{}",
        crate::cli::text(&result.stderr)
    );
    let svg = std::fs::read_to_string(&out).unwrap();
    let row = |start: &str| crate::support::svg_text_attribute(&svg, start, "y");
    let rows = [
        row("singularity-free region"),
        row("serial (type I)"),
        row("3-D MIW"),
    ];
    assert!(!svg.contains("parallel (type II)"));
    // One row pitch between each entry and the next: an empty row would double a gap.
    let pitch = rows[1] - rows[0];
    assert!(
        pitch > 0.0 && (rows[2] - rows[1] - pitch).abs() < 0.5,
        "{rows:?}"
    );
}

/// A bed probe's bed bounds the 3-D MIW: the nozzle (0.02 m under the platform) cannot go
/// through it. delta-probe.yaml's platform is at z = 0.05 at home, so the nozzle is 0.03 m above
/// the level bed, and the ball's radius is 0.03 m (the same mechanism without the probe,
/// delta.yaml, has 0.158 m, the singularity-free radius kept beside it). A bed tilted by roll
/// 0.2 rad is nearer along its normal: 0.03·cos(0.2) + 0 (the nozzle under the platform's
/// centre, the plane through the frame origin). `legwise workspace` prints both and draws the
/// bed in the vertical slices.
#[test]
fn a_bed_probe_bounds_the_ball_by_its_bed() {
    let options = |m: &Mechanism| Miw3dOptions::for_mechanism(m);
    let probe = bundled("delta-probe.yaml");
    let miw = spatial_inscribed_workspace(&probe, options(&probe)).unwrap();
    let plain = bundled("delta.yaml");
    let free = spatial_inscribed_workspace(&plain, options(&plain)).unwrap();
    assert!((miw.radius - 0.03).abs() < 1e-12, "{}", miw.radius);
    assert!((miw.singularity_free_radius - free.radius).abs() < 1e-15);
    assert!(free.surfaces.is_empty());
    assert!((free.radius - free.singularity_free_radius).abs() < 1e-15);
    // Tilted about x by 0.2 rad: the nozzle at (0, 0, 0.03) in the world is 0.03·cos(0.2)
    // above the plane through the origin with normal (0, −sin 0.2, cos 0.2).
    let dir = tempfile::tempdir().unwrap();
    let yaml = std::fs::read_to_string("models/delta-probe.yaml").unwrap();
    let urdf = std::fs::canonicalize("models/delta.urdf").unwrap();
    let tilted = yaml
        .replace(
            "pose: {x: 0.0, y: 0.0, z: 0.0, roll: 0.0, pitch: 0.0, yaw: 0.0}",
            "pose: {x: 0.0, y: 0.0, z: 0.0, roll: 0.2, pitch: 0.0, yaw: 0.0}",
        )
        .replace("urdf: delta.urdf", &format!("urdf: {}", urdf.display()));
    assert_ne!(tilted, yaml);
    let path = dir.path().join("tilted.yaml");
    std::fs::write(&path, tilted).unwrap();
    let mechanism = Mechanism::load(&path).unwrap();
    let miw = spatial_inscribed_workspace(&mechanism, options(&mechanism)).unwrap();
    let expected = 0.03 * 0.2_f64.cos();
    assert!(
        (miw.radius - expected).abs() < 1e-12,
        "{} vs {expected}",
        miw.radius
    );
    let out = legwise(&[
        "workspace",
        "--model",
        "models/delta-probe.yaml",
        "--out",
        dir.path().join("w.svg").to_str().unwrap(),
    ]);
    let printed = text(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(printed.contains("radius  0.0300000 m"), "{printed}");
    assert!(
        printed.contains("the touch surface of target `nozzle` is 0.0300000 m from the home position and bounds the ball"),
        "{printed}"
    );
    let labels = svg_texts(&std::fs::read_to_string(dir.path().join("w.svg")).unwrap());
    assert!(
        labels
            .iter()
            .any(|l| l.starts_with("touch surface of target `nozzle`")),
        "{labels:?}"
    );
}
