//! Klipper's `printer.cfg`: the reader and the linear delta it describes.
//!
//! The file is an INI file: `[section]` headers, `key: value` or `key = value` lines, full-line
//! comments (`#`, `;`) and inline ones (`#`, `;` after a blank), indented continuation lines
//! (a macro's g-code; kept out of the values read here). Below the line
//! `#*# <---------------------- SAVE_CONFIG ---------------------->` every line starts `#*# `
//! and holds sections and values (Klipper's SAVE_CONFIG block) that apply where the sections above
//! do not set the same key: Klipper comments out a block value whose key a section still sets
//! when it reads the file, and a section's value of each key it saves when it writes the block.
//! (The Kalico fork reads the block over the sections; this reader follows Klipper.)
//! Keys are case-insensitive (read in lower case), as Klipper reads them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::delta_model::{DeltaGeometry, Distance, Firmware, Touch};
use crate::error::{Error, Result};

/// The marker line opening Klipper's SAVE_CONFIG block.
pub const SAVE_CONFIG_MARKER: &str =
    "#*# <---------------------- SAVE_CONFIG ---------------------->";

/// One value of the file and where it is.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigValue {
    /// The value, trimmed, without its inline comment.
    pub value: String,
    /// 1-based line number.
    pub line: usize,
    /// Read from the SAVE_CONFIG block.
    pub saved: bool,
}

/// A value of the SAVE_CONFIG block that the sections above also define: Klipper comments the
/// block's value out when it reads the file (the sections win; `SAVE_CONFIG` comments out the
/// sections' value when it writes one), and so does this reader.
#[derive(Debug, Clone, PartialEq)]
pub struct ShadowedValue {
    /// The section.
    pub section: String,
    /// The key.
    pub key: String,
    /// The block's value, not used.
    pub value: String,
    /// Its line.
    pub line: usize,
    /// The line of the sections' value, used.
    pub used_line: usize,
}

/// A parsed `printer.cfg`: sections of keys, the SAVE_CONFIG block's values where the sections
/// above do not define the same key (as Klipper reads it).
#[derive(Debug, Clone)]
pub struct KlipperConfig {
    /// The file (for messages).
    pub path: PathBuf,
    sections: BTreeMap<String, BTreeMap<String, ConfigValue>>,
    section_lines: BTreeMap<String, usize>,
    /// The block's values the sections above shadow.
    pub shadowed: Vec<ShadowedValue>,
}

impl KlipperConfig {
    /// Reads and parses `path`.
    ///
    /// # Errors
    /// The file cannot be read, or a line is neither a section, a value, a comment nor a
    /// continuation (the message names the file and line).
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::model::source::read_text_file(path)?;
        Self::parse(path, &text)
    }

    /// Parses `text`, the contents of `path`.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn parse(path: &Path, text: &str) -> Result<Self> {
        let mut config = KlipperConfig {
            path: path.to_path_buf(),
            sections: BTreeMap::new(),
            section_lines: BTreeMap::new(),
            shadowed: Vec::new(),
        };
        let mut saved = false;
        let mut section: Option<String> = None;
        for (index, raw) in text.lines().enumerate() {
            let line = index + 1;
            let mut content = raw;
            if raw.trim_end() == SAVE_CONFIG_MARKER {
                saved = true;
                section = None;
                continue;
            }
            if saved {
                let Some(rest) = raw.strip_prefix("#*#") else {
                    if raw.trim().is_empty() {
                        continue;
                    }
                    return Err(config.error(
                        line,
                        "a line in the SAVE_CONFIG block that does not start with `#*# `",
                    ));
                };
                content = rest.strip_prefix(' ').unwrap_or(rest);
                if content.starts_with("DO NOT EDIT THIS BLOCK") {
                    // The rest of Klipper's header.
                    continue;
                }
            }
            if content.starts_with([' ', '\t']) && !content.trim().is_empty() {
                // A continuation line of a multi-line value (a macro's g-code).
                continue;
            }
            let stripped = strip_comment(content).trim();
            if stripped.is_empty() {
                continue;
            }
            if let Some(name) = stripped.strip_prefix('[') {
                let Some(name) = name.strip_suffix(']') else {
                    return Err(config.error(line, "a section header without its closing `]`"));
                };
                let name = name.trim().to_string();
                config.section_lines.entry(name.clone()).or_insert(line);
                config.sections.entry(name.clone()).or_default();
                section = Some(name);
                continue;
            }
            let Some(split) = stripped.find([':', '=']) else {
                return Err(config.error(
                    line,
                    &format!(
                        "expected `key: value`, `key = value` or `[section]`, found `{stripped}`"
                    ),
                ));
            };
            let Some(name) = &section else {
                return Err(config.error(line, "a value before any `[section]`"));
            };
            let key = stripped[..split].trim().to_lowercase();
            let value = stripped[split + 1..].trim().to_string();
            let values = config.sections.entry(name.clone()).or_default();
            match values.get(&key) {
                Some(above) if saved && !above.saved => config.shadowed.push(ShadowedValue {
                    section: name.clone(),
                    key,
                    value,
                    line,
                    used_line: above.line,
                }),
                _ => {
                    values.insert(key, ConfigValue { value, line, saved });
                }
            }
        }
        Ok(config)
    }

    /// An error at `line` of the file.
    fn error(&self, line: usize, message: &str) -> Error {
        Error::Invalid(format!("{}: line {line}: {message}", self.path.display()))
    }

    /// The sections' names, in alphabetical order.
    pub fn section_names(&self) -> impl Iterator<Item = &str> {
        self.sections.keys().map(String::as_str)
    }

    /// Does the file have section `name`?
    pub fn has_section(&self, name: &str) -> bool {
        self.sections.contains_key(name)
    }

    /// The value of `key` in `section` (the SAVE_CONFIG block's if it has one).
    pub fn get(&self, section: &str, key: &str) -> Option<&ConfigValue> {
        self.sections.get(section).and_then(|s| s.get(key))
    }

    /// `key` of `section` as a number, or `None` if absent.
    ///
    /// # Errors
    /// A value that is not a finite number, naming the file, line, section and key.
    pub fn float(&self, section: &str, key: &str) -> Result<Option<f64>> {
        let Some(entry) = self.get(section, key) else {
            return Ok(None);
        };
        match entry.value.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(self.error(
                entry.line,
                &format!(
                    "[{section}] `{key}`: expected a number, found `{}`",
                    entry.value
                ),
            )),
        }
    }

    /// `key` of `section` as a number; its absence is an error saying what it is.
    ///
    /// # Errors
    /// Missing (naming the file, the section's line, the section and the key) or not a number.
    pub fn require_float(&self, section: &str, key: &str, what: &str) -> Result<f64> {
        self.float(section, key)?
            .ok_or_else(|| self.missing(section, key, what))
    }

    /// The error for a missing `key` of `section`.
    pub fn missing(&self, section: &str, key: &str, what: &str) -> Error {
        match self.section_lines.get(section) {
            Some(line) => self.error(
                *line,
                &format!("[{section}]: missing `{key}` ({what}); Klipper needs it and legwise does not guess it"),
            ),
            None => Error::Invalid(format!(
                "{}: no section [{section}]: expected it with `{key}` ({what})",
                self.path.display()
            )),
        }
    }

    /// `key` of `section` as a list of `count` numbers separated by commas.
    ///
    /// # Errors
    /// Not `count` finite numbers, naming the file, line, section and key.
    pub fn floats(&self, section: &str, key: &str, count: usize) -> Result<Option<Vec<f64>>> {
        let Some(entry) = self.get(section, key) else {
            return Ok(None);
        };
        let values: Vec<Option<f64>> = entry
            .value
            .split(',')
            .map(|p| p.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect();
        if values.len() != count || values.iter().any(Option::is_none) {
            return Err(self.error(
                entry.line,
                &format!(
                    "[{section}] `{key}`: expected {count} numbers separated by commas, found `{}`",
                    entry.value
                ),
            ));
        }
        Ok(Some(values.into_iter().flatten().collect()))
    }
}

/// `text` without an inline comment: `#` or `;` at the start or after a blank.
fn strip_comment(text: &str) -> &str {
    let bytes = text.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        if (b == b'#' || b == b';') && (i == 0 || bytes[i - 1] == b' ' || bytes[i - 1] == b'\t') {
            return &text[..i];
        }
    }
    text
}

/// One probe touch of the SAVE_CONFIG block: `heightN = h`, `heightN_pos = a,b,c` (or the
/// `manual_heightN` pair).
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeTouch {
    /// `height0`, `manual_height2`, …: the key, used as the row's id.
    pub id: String,
    /// The nozzle's height above the bed at the touch, mm.
    pub height_mm: f64,
    /// The stable position: steps since each tower's endstop (towers a, b, c).
    pub steps: [f64; 3],
    /// Line of `heightN_pos`.
    pub line: usize,
}

/// The linear delta of a `printer.cfg`, in Klipper's units (mm, degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct KlipperDelta {
    /// `[printer] delta_radius`, mm.
    pub radius: f64,
    /// `[stepper_a|b|c] angle`, degrees (defaults 210, 330, 90).
    pub angles: [f64; 3],
    /// `[stepper_a|b|c] arm_length`, mm (b and c default to a's).
    pub arms: [f64; 3],
    /// `[stepper_a|b|c] position_endstop`, mm (b and c default to a's).
    pub endstops: [f64; 3],
    /// Each tower's step distance, mm per step.
    pub step_distances: [f64; 3],
    /// `[probe] z_offset`, mm, if the file has a probe.
    pub z_offset: Option<f64>,
    /// `[delta_calibrate] radius`, mm, if present.
    pub calibrate_radius: Option<f64>,
    /// The touches of the SAVE_CONFIG `[delta_calibrate]` section, manual heights first.
    pub touches: Vec<ProbeTouch>,
    /// The `DELTA_ANALYZE` distances of the SAVE_CONFIG `[delta_calibrate]` section.
    pub distances: Vec<MeasuredDistance>,
}

/// One measured distance: `distanceN = d`, `distanceN_pos1 = a,b,c`, `distanceN_pos2 = a,b,c`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredDistance {
    /// `distance0`, …: the key.
    pub id: String,
    /// The measured distance between the nozzle's two positions, mm.
    pub distance_mm: f64,
    /// The two stable positions (steps since each tower's endstop).
    pub steps: [[f64; 3]; 2],
}

/// Tower names, in legwise's leg order.
pub const TOWERS: [&str; 3] = ["stepper_a", "stepper_b", "stepper_c"];
/// Klipper's default tower angles, degrees.
pub const DEFAULT_ANGLES: [f64; 3] = [210.0, 330.0, 90.0];

impl KlipperDelta {
    /// The delta described by `config`.
    ///
    /// # Errors
    /// Not a delta (`kinematics` other than `delta`), a missing `delta_radius`, `arm_length`,
    /// `position_endstop`, `rotation_distance` or `microsteps`, a value out of range (a rod
    /// not longer than the radius), or an unreadable touch; each names file, line, section, key.
    pub fn from_config(config: &KlipperConfig) -> Result<Self> {
        match config.get("printer", "kinematics") {
            Some(k) if k.value == "delta" => {}
            Some(k) => {
                return Err(config.error(
                    k.line,
                    &format!(
                        "[printer] `kinematics`: expected `delta`, found `{}`",
                        k.value
                    ),
                ))
            }
            None => return Err(config.missing("printer", "kinematics", "expected `delta`")),
        }
        let radius = config.require_float("printer", "delta_radius", "the tower radius, mm")?;
        positive(config, "printer", "delta_radius", radius)?;
        let arm_a =
            config.require_float("stepper_a", "arm_length", "the diagonal rod length, mm")?;
        let endstop_a = config.require_float(
            "stepper_a",
            "position_endstop",
            "the nozzle's height at the endstops, mm",
        )?;
        let mut angles = DEFAULT_ANGLES;
        let mut arms = [arm_a; 3];
        let mut endstops = [endstop_a; 3];
        let mut step_distances = [0.0; 3];
        for (i, tower) in TOWERS.iter().enumerate() {
            if !config.has_section(tower) {
                return Err(config.missing(tower, "arm_length", "a tower of the delta"));
            }
            angles[i] = config.float(tower, "angle")?.unwrap_or(angles[i]);
            arms[i] = config.float(tower, "arm_length")?.unwrap_or(arm_a);
            endstops[i] = config
                .float(tower, "position_endstop")?
                .unwrap_or(endstop_a);
            if arms[i] <= radius {
                let line = config.get(tower, "arm_length").map_or(0, |v| v.line);
                return Err(config.error(
                    line,
                    &format!(
                        "[{tower}] `arm_length`: expected more than delta_radius {radius} mm, found {} mm",
                        arms[i]
                    ),
                ));
            }
            step_distances[i] = step_distance(config, tower)?;
        }
        let z_offset = config.float("probe", "z_offset")?;
        let calibrate_radius = config.float("delta_calibrate", "radius")?;
        let mut touches = Vec::new();
        for prefix in ["manual_height", "height"] {
            for n in 0.. {
                let key = format!("{prefix}{n}");
                let Some(height) = config.float("delta_calibrate", &key)? else {
                    break;
                };
                let pos_key = format!("{key}_pos");
                let steps = config
                    .floats("delta_calibrate", &pos_key, 3)?
                    .ok_or_else(|| {
                        config.missing(
                            "delta_calibrate",
                            &pos_key,
                            "the stable position of the touch",
                        )
                    })?;
                let line = config
                    .get("delta_calibrate", &pos_key)
                    .map_or(0, |v| v.line);
                touches.push(ProbeTouch {
                    id: key,
                    height_mm: height,
                    steps: [steps[0], steps[1], steps[2]],
                    line,
                });
            }
        }
        let mut distances = Vec::new();
        for n in 0.. {
            let key = format!("distance{n}");
            let Some(distance_mm) = config.float("delta_calibrate", &key)? else {
                break;
            };
            let mut steps = [[0.0; 3]; 2];
            for (k, end) in steps.iter_mut().enumerate() {
                let pos_key = format!("{key}_pos{}", k + 1);
                let v = config
                    .floats("delta_calibrate", &pos_key, 3)?
                    .ok_or_else(|| {
                        config.missing(
                            "delta_calibrate",
                            &pos_key,
                            "a stable position of the distance",
                        )
                    })?;
                *end = [v[0], v[1], v[2]];
            }
            distances.push(MeasuredDistance {
                id: key,
                distance_mm,
                steps,
            });
        }
        Ok(KlipperDelta {
            radius,
            angles,
            arms,
            endstops,
            step_distances,
            z_offset,
            calibrate_radius,
            touches,
            distances,
        })
    }

    /// The firmware-neutral geometry: the touches' and distances' readings are
    /// `−steps × step distance` (mm; 0 at the endstop, negative below it).
    pub fn geometry(&self) -> DeltaGeometry {
        let readings = |steps: &[f64; 3]| -> [f64; 3] {
            std::array::from_fn(|i| -steps[i] * self.step_distances[i])
        };
        DeltaGeometry {
            firmware: Firmware::Klipper,
            radius: self.radius,
            angles: self.angles,
            arms: self.arms,
            endstops: self.endstops,
            tilt: [0.0, 0.0],
            z_offset: self.z_offset,
            calibrate_radius: self.calibrate_radius,
            touches: self
                .touches
                .iter()
                .map(|t| Touch {
                    id: t.id.clone(),
                    height_mm: t.height_mm,
                    readings_mm: readings(&t.steps),
                })
                .collect(),
            distances: self
                .distances
                .iter()
                .map(|d| Distance {
                    id: d.id.clone(),
                    distance_mm: d.distance_mm,
                    readings_mm: [readings(&d.steps[0]), readings(&d.steps[1])],
                })
                .collect(),
            steps_known: true,
        }
    }

    /// Tower `i`'s position in Klipper's frame, mm.
    pub fn tower(&self, i: usize) -> [f64; 2] {
        let a = self.angles[i].to_radians();
        [self.radius * a.cos(), self.radius * a.sin()]
    }

    /// Tower `i`'s carriage height at its endstop, mm: `position_endstop + sqrt(arm² − radius²)`.
    pub fn abs_endstop(&self, i: usize) -> f64 {
        self.endstops[i] + (self.arms[i].powi(2) - self.radius.powi(2)).sqrt()
    }
}

/// A positive value, or an error naming the key.
fn positive(config: &KlipperConfig, section: &str, key: &str, value: f64) -> Result<()> {
    if value > 0.0 {
        return Ok(());
    }
    let line = config.get(section, key).map_or(0, |v| v.line);
    Err(config.error(
        line,
        &format!("[{section}] `{key}`: expected a positive number, found {value}"),
    ))
}

/// A tower's step distance, mm: `rotation_distance / (full_steps_per_rotation × microsteps ×
/// gear_ratio)` (Klipper's rotation-distance convention; `full_steps_per_rotation` defaults to
/// 200, `gear_ratio` to none).
fn step_distance(config: &KlipperConfig, tower: &str) -> Result<f64> {
    let rotation = config.require_float(tower, "rotation_distance", "mm per motor turn")?;
    positive(config, tower, "rotation_distance", rotation)?;
    let microsteps = config.require_float(tower, "microsteps", "microsteps per full step")?;
    positive(config, tower, "microsteps", microsteps)?;
    let full = config
        .float(tower, "full_steps_per_rotation")?
        .unwrap_or(200.0);
    positive(config, tower, "full_steps_per_rotation", full)?;
    let mut gearing = 1.0;
    if let Some(entry) = config.get(tower, "gear_ratio") {
        for pair in entry.value.split(',') {
            let parts: Vec<Option<f64>> = pair
                .split(':')
                .map(|p| p.trim().parse::<f64>().ok().filter(|v| *v > 0.0))
                .collect();
            match parts.as_slice() {
                [Some(a), Some(b)] => gearing *= a / b,
                _ => {
                    return Err(config.error(
                        entry.line,
                        &format!(
                            "[{tower}] `gear_ratio`: expected ratios `a:b, c:d` of positive numbers, found `{}`",
                            entry.value
                        ),
                    ))
                }
            }
        }
    }
    Ok(rotation / (full * microsteps * gearing))
}
