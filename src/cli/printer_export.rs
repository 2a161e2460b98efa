//! `legwise printer export`'s work: the calibrated model's firmware values as the lines to send
//! or paste, and what the export says about them (the values, the loss), kept in memory so that
//! the command line prints them and the library hands them back.

use std::fmt::Write as _;
use std::path::Path;

use super::args::PrinterExportArgs;
use crate::error::Error;
use crate::model::region::Region;
use crate::model::Mechanism;
use crate::printer::export::{
    calibrated_gains, fit_delta, fit_klipper, save_config_block, stepper_settings,
};
use crate::printer::klipper::{KlipperConfig, TOWERS};
use crate::printer::marlin::{self, MarlinDelta, MarlinValues};
use crate::printer::rrf::{self, RrfDelta, RrfValues};

/// What an export gives: the firmware's lines and the report about them.
#[derive(Debug, Clone)]
pub struct ExportOutputs {
    /// The lines to paste or send (Klipper's SAVE_CONFIG block, `M665`/`M666`/`M92` lines).
    pub values: String,
    /// The values in words, a note on gains not exported, and what the export loses.
    pub summary: String,
}

/// The export `args` asks for (its `--out` is the caller's business).
///
/// # Errors
/// A calibrated model that is not an imported printer, a bad `--bed-radius`, a firmware file
/// without its step settings, a fit that fails.
pub(crate) fn exported(args: &PrinterExportArgs) -> anyhow::Result<ExportOutputs> {
    let mechanism = Mechanism::load(&args.calibrated)?;
    let bed_radius = match args.bed_radius {
        Some(r) if r.is_finite() && r > 0.0 => r,
        Some(r) => {
            return Err(Error::Invalid(format!(
                "--bed-radius: expected a positive radius in metres, found {r}"
            ))
            .into())
        }
        None => match mechanism.workspace.region {
            Region::Cylinder { radius, .. } => radius,
            _ => {
                return Err(Error::Invalid(format!(
                    "{}: field `workspace.region`: expected the cylinder of an imported printer, or give --bed-radius",
                    args.calibrated.display()
                ))
                .into())
            }
        },
    };
    let steps = match &args.firmware_config {
        Some(path) => Some(firmware_steps(args, path)?),
        None => None,
    };
    let mut summary = String::new();
    if steps.is_none() {
        let gains = calibrated_gains(&mechanism)?;
        if gains.iter().any(|g| (g - 1.0).abs() > 1e-12) {
            let _ = writeln!(
                summary,
                "note: the calibrated gains {gains:.6?} are not exported (they count in the loss): \
                 give --firmware-config with the file the printer was imported from to write them \
                 as its step settings"
            );
        }
    }
    let gains_lost = if steps.is_some() { "" } else { "gains, " };
    let grid = |points: usize| {
        format!(
            "over the bed (r <= {:.1} mm, {points} points at 0 and {:.1} mm)",
            bed_radius * 1e3,
            bed_radius * 5e2
        )
    };
    let calibrated = args.calibrated.display();
    if args.klipper {
        let fit = fit_klipper(&mechanism, bed_radius, steps)?;
        let v = &fit.values;
        let _ = writeln!(
            summary,
            "Klipper values closest to {calibrated} {}: delta_radius {:.6} mm, angle {:.6?} deg, \
             arm_length {:.6?} mm, position_endstop {:.6?} mm{}",
            grid(fit.points),
            v.radius,
            v.angles,
            v.arms,
            v.endstops,
            v.rotation_distances
                .map_or_else(String::new, |r| format!(", rotation_distance {r:.6?} mm"))
        );
        let _ = writeln!(
            summary,
            "lost in the export (what Klipper cannot express: {gains_lost}a bed tilt): {:.3} µm RMS, \
             {:.3} µm max of the nozzle's position over the bed; Klipper's origin at ({:.4}, {:.4}) \
             mm of the bed frame",
            fit.rms_loss * 1e6,
            fit.max_loss * 1e6,
            fit.origin[0] * 1e3,
            fit.origin[1] * 1e3
        );
        return Ok(ExportOutputs {
            values: stepper_settings(&fit.values) + &save_config_block(&fit.values),
            summary,
        });
    }
    let (terms, name) = if args.rrf {
        (rrf::TERMS, "RepRapFirmware")
    } else {
        (marlin::TERMS, "Marlin")
    };
    let fit = fit_delta(&mechanism, bed_radius, terms.with_gains(steps.is_some()))?;
    let (values, words, lost) = if args.rrf {
        let v = RrfValues::from_fit(&fit, steps);
        (
            v.lines(),
            format!(
                "M665 L {:.6?} R {:.6} H {:.6} X Y Z {:.6?} deg; M666 X Y Z {:.6?} mm, A B {:.6?} %{}",
                v.rods,
                v.radius,
                v.height,
                v.corrections,
                v.adjustments,
                v.tilt,
                steps_text(v.steps_per_mm)
            ),
            format!("{gains_lost}a bed tilt beyond the firmware's shear"),
        )
    } else {
        // Marlin's H counts from the probe's M851 Z: the model keeps it as the nozzle's touch
        // height (−M851 Z).
        let touch = mechanism
            .instrument
            .as_ref()
            .and_then(|i| i.targets.first())
            .and_then(|t| t.touch)
            .unwrap_or(0.0);
        let v = MarlinValues::from_fit(&fit, -touch * 1e3, steps);
        (
            v.lines(),
            format!(
                "M665 L {:.6} R {:.6} H {:.6} X Y Z {:.6?} deg A B C {:.6?} mm; M666 X Y Z {:.6?} mm (M851 Z {:.6} mm){}",
                v.rod,
                v.radius,
                v.height,
                v.trims,
                v.rod_trims,
                v.adjustments,
                -touch * 1e3,
                steps_text(v.steps_per_mm)
            ),
            format!("{gains_lost}a bed tilt"),
        )
    };
    let _ = writeln!(
        summary,
        "{name} values closest to {calibrated} {}: {words}",
        grid(fit.points)
    );
    let _ = writeln!(
        summary,
        "lost in the export (what {name} cannot express: {lost}): {:.3} µm RMS, {:.3} µm max \
         of the nozzle's position over the bed; the firmware's origin at ({:.4}, {:.4}) mm of the bed frame",
        fit.rms_loss * 1e6,
        fit.max_loss * 1e6,
        fit.origin[0] * 1e3,
        fit.origin[1] * 1e3
    );
    Ok(ExportOutputs { values, summary })
}

/// The step settings of the firmware file `path` the printer was imported from: Klipper's
/// steppers' `rotation_distance` (mm), or `M92 X Y Z` (steps per mm).
fn firmware_steps(args: &PrinterExportArgs, path: &Path) -> Result<[f64; 3], Error> {
    if args.klipper {
        let config = KlipperConfig::read(path)?;
        let mut out = [0.0; 3];
        for (i, tower) in TOWERS.iter().enumerate() {
            out[i] = config.require_float(tower, "rotation_distance", "mm per motor turn")?;
        }
        return Ok(out);
    }
    let steps = if args.rrf {
        RrfDelta::read(path, None, None)?.steps_per_mm
    } else {
        MarlinDelta::read(path, None)?.steps_per_mm
    };
    steps.ok_or_else(|| {
        Error::Invalid(format!(
            "{}: expected `M92 X Y Z` (steps per mm) to write the calibrated gains, found none",
            path.display()
        ))
    })
}

/// The new step settings in words, if any.
fn steps_text(steps: Option<[f64; 3]>) -> String {
    steps.map_or_else(String::new, |s| format!("; M92 X Y Z {s:.6?} steps/mm"))
}
