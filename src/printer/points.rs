//! The touches `legwise select` picks for an imported printer, written as the firmware's own
//! probing commands: RepRapFirmware's `bed.g` (`G30 P… X… Y… Z-99999`, the last point `S-1`),
//! Marlin's `G30 X… Y…` lines, Klipper's `[delta_calibrate]` section with a `points:` list.
//! Each firmware's log (or SAVE_CONFIG block) of those commands is what `legwise printer import`
//! reads, so the selected touches come back as probe rows.
//!
//! The selection's `pose.x`, `pose.y` are the nozzle's position in the model's base frame, the
//! firmware's frame (docs/printers.md §3), in metres; the firmware's commands take mm. RepRapFirmware's
//! `G30 P` and Marlin's `G30` place the probe, not the nozzle: they get the nozzle's point plus the
//! probe's XY offset (`G31 X Y`, `M851 X Y`), as the importers subtract it. Klipper's
//! `[delta_calibrate] points` are the nozzle's coordinates (its probe helper applies no offset).

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::measure::forward_simulate::touched;
use crate::measure::observations::template_csv;
use crate::measure::MeasurementSet;
use crate::model::region::Region;
use crate::model::Mechanism;

/// One selected touch: its row and the nozzle's point on the bed.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectedTouch {
    /// The row's id (`t1`, `t2`, …).
    pub id: String,
    /// 1-based line of the selection file.
    pub line: usize,
    /// The nozzle's `x`, `y` in the firmware's frame, mm.
    pub nozzle_mm: [f64; 2],
}

/// Tolerance on a selected row's height against the model's touch there, m.
const SAME_HEIGHT: f64 = 1e-9;

/// The touches of the selection file `path` (`legwise select --model` of `mechanism`).
///
/// # Errors
/// The file cannot be read; its header is not the one `legwise select` writes for `mechanism`;
/// a cell is not a number; a row's `pose.z` is not the model's touch at its `x`, `y` (a
/// selection made for another model); a point outside the model's workspace radius; no touch
/// rows. Each names the file and the line.
pub fn read_selected(path: &Path, mechanism: &Mechanism) -> Result<Vec<SelectedTouch>> {
    let text = crate::model::source::read_text_file(path)?;
    let err = |line: usize, message: String| {
        Error::Invalid(format!("{}: line {line}: {message}", path.display()))
    };
    let instrument = mechanism.forward_instrument().ok_or_else(|| {
        Error::Invalid(format!(
            "{}: field `instrument.kinematics`: expected an imported printer (a forward model), found none",
            mechanism.model_path.display()
        ))
    })?;
    if mechanism.measured_names() != ["x", "y", "z"] {
        return Err(Error::Invalid(format!(
            "{}: field `measured`: expected [x, y, z] (an imported printer), found [{}]",
            mechanism.model_path.display(),
            mechanism.measured_names().join(", ")
        )));
    }
    let (centre, radius) = match mechanism.workspace.region {
        Region::Cylinder { centre, radius, .. } => (centre, radius),
        _ => {
            return Err(Error::Invalid(format!(
                "{}: field `workspace.region`: expected the cylinder of an imported printer",
                mechanism.model_path.display()
            )))
        }
    };
    let template = template_csv(
        mechanism,
        &MeasurementSet::new(None, mechanism.legs.len()),
        0,
    )?;
    let expected = template.lines().next().unwrap_or("").trim();
    let mut lines = text.lines().enumerate();
    let header = lines.next().map_or("", |(_, h)| h.trim());
    if header != expected {
        return Err(err(
            1,
            format!(
                "expected the header `legwise select --model {}` writes, `{expected}`, found `{header}` \
                 (a selection of another model?)",
                mechanism.model_path.display()
            ),
        ));
    }
    let names: Vec<&str> = header.split(',').collect();
    let column = |name: &str| names.iter().position(|n| *n == name);
    let (Some(cx), Some(cy), Some(cz), Some(cid)) = (
        column("pose.x"),
        column("pose.y"),
        column("pose.z"),
        column("id"),
    ) else {
        return Err(err(
            1,
            format!("expected the columns pose.x, pose.y, pose.z and id, found `{header}`"),
        ));
    };
    let nominal = instrument.nominal();
    let mut touches = Vec::new();
    for (index, raw) in lines {
        let line = index + 1;
        if raw.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = raw.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(err(
                line,
                format!("expected {} cells, found {}", names.len(), cells.len()),
            ));
        }
        let id = cells[cid];
        if !id.starts_with('t') {
            // A measured pose (`m1`, …): not a touch.
            continue;
        }
        let number = |c: usize| -> Result<f64> {
            cells[c]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    err(
                        line,
                        format!("{}: expected a number (m), found `{}`", names[c], cells[c]),
                    )
                })
        };
        let (x, y, z) = (number(cx)?, number(cy)?, number(cz)?);
        let off = (x - centre[0]).hypot(y - centre[1]);
        if off > radius * (1.0 + 1e-9) {
            return Err(err(
                line,
                format!(
                    "touch {id}: the nozzle at ({:.3}, {:.3}) mm is {:.3} mm from the bed's centre, \
                     outside the printer's radius {:.3} mm ({} `workspace.region`)",
                    x * 1e3,
                    y * 1e3,
                    off * 1e3,
                    radius * 1e3,
                    mechanism.model_path.display()
                ),
            ));
        }
        let at = touched(mechanism, instrument, &nominal, [x, y, z, 0.0, 0.0, 0.0])?;
        if (at[2] - z).abs() > SAME_HEIGHT {
            return Err(err(
                line,
                format!(
                    "touch {id}: pose.z: expected the model's touch height there, {} m, found {z} m \
                     (a selection of another model than {}?)",
                    at[2],
                    mechanism.model_path.display()
                ),
            ));
        }
        touches.push(SelectedTouch {
            id: id.to_string(),
            line,
            nozzle_mm: [x * 1e3, y * 1e3],
        });
    }
    if touches.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no touch rows (ids t1, t2, …): expected the file `legwise select --model {}` writes",
            path.display(),
            mechanism.model_path.display()
        )));
    }
    Ok(touches)
}

/// A coordinate in mm as the commands write it (6 decimals, `-0` written `0`).
fn mm(v: f64) -> String {
    let text = format!("{v:.6}");
    match text
        .trim_start_matches('-')
        .trim_matches(|c| c == '0' || c == '.')
    {
        "" => "0.000000".into(),
        _ => text,
    }
}

/// A coordinate in mm to 0.01 mm (`-0` written `0`).
fn hundredths(v: f64) -> String {
    let text = format!("{v:.2}");
    match text.as_str() {
        "-0.00" => "0.00".into(),
        _ => text,
    }
}

/// RepRapFirmware's `bed.g` probing `touches`, the probe `offset` (`G31 X Y`, mm) from the
/// nozzle: `G30 P<k> X Y Z-99999`, the last with `S-1` (print the heights, adjust nothing), whose
/// reply `G32 bed probe heights: …` `legwise printer import --rrf --probes` reads.
pub fn rrf_bed_g(touches: &[SelectedTouch], offset: [f64; 2], source: &str) -> String {
    let mut out = format!(
        "; bed.g: legwise printer points --rrf (docs/printers.md): the {} touches selected in\n\
         ; {source}, the probe at the nozzle's point + G31 X Y ({}, {}) mm. The last point's S-1\n\
         ; prints the heights and adjusts nothing: log the console and give it to\n\
         ; legwise printer import --rrf --probes\n\
         M561 ; clear any bed transform\nG28 ; home\n",
        touches.len(),
        mm(offset[0]),
        mm(offset[1])
    );
    for (k, t) in touches.iter().enumerate() {
        let last = if k + 1 == touches.len() { " S-1" } else { "" };
        let _ = writeln!(
            out,
            "G30 P{k} X{} Y{} Z-99999{last} ; {}",
            mm(t.nozzle_mm[0] + offset[0]),
            mm(t.nozzle_mm[1] + offset[1]),
            t.id
        );
    }
    out
}

/// Marlin's `G30 X Y` lines probing `touches`, the probe `offset` (`M851 X Y`, mm) from the
/// nozzle; each prints `Bed X: Y: Z:`, which `legwise printer import --marlin --probes` reads.
/// The points are written to 0.01 mm, the decimals Marlin prints them with, so that the log
/// reports where the probe went (each within 0.005 mm of the selection).
pub fn marlin_g30(touches: &[SelectedTouch], offset: [f64; 2], source: &str) -> String {
    let mut out = format!(
        "; legwise printer points --marlin (docs/printers.md): the {} touches selected in\n\
         ; {source}, the probe at the nozzle's point + M851 X Y ({}, {}) mm, to 0.01 mm as\n\
         ; Marlin prints them. Send them and log the host's console for\n\
         ; legwise printer import --marlin --probes\nG28 ; home\n",
        touches.len(),
        hundredths(offset[0]),
        hundredths(offset[1])
    );
    for t in touches {
        let _ = writeln!(
            out,
            "G30 X{} Y{} ; {}",
            hundredths(t.nozzle_mm[0] + offset[0]),
            hundredths(t.nozzle_mm[1] + offset[1]),
            t.id
        );
    }
    out
}

/// Klipper's `[delta_calibrate]` section probing `touches` (nozzle coordinates, mm) through its
/// `points` option, keeping `radius` and the optional `speed` and `horizontal_move_z` of the
/// printer's section; `DELTA_CALIBRATE` then `SAVE_CONFIG` store each touch as `heightN_pos`,
/// which `legwise printer import --klipper` reads.
pub fn klipper_section(
    touches: &[SelectedTouch],
    radius: f64,
    speed: Option<f64>,
    horizontal_move_z: Option<f64>,
    source: &str,
) -> String {
    let mut out = format!(
        "# legwise printer points --klipper (docs/printers.md): the {} touches selected in\n\
         # {source}, nozzle coordinates. Replace printer.cfg's [delta_calibrate] section with this\n\
         # one, run DELTA_CALIBRATE and SAVE_CONFIG, then legwise printer import --klipper.\n\
         [delta_calibrate]\nradius: {radius}\n",
        touches.len()
    );
    if let Some(v) = speed {
        let _ = writeln!(out, "speed: {v}");
    }
    if let Some(v) = horizontal_move_z {
        let _ = writeln!(out, "horizontal_move_z: {v}");
    }
    out.push_str("points:\n");
    for t in touches {
        let _ = writeln!(out, "    {}, {}", mm(t.nozzle_mm[0]), mm(t.nozzle_mm[1]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(id: &str, x: f64, y: f64) -> SelectedTouch {
        SelectedTouch {
            id: id.into(),
            line: 2,
            nozzle_mm: [x, y],
        }
    }

    #[test]
    fn rrf_points_add_the_probe_offset_and_end_with_s_minus_1() {
        let text = rrf_bed_g(
            &[touch("t1", -135.0, 0.0), touch("t2", 10.5, -20.25)],
            [0.0, 15.0],
            "sel.csv",
        );
        let lines: Vec<&str> = text.lines().filter(|l| l.starts_with("G30")).collect();
        assert_eq!(
            lines,
            [
                "G30 P0 X-135.000000 Y15.000000 Z-99999 ; t1",
                "G30 P1 X10.500000 Y-5.250000 Z-99999 S-1 ; t2"
            ]
        );
    }

    #[test]
    fn marlin_points_add_the_probe_offset_to_hundredths_and_write_no_negative_zero() {
        let text = marlin_g30(
            &[touch("t1", -1e-9, 3.0), touch("t2", 12.344, -7.5)],
            [0.0, -3.0],
            "sel.csv",
        );
        assert!(
            text.ends_with("\nG30 X0.00 Y0.00 ; t1\nG30 X12.34 Y-10.50 ; t2\n"),
            "{text}"
        );
    }

    #[test]
    fn klipper_points_are_the_nozzle_coordinates_in_delta_calibrate() {
        let text = klipper_section(&[touch("t1", 1.0, -2.5)], 50.0, None, Some(5.0), "s");
        assert!(
            text.ends_with("[delta_calibrate]\nradius: 50\nhorizontal_move_z: 5\npoints:\n    1.000000, -2.500000\n"),
            "{text}"
        );
    }
}
