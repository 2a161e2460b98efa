//! The firmware's side of a printer study: its own calibration (where it probes, which factors it
//! fits) and a firmware fit as the model's quantities.

use crate::error::{Error, Result};
use crate::model::quantities::FactorSet;
use crate::model::Mechanism;

use super::bed::bed_radius;
use crate::printer::export::{DeltaFit, FirmwareTerms};

/// A firmware's own calibration: where it probes and which factors it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct FirmwareCalibration {
    /// Its name in reports (`Klipper DELTA_CALIBRATE`).
    pub name: String,
    /// The nozzle's points it probes, (x, y) in the firmware's frame, m.
    pub points: Vec<[f64; 2]>,
    /// The factor set it fits (one of the model's `factor_sets`).
    pub set: FactorSet,
    /// What its parameters can express (the export of legwise's fit).
    pub terms: FirmwareTerms,
}

/// Scatter of Klipper's six outer `DELTA_CALIBRATE` points, as fractions of its `radius`:
/// Klipper probes the centre and six points at 90° + 60° k, not all at the same distance.
pub const KLIPPER_SCATTER: [f64; 6] = [0.95, 0.90, 0.85, 0.70, 0.75, 0.80];

/// Klipper's `DELTA_CALIBRATE` on `mechanism` (a model imported from Klipper): its seven
/// default points at the `[delta_calibrate] radius` (the model's workspace radius) and its set
/// `klipper-6`; legwise's export writes the gains as `rotation_distance` (the owner gives
/// `printer export --firmware-config printer.cfg`).
///
/// # Errors
/// The model has no `klipper-6` set or no cylinder workspace (not imported from Klipper).
pub fn klipper_calibration(mechanism: &Mechanism) -> Result<FirmwareCalibration> {
    let set = named_set(mechanism, "klipper-6")?;
    let radius = bed_radius(mechanism)?;
    let mut points = vec![[0.0, 0.0]];
    points.extend(KLIPPER_SCATTER.iter().enumerate().map(|(k, s)| {
        let angle = (90.0 + 60.0 * k as f64).to_radians();
        [radius * s * angle.cos(), radius * s * angle.sin()]
    }));
    Ok(FirmwareCalibration {
        name: "Klipper DELTA_CALIBRATE".into(),
        points,
        set,
        terms: crate::printer::export::KLIPPER_TERMS.with_gains(true),
    })
}

/// The model's factor set called `name`.
fn named_set(mechanism: &Mechanism, name: &str) -> Result<FactorSet> {
    mechanism
        .factor_sets
        .iter()
        .find(|s| s.name == name)
        .cloned()
        .ok_or_else(|| Error::Model {
            path: mechanism.model_path.clone(),
            field: "factor_sets".into(),
            message: format!(
                "expected the set `{name}` of a printer imported by `legwise printer import`, \
                 found {}",
                if mechanism.factor_sets.is_empty() {
                    "none".to_string()
                } else {
                    let names: Vec<&str> = mechanism
                        .factor_sets
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect();
                    names.join(", ")
                }
            ),
        })
}

/// A firmware fit as the values of `mechanism`'s quantities: `radius`, each tower's `angle_t`,
/// its rod (`arm_t`, or one `rod`) and `endstop_t`, the towers' letters read from the model's
/// `angle_*` quantities in order; a fit with [`FirmwareTerms::gains`] sets the gain parameters `k1 k2 k3` too.
///
/// # Errors
/// The model does not name three tower angles.
pub fn firmware_quantities(
    mechanism: &Mechanism,
    fit: &DeltaFit,
    terms: FirmwareTerms,
) -> Result<Vec<(String, f64)>> {
    let towers: Vec<&str> = mechanism
        .quantities
        .iter()
        .filter_map(|q| q.name.strip_prefix("angle_"))
        .collect();
    if towers.len() != 3 {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "quantities".into(),
            message: format!(
                "expected the three tower angles `angle_*` of an imported printer, found {}",
                towers.len()
            ),
        });
    }
    let has = |name: &str| mechanism.quantities.iter().any(|q| q.name == name);
    let mut values = vec![("radius".to_string(), fit.radius)];
    for (i, t) in towers.iter().enumerate() {
        values.push((format!("angle_{t}"), fit.angles[i]));
        values.push((format!("endstop_{t}"), fit.endstop(i)));
        if has(&format!("arm_{t}")) {
            values.push((format!("arm_{t}"), fit.arms[i]));
        }
    }
    if has("rod") {
        values.push(("rod".to_string(), fit.arms[0]));
    }
    if terms.gains {
        values.extend((0..3).map(|i| (format!("k{}", i + 1), fit.gains[i])));
    }
    Ok(values)
}
