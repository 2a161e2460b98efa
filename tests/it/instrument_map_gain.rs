//! The bundled tracker models at their default settings (their seed, noise scale 1, their poses
//! per leg): the joint identification of the legs, the instrument frame and the targets' offsets
//! must give a better accuracy map than the nominal model. A model whose held parameters pin the
//! base frame poorly fails this: the hexapod holding the base-joint heights `a1z a2z a3z` (and
//! not the tracker's tilt) identified the frame to σ ≈ 3 cm and 2e-2 rad, and its map was 37.8 mm
//! RMS against 3.15 mm for the nominal model (docs/models.md §9.4).
use serde_json::Value;

use crate::cli::{legwise, text};

/// RMS of the position errors of a JSON accuracy map's assemblable points, recomputed from the
/// points; checks it against the map's own `rms` and returns it.
fn rms_of_points(map: &Value, what: &str) -> f64 {
    // A point the real legs cannot reach has no error (null); the others give the RMS.
    let errors: Vec<f64> = map["points"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|p| p["position_error_m"].as_f64())
        .collect();
    assert!(!errors.is_empty(), "{what}: no assemblable map point");
    let missing = map["points"].as_array().unwrap().len() - errors.len();
    assert_eq!(
        map["non_assemblable"].as_u64(),
        Some(missing as u64),
        "{what}"
    );
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let reported = map["position_error_m"]["rms"].as_f64().unwrap();
    assert!(
        (rms - reported).abs() <= 1e-12 * rms.max(1e-3),
        "{what}: reported RMS {reported} but the points give {rms}"
    );
    rms
}

#[test]
fn the_joint_identification_of_every_bundled_tracker_model_improves_its_accuracy_map() {
    // (model, map grid, largest ratio of the joint map's RMS to the nominal one's)
    for (model, grid, ratio) in [
        ("models/5r-tracker.yaml", "0.05", 0.2),
        ("models/delta-tracker.yaml", "0.02", 0.75),
        ("models/hexapod-tracker.yaml", "0.02", 0.75),
    ] {
        let out = legwise(&["identify", "--model", model, "--map", grid, "--json", "-"]);
        assert_eq!(out.status.code(), Some(0), "{model}: {}", text(&out.stderr));
        let report: Value = serde_json::from_str(&text(&out.stdout)).unwrap();
        let joint = &report["results"][0];
        assert!(
            joint["strategy"].as_str().unwrap().starts_with("joint"),
            "{model}"
        );
        let before = rms_of_points(&report["accuracy_map_before"], model);
        let after = rms_of_points(&joint["accuracy_map"], model);
        assert!(
            after < ratio * before,
            "{model}: joint map {:.3} mm RMS, nominal {:.3} mm: not below {ratio} of it",
            after * 1e3,
            before * 1e3
        );
    }
}
