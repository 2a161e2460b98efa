//! Marlin's linear delta: an `M503` report (`M665`, `M666`, `M92`, `M851`) and a bed-probe log
//! (`Bed X: … Y: … Z: …` lines, printed by `G30` and by `G29` at verbose level 3 or more) read
//! as a [`DeltaGeometry`]; and a calibrated model's [`DeltaFit`] written as `M665`/`M666` lines
//! and `M500`.
//!
//! The conventions (Marlin's G-code documentation and the formulas of module/delta.cpp,
//! module/motion.cpp, module/probe.cpp, gcode/probe/G30.cpp; formulas only, no code) are in
//! docs/printers.md and [`CONVENTIONS`].

use std::fmt::Write as _;
use std::path::Path;

use super::delta_model::{DeltaGeometry, Firmware};
use super::export::{DeltaFit, FirmwareTerms};
use super::gcode::{code_of, Settings};
use super::rrf::{correction, to_touches, Stop};
use crate::error::{Error, Result};

/// The conventions of the import and export, as printed by `legwise printer import --marlin`.
pub const CONVENTIONS: &str = "\
conventions (Marlin linear delta; docs/printers.md):
  towers: leg1 = X/A (210 deg + M665 X), leg2 = Y/B (330 deg + M665 Y), leg3 = Z/C (90 deg + M665 Z),
    tower i at R * (cos angle_i, sin angle_i) in the firmware's frame (the base frame)
  M665 L: the diagonal rod, A B C: each tower's rod trim (rod_i = L + A|B|C); R: delta radius
    |t_i - e_i| (the effector joints sit at the nozzle); H: delta height
  M851 X Y Z: the probe's offset from the nozzle (Z < 0: the nozzle is -Z above the bed at the trigger)
  homing: the nozzle's z at home (centre) = H - M851 Z (Marlin 2.1, with a probe)
  M666 X Y Z (<= 0): the carriage stops |M666| below its endstop, so its endstop is at
    H - M851 Z - M666_i + sqrt(rod_i^2 - R^2): the sign is the opposite of RepRapFirmware's
  carriage height: h_i = z + sqrt(rod_i^2 - (x - t_ix)^2 - (y - t_iy)^2); k_i = 1
  reading: s_i = h_i - h0_i at the nozzle's stopped position (m; 0 at the endstop, down negative)
  probe: 'Bed X: x Y: y Z: z' (G30, G29 V3+) = the probe at (x, y), the nozzle at
    (x - M851 X, y - M851 Y, z - M851 Z) and -M851 Z above the bed; G33's report has no points
  M92: steps per mm, not needed for the readings (the log's heights are already the stopped motor
    positions); `printer export --firmware-config` writes it divided by the calibrated gains
  units: mm -> m, degrees -> rad";

/// What Marlin's parameters express: three rods (`L` and the trims `A B C`), no tilt.
pub const TERMS: FirmwareTerms = FirmwareTerms {
    one_rod: false,
    tilt: false,
    gains: false,
};

/// The commands read from the `M503` report.
const COMMANDS: [&str; 4] = ["M665", "M666", "M92", "M851"];
/// The firmware's name in messages.
const NAME: &str = "Marlin";

/// A Marlin delta: the geometry and what the import reports.
#[derive(Debug, Clone)]
pub struct MarlinDelta {
    /// The geometry with the log's touches.
    pub geometry: DeltaGeometry,
    /// `M92 X Y Z` steps per mm, if given.
    pub steps_per_mm: Option<[f64; 3]>,
    /// `M851 X Y Z`, mm.
    pub probe_offset: [f64; 3],
}

impl MarlinDelta {
    /// Reads the `M503` report `report`, then the probe log `probes` if given.
    ///
    /// # Errors
    /// A file cannot be read, a required parameter is missing (`M665 L`, `R`, `H`,
    /// `M666 X Y Z`, `M851 Z`) or not a number, a positive `M666`, a rod not longer than the
    /// radius, or a bad log line; each names the file, the line and the parameter.
    pub fn read(report: &Path, probes: Option<&Path>) -> Result<Self> {
        let mut settings = Settings::default();
        settings.read(report, &COMMANDS)?;
        let rod = settings.require("M665", 'L', "the diagonal rod length, mm", NAME)?;
        let radius = settings.require("M665", 'R', "the delta radius, mm", NAME)?;
        let height = settings.require("M665", 'H', "the delta height, mm", NAME)?;
        if !(radius > 0.0 && rod > radius) {
            let w = settings.get("M665", 'L');
            return Err(Error::Invalid(format!(
                "{}: line {}: M665: expected 0 < R < L, found R {radius} mm and L {rod} mm",
                w.map_or(report, |w| w.path.as_path()).display(),
                w.map_or(0, |w| w.line)
            )));
        }
        let trims = [
            settings.number("M665", 'X')?.unwrap_or(0.0),
            settings.number("M665", 'Y')?.unwrap_or(0.0),
            settings.number("M665", 'Z')?.unwrap_or(0.0),
        ];
        let rod_trims = [
            settings.number("M665", 'A')?.unwrap_or(0.0),
            settings.number("M665", 'B')?.unwrap_or(0.0),
            settings.number("M665", 'C')?.unwrap_or(0.0),
        ];
        let arms: [f64; 3] = std::array::from_fn(|i| rod + rod_trims[i]);
        if let Some(i) = (0..3).find(|&i| arms[i] <= radius) {
            let w = settings.get("M665", 'L');
            return Err(Error::Invalid(format!(
                "{}: line {}: M665: expected each rod L + A|B|C longer than R {radius} mm, found {} mm for tower {}",
                w.map_or(report, |w| w.path.as_path()).display(),
                w.map_or(0, |w| w.line),
                arms[i],
                ["X", "Y", "Z"][i]
            )));
        }
        let mut adjustments = [0.0; 3];
        for (i, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            adjustments[i] =
                settings.require("M666", letter, "the endstop adjustment, mm, <= 0", NAME)?;
            if adjustments[i] > 0.0 {
                let w = settings.get("M666", letter).map_or(0, |w| w.line);
                return Err(Error::Invalid(format!(
                    "{}: line {w}: M666 {letter}: expected a value <= 0 (Marlin refuses others), found {}",
                    report.display(),
                    adjustments[i]
                )));
            }
        }
        let offset_z = settings.require(
            "M851",
            'Z',
            "the probe's Z offset from the nozzle, mm",
            NAME,
        )?;
        let probe_offset = [
            settings.number("M851", 'X')?.unwrap_or(0.0),
            settings.number("M851", 'Y')?.unwrap_or(0.0),
            offset_z,
        ];
        let steps_per_mm = match (
            settings.number("M92", 'X')?,
            settings.number("M92", 'Y')?,
            settings.number("M92", 'Z')?,
        ) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        let nominal = [210.0, 330.0, 90.0];
        let trigger = -offset_z;
        let mut geometry = DeltaGeometry {
            firmware: Firmware::Marlin,
            radius,
            angles: std::array::from_fn(|i| nominal[i] + trims[i]),
            arms,
            endstops: std::array::from_fn(|i| height - offset_z - adjustments[i]),
            tilt: [0.0, 0.0],
            z_offset: Some(trigger),
            calibrate_radius: None,
            touches: Vec::new(),
            distances: Vec::new(),
            steps_known: steps_per_mm.is_some(),
        };
        if let Some(log) = probes {
            let stops = read_log(log, probe_offset)?;
            let reach = stops
                .iter()
                .map(|s| s.nozzle[0].hypot(s.nozzle[1]))
                .fold(0.0, f64::max);
            geometry.touches = to_touches(log, &geometry, &stops, trigger)?;
            if reach > 0.0 {
                geometry.calibrate_radius = Some(reach);
            }
        }
        Ok(MarlinDelta {
            geometry,
            steps_per_mm,
            probe_offset,
        })
    }
}

/// The nozzle's stopped positions in a probe log: its `Bed X: x Y: y Z: z` lines.
fn read_log(path: &Path, offset: [f64; 3]) -> Result<Vec<Stop>> {
    let text = crate::model::source::read_text_file(path)?;
    let mut stops = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let code = code_of(raw);
        let Some(rest) = code.find("Bed X:").map(|k| &code[k + 6..]) else {
            continue;
        };
        let bad = || {
            Error::Invalid(format!(
                "{}: line {line}: expected `Bed X: <x> Y: <y> Z: <z>` with three numbers, found `{}`",
                path.display(),
                code.trim()
            ))
        };
        let (x, rest) = rest.split_once("Y:").ok_or_else(bad)?;
        let (y, z) = rest.split_once("Z:").ok_or_else(bad)?;
        let z = z.split_whitespace().next().unwrap_or("");
        let parse = |t: &str| t.trim().parse::<f64>().ok().filter(|v| v.is_finite());
        let (Some(x), Some(y), Some(z)) = (parse(x), parse(y), parse(z)) else {
            return Err(bad());
        };
        stops.push(Stop {
            id: format!("bed_line{line}"),
            nozzle: [x - offset[0], y - offset[1], z - offset[2]],
            line,
        });
    }
    Ok(stops)
}

/// Marlin's values of a fit, in its units (mm, degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarlinValues {
    /// `M665 L`, mm: the rods' mean.
    pub rod: f64,
    /// `M665 A B C`, mm: each rod's trim from `L`.
    pub rod_trims: [f64; 3],
    /// `M665 R`, mm.
    pub radius: f64,
    /// `M665 H`, mm.
    pub height: f64,
    /// `M665 X Y Z`, degrees.
    pub trims: [f64; 3],
    /// `M666 X Y Z`, mm (the largest 0, as Marlin's G33 normalises them).
    pub adjustments: [f64; 3],
    /// `M92 X Y Z`, steps per mm: the current ones divided by the calibrated gains, when the
    /// export was given them.
    pub steps_per_mm: Option<[f64; 3]>,
}

impl MarlinValues {
    /// The values of `fit` for a probe whose `M851 Z` is `offset_z` (mm); with the current `M92
    /// X Y Z` (`steps_per_mm`), the new ones.
    pub fn from_fit(fit: &DeltaFit, offset_z: f64, steps_per_mm: Option<[f64; 3]>) -> Self {
        // The nozzle's height at the centre with the carriages at their endstops:
        // H − M851 Z − M666_i.
        let bases: [f64; 3] = std::array::from_fn(|i| fit.endstop(i) * 1e3);
        let lowest = bases.iter().copied().fold(f64::INFINITY, f64::min);
        let nominal = [210.0, 330.0, 90.0];
        let rods = fit.arms.map(|l| l * 1e3);
        let rod = (rods[0] + rods[1] + rods[2]) / 3.0;
        MarlinValues {
            rod,
            rod_trims: rods.map(|l| l - rod + 0.0),
            radius: fit.radius * 1e3,
            height: lowest + offset_z,
            trims: std::array::from_fn(|i| correction(fit.angles[i], nominal[i])),
            adjustments: bases.map(|b| lowest - b + 0.0),
            steps_per_mm: steps_per_mm.map(|s| std::array::from_fn(|i| s[i] / fit.gains[i])),
        }
    }

    /// The `M665`/`M666` lines and `M500` (9 decimals).
    pub fn lines(&self) -> String {
        let mut out = String::from(
            "; legwise printer export --marlin (docs/printers.md): send these lines; M500 stores them\n",
        );
        let _ = writeln!(
            out,
            "M665 L{:.9} R{:.9} H{:.9} X{:.9} Y{:.9} Z{:.9} A{:.9} B{:.9} C{:.9}",
            self.rod,
            self.radius,
            self.height,
            self.trims[0],
            self.trims[1],
            self.trims[2],
            self.rod_trims[0],
            self.rod_trims[1],
            self.rod_trims[2]
        );
        let _ = writeln!(
            out,
            "M666 X{:.9} Y{:.9} Z{:.9}",
            self.adjustments[0], self.adjustments[1], self.adjustments[2]
        );
        if let Some(s) = self.steps_per_mm {
            let _ = writeln!(out, "M92 X{:.9} Y{:.9} Z{:.9}", s[0], s[1], s[2]);
        }
        out.push_str("M500\n");
        out
    }
}
