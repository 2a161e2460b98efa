//! The 3-D MIW of the spatial models: its ball lies in the singularity-free region (points on
//! its surface, in directions the computation did not use, checked with the legs' inverse
//! kinematics and the parallel measure directly), it is tight (just past the nearest crossing
//! a point is outside), and `legwise workspace` draws its picture.
use legwise::kinematics::inverse::solve_leg;
use legwise::kinematics::singularity::ParallelMeasure;
use legwise::model::Mechanism;
use legwise::workspace::miw3d::{spatial_inscribed_workspace, Miw3dOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cli::{legwise, text};
use crate::spatial::MODELS;
use crate::support::bundled;

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
fn workspace_on_the_delta_prints_the_3d_miw_and_writes_its_picture() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("delta.svg");
    let run = legwise(&[
        "workspace",
        "--model",
        "models/delta.yaml",
        "--rays",
        "200",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = text(&run.stdout);
    assert_eq!(run.status.code(), Some(0), "{}", text(&run.stderr));
    assert!(stdout.contains("3-D MIW"), "{stdout}");
    assert!(stdout.contains("radius"), "{stdout}");
    let svg = std::fs::read_to_string(&out).unwrap();
    assert!(
        svg.starts_with("<svg") || svg.contains("<svg"),
        "not an SVG"
    );
    assert!(svg.contains("MIW"), "no MIW legend in the picture");
    // The slice draws no singular curves, so its legend names none.
    assert!(!svg.contains("singularity: a leg") && !svg.contains("(type II) singularity"));
}
