//! RepRapFirmware's linear delta: `config.g` (and `config-override.g`) `M665`, `M666`, `M92`,
//! `G31`, a bed-probe log (`G30 P… X… Y… Z-99999` points and the `G32 bed probe heights:`
//! reply of the `S-1` point, or `G30 S-1` and its `Stopped at height` reply) read as a
//! [`DeltaGeometry`]; and a calibrated model's [`DeltaFit`] written as `M665`/`M666` lines.
//!
//! The conventions (RepRapFirmware's G-code documentation and the formulas of
//! src/Movement/Kinematics/LinearDeltaKinematics.cpp, GCodes4.cpp; formulas only, no code) are
//! in docs/printers.md and [`CONVENTIONS`].

use std::fmt::Write as _;
use std::path::Path;

use super::delta_model::{DeltaGeometry, Firmware, Touch};
use super::export::{DeltaFit, FirmwareTerms};
use super::gcode::{parse_command, Settings};
use crate::error::{Error, Result};

/// The conventions of the import and export, as printed by `legwise printer import --rrf`.
pub const CONVENTIONS: &str = "\
conventions (RepRapFirmware linear delta; docs/printers.md):
  towers: leg1 = X (210 deg + M665 X), leg2 = Y (330 deg + M665 Y), leg3 = Z (90 deg + M665 Z),
    tower i at R * (cos angle_i, sin angle_i) in the firmware's frame (the base frame)
  M665 L: diagonal rod (one, or three separated by ':'); R: delta radius |t_i - e_i| (the effector
    joints sit at the nozzle); H: the nozzle's height at the centre with the carriages homed
  M666 X Y Z: endstop corrections added to tower X, Y, Z's homed carriage height (mm, + = higher);
    A B: bed tilt in percent, the carriage heights add (A x + B y) / 100
  carriage height: h_i = z + (A x + B y)/100 + sqrt(L_i^2 - (x - t_ix)^2 - (y - t_iy)^2)
  actuator: h0_i = H + M666_i + sqrt(L_i^2 - R^2) (the homed carriage height), k_i = 1
  reading: s_i = h_i - h0_i at the nozzle's stopped position (m; 0 at the endstop, down negative)
  probe: G31 Z = the nozzle's height above the bed at the trigger; G31 X Y = the probe's offset
    from the nozzle. G30 P.. X Y Z-99999 [H] probes with the probe at (X, Y): the nozzle stops at
    (X - G31 X, Y - G31 Y, e + G31 Z + H), e the height the S-1 reply lists for that point;
    G30 S-1 [H] stops the nozzle at the last G0/G1 X Y and height h + H ('Stopped at height h mm')
  M92: steps per mm, not needed for the readings (the log's heights are already the stopped motor
    positions); `printer export --firmware-config` writes it divided by the calibrated gains
  units: mm -> m, degrees -> rad, percent -> fraction";

/// What RepRapFirmware's parameters express: three rods, a bed tilt.
pub const TERMS: FirmwareTerms = FirmwareTerms {
    one_rod: false,
    tilt: true,
    gains: false,
};

/// The commands read from `config.g` / `config-override.g`.
const COMMANDS: [&str; 4] = ["M665", "M666", "M92", "G31"];
/// The firmware's name in messages.
const NAME: &str = "RepRapFirmware";

/// A RepRapFirmware delta: the geometry and what the import reports.
#[derive(Debug, Clone)]
pub struct RrfDelta {
    /// The geometry with the log's touches.
    pub geometry: DeltaGeometry,
    /// `M92 X Y Z` steps per mm, if given.
    pub steps_per_mm: Option<[f64; 3]>,
    /// `G31 X Y` the probe's offset from the nozzle, mm.
    pub probe_offset: [f64; 2],
}

impl RrfDelta {
    /// Reads `config` and, over it, `overrides` (config-override.g), then the probe log
    /// `probes` if given.
    ///
    /// # Errors
    /// A file cannot be read, a required parameter is missing (`M665 L`, `R`, `H`; `G31 Z` with a
    /// probe log) or not a number, a rod not longer than the radius, or a bad log line; each
    /// names the file, the line and the parameter.
    pub fn read(config: &Path, overrides: Option<&Path>, probes: Option<&Path>) -> Result<Self> {
        let mut settings = Settings::default();
        settings.read(config, &COMMANDS)?;
        if let Some(path) = overrides {
            settings.read(path, &COMMANDS)?;
        }
        let rods = match settings.get("M665", 'L') {
            Some(word) => word.numbers("M665", 'L')?,
            None => return Err(settings.missing("M665", 'L', "the diagonal rod length, mm", NAME)),
        };
        let arms = match rods.as_slice() {
            [l] => [*l; 3],
            [a, b] => [*a, *b, *a],
            [a, b, c] => [*a, *b, *c],
            _ => {
                let word = settings.get("M665", 'L').map_or(0, |w| w.line);
                return Err(Error::Invalid(format!(
                    "{}: line {word}: M665 L: expected one to three rod lengths separated by ':', found {}",
                    settings.get("M665", 'L').map_or(config, |w| w.path.as_path()).display(),
                    rods.len()
                )));
            }
        };
        let radius = settings.require("M665", 'R', "the delta radius, mm", NAME)?;
        let height = settings.require(
            "M665",
            'H',
            "the nozzle's homed height at the centre, mm",
            NAME,
        )?;
        for (i, arm) in arms.iter().enumerate() {
            if !(radius > 0.0 && *arm > radius) {
                let w = settings.get("M665", 'L').or(settings.get("M665", 'R'));
                return Err(Error::Invalid(format!(
                    "{}: line {}: M665: expected 0 < R < L, found R {radius} mm and tower {} rod {arm} mm",
                    w.map_or(config, |w| w.path.as_path()).display(),
                    w.map_or(0, |w| w.line),
                    ["X", "Y", "Z"][i]
                )));
            }
        }
        let or_zero = |command: &str, letter: char| -> Result<f64> {
            Ok(settings.number(command, letter)?.unwrap_or(0.0))
        };
        let corrections = [
            or_zero("M665", 'X')?,
            or_zero("M665", 'Y')?,
            or_zero("M665", 'Z')?,
        ];
        let adjustments = [
            or_zero("M666", 'X')?,
            or_zero("M666", 'Y')?,
            or_zero("M666", 'Z')?,
        ];
        let tilt = [or_zero("M666", 'A')? * 0.01, or_zero("M666", 'B')? * 0.01];
        let steps_per_mm = match (
            settings.number("M92", 'X')?,
            settings.number("M92", 'Y')?,
            settings.number("M92", 'Z')?,
        ) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        let probe_offset = [or_zero("G31", 'X')?, or_zero("G31", 'Y')?];
        let trigger = settings.number("G31", 'Z')?;
        let nominal = [210.0, 330.0, 90.0];
        let mut geometry = DeltaGeometry {
            firmware: Firmware::Rrf,
            radius,
            angles: std::array::from_fn(|i| nominal[i] + corrections[i]),
            arms,
            endstops: std::array::from_fn(|i| height + adjustments[i]),
            tilt,
            z_offset: trigger,
            calibrate_radius: settings.number("M665", 'B')?,
            touches: Vec::new(),
            distances: Vec::new(),
            steps_known: steps_per_mm.is_some(),
        };
        if let Some(log) = probes {
            let trigger = trigger.ok_or_else(|| {
                settings.missing(
                    "G31",
                    'Z',
                    "the nozzle's height above the bed when the probe triggers, mm",
                    NAME,
                )
            })?;
            let stops = read_log(log, probe_offset, trigger)?;
            let reach = stops
                .iter()
                .map(|s| s.nozzle[0].hypot(s.nozzle[1]))
                .fold(0.0, f64::max);
            geometry.touches = to_touches(log, &geometry, &stops, trigger)?;
            if reach > 0.0 {
                geometry.calibrate_radius = Some(reach);
            }
        }
        Ok(RrfDelta {
            geometry,
            steps_per_mm,
            probe_offset,
        })
    }
}

/// A touch before its readings: the nozzle's stopped position and where it was read.
pub(crate) struct Stop {
    pub(crate) id: String,
    pub(crate) nozzle: [f64; 3],
    pub(crate) line: usize,
}

/// The nozzle's stopped positions in a probe log (mm, the firmware's coordinates).
fn read_log(path: &Path, offset: [f64; 2], trigger: f64) -> Result<Vec<Stop>> {
    let text = crate::model::source::read_text_file(path)?;
    let err = |line: usize, message: String| {
        Error::Invalid(format!("{}: line {line}: {message}", path.display()))
    };
    let mut stops: Vec<Stop> = Vec::new();
    let mut points: std::collections::BTreeMap<usize, ([f64; 3], usize)> = Default::default();
    let mut at: [Option<f64>; 2] = [None, None];
    let mut pending: Option<([f64; 3], usize)> = None;
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        let reply = parse_reply(raw);
        // The reply `G32 bed probe heights: …` starts like a command: read it first.
        let heights_reply = reply.find("bed probe heights:");
        if let Some(command) = parse_command(raw, line).filter(|_| heights_reply.is_none()) {
            let number = |letter: char| command.number(path, letter);
            match command.name.as_str() {
                "G0" | "G1" => {
                    if let Some(x) = number('X')? {
                        at[0] = Some(x);
                    }
                    if let Some(y) = number('Y')? {
                        at[1] = Some(y);
                    }
                }
                "G91" => {
                    return Err(err(
                        line,
                        "G91: relative moves are not followed; the log must move with absolute G0/G1 X Y".into(),
                    ))
                }
                "G30" => {
                    let s = number('S')?;
                    // `H`: the firmware reports the stopped height minus H.
                    let correction = number('H')?.unwrap_or(0.0);
                    if let Some(p) = number('P')? {
                        let (Some(x), Some(y)) = (number('X')?, number('Y')?) else {
                            return Err(err(
                                line,
                                "G30 P: expected the point's X and Y (the probe's position)".into(),
                            ));
                        };
                        match number('Z')? {
                            Some(z) if z <= -9999.0 => {}
                            found => {
                                return Err(err(
                                    line,
                                    format!(
                                        "G30 P: expected Z-99999 (a probed point), found {}",
                                        found.map_or("no Z".into(), |z| format!("Z{z}"))
                                    ),
                                ))
                            }
                        }
                        if p < 0.0 || p.fract() != 0.0 {
                            return Err(err(line, format!("G30 P: expected a point number 0, 1, …, found {p}")));
                        }
                        points.insert(p as usize, ([x, y, correction], line));
                    } else if s == Some(-1.0) {
                        let (Some(x), Some(y)) = (at[0], at[1]) else {
                            return Err(err(
                                line,
                                "G30 S-1: the nozzle's X and Y are unknown (no G0/G1 X Y before it)"
                                    .into(),
                            ));
                        };
                        pending = Some(([x, y, correction], line));
                    }
                }
                _ => {}
            }
            continue;
        }
        if let Some(rest) = heights_reply.map(|k| &reply[k + 18..]) {
            let list = rest.split(", mean").next().unwrap_or(rest);
            let mut heights = Vec::new();
            for token in list.split_whitespace() {
                match token.parse::<f64>() {
                    Ok(v) if v.is_finite() => heights.push(v),
                    _ => {
                        return Err(err(
                            line,
                            format!(
                                "bed probe heights: expected a height per point, found `{}` (a point not set or failed)",
                                list.trim()
                            ),
                        ))
                    }
                }
            }
            for (k, e) in heights.iter().enumerate() {
                let Some(([x, y, h], _)) = points.get(&k) else {
                    return Err(err(
                        line,
                        format!(
                            "bed probe heights: height {} has no G30 P{k} X Y line before it",
                            k + 1
                        ),
                    ));
                };
                stops.push(Stop {
                    id: format!("P{k}_line{line}"),
                    nozzle: [x - offset[0], y - offset[1], e + trigger + h],
                    line,
                });
            }
            points.clear();
        } else if let Some(rest) = reply.strip_prefix("Stopped at height") {
            let Some(([x, y, correction], _)) = pending.take() else {
                return Err(err(line, "Stopped at height: no G30 S-1 before it".into()));
            };
            let value = rest.trim().trim_end_matches("mm").trim();
            let h = value
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    err(
                        line,
                        format!("Stopped at height: expected a height in mm, found `{value}`"),
                    )
                })?;
            stops.push(Stop {
                id: format!("S-1_line{line}"),
                nozzle: [x, y, h + correction],
                line,
            });
        }
    }
    if let Some((_, line)) = points.values().next() {
        return Err(err(
            *line,
            "G30 P: a probed point without a `G32 bed probe heights:` reply after it (end the points with S-1 to print them)"
                .into(),
        ));
    }
    Ok(stops)
}

/// The reply text of a console line (the console prefixes removed).
fn parse_reply(raw: &str) -> String {
    super::gcode::code_of(raw)
}

/// The touches of `stops`: each nozzle position's readings by the firmware's kinematics, the
/// nozzle `trigger` mm above the bed.
pub(crate) fn to_touches(
    path: &Path,
    geometry: &DeltaGeometry,
    stops: &[Stop],
    trigger: f64,
) -> Result<Vec<Touch>> {
    stops
        .iter()
        .map(|stop| {
            let readings_mm = geometry.readings_at(stop.nozzle).ok_or_else(|| {
                Error::Invalid(format!(
                    "{}: line {}: the nozzle at ({}, {}, {}) mm is out of the rods' reach",
                    path.display(),
                    stop.line,
                    stop.nozzle[0],
                    stop.nozzle[1],
                    stop.nozzle[2]
                ))
            })?;
            Ok(Touch {
                id: stop.id.clone(),
                height_mm: trigger,
                readings_mm,
            })
        })
        .collect()
}

/// RepRapFirmware's values of a fit, in its units (mm, degrees, percent).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RrfValues {
    /// `M665 L`: the three rods, mm.
    pub rods: [f64; 3],
    /// `M665 R`, mm.
    pub radius: f64,
    /// `M665 H`, mm.
    pub height: f64,
    /// `M665 X Y Z`, degrees.
    pub corrections: [f64; 3],
    /// `M666 X Y Z`, mm (mean 0, as RepRapFirmware normalises them).
    pub adjustments: [f64; 3],
    /// `M666 A B`, percent.
    pub tilt: [f64; 2],
    /// `M92 X Y Z`, steps per mm: the current ones divided by the calibrated gains, when the
    /// export was given them.
    pub steps_per_mm: Option<[f64; 3]>,
}

/// An angle's difference from `nominal`, degrees, in (−180, 180].
pub(crate) fn correction(angle: f64, nominal: f64) -> f64 {
    let d = (angle.to_degrees() - nominal).rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

impl RrfValues {
    /// The values of `fit` (its endstop heights split into `H` and corrections of mean 0); with
    /// the current `M92 X Y Z` (`steps_per_mm`), the new ones.
    pub fn from_fit(fit: &DeltaFit, steps_per_mm: Option<[f64; 3]>) -> Self {
        let bases: [f64; 3] = std::array::from_fn(|i| fit.endstop(i) * 1e3);
        let height = (bases[0] + bases[1] + bases[2]) / 3.0;
        let nominal = [210.0, 330.0, 90.0];
        RrfValues {
            rods: fit.arms.map(|l| l * 1e3),
            radius: fit.radius * 1e3,
            height,
            corrections: std::array::from_fn(|i| correction(fit.angles[i], nominal[i])),
            adjustments: bases.map(|b| b - height + 0.0),
            tilt: fit.tilt.map(|t| t * 100.0 + 0.0),
            steps_per_mm: steps_per_mm.map(|s| std::array::from_fn(|i| s[i] / fit.gains[i])),
        }
    }

    /// The `M665`/`M666` lines (9 decimals: the firmware reads any and writes 3).
    pub fn lines(&self) -> String {
        let mut out = String::from(
            "; legwise printer export --rrf (docs/printers.md): send these lines, or put them in\n\
             ; config-override.g (M500 writes it from the running values)\n",
        );
        let [a, b, c] = self.rods;
        let rods = [a, b, c].map(|l| format!("{l:.9}"));
        // One value when the three read the same (the firmware copies it to the three towers).
        let rods = if rods[0] == rods[1] && rods[1] == rods[2] {
            rods[0].clone()
        } else {
            rods.join(":")
        };
        let _ = writeln!(
            out,
            "M665 L{rods} R{:.9} H{:.9} X{:.9} Y{:.9} Z{:.9}",
            self.radius, self.height, self.corrections[0], self.corrections[1], self.corrections[2]
        );
        let _ = writeln!(
            out,
            "M666 X{:.9} Y{:.9} Z{:.9} A{:.9} B{:.9}",
            self.adjustments[0],
            self.adjustments[1],
            self.adjustments[2],
            self.tilt[0],
            self.tilt[1]
        );
        if let Some(s) = self.steps_per_mm {
            let _ = writeln!(out, "M92 X{:.9} Y{:.9} Z{:.9}", s[0], s[1], s[2]);
        }
        out
    }
}
