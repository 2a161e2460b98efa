//! Plausibility checks of a measurement set, before any fit: values far outside what the
//! mechanism can produce, and rows entered twice.
//!
//! * A position farther from the home pose than [`SIZE_FACTOR`] × the mechanism's size (the
//!   longest chain of joint offsets plus the attachment, or the workspace region's extent,
//!   whichever is larger) is an **error** naming the line and column: no leg can reach it, so
//!   the fit would fail anyway, only without the hint (millimetres?).
//! * An orientation (`roll`, `pitch`, `yaw`) beyond ±2π, a revolute reading whose joint value
//!   (`gain · reading + offset`, nominal) lies more than 2π from the joint's home value, or a
//!   prismatic reading whose joint value is larger than [`SIZE_FACTOR`] × the size, is a
//!   **warning**: an unwrapped orientation or an odd actuator model can be legitimate, and the
//!   decisive evidence about units is the fit itself (the residuals' noise test makes a
//!   wrong-unit result untrusted, exit 3). One warning per column, naming the first and the
//!   largest offending line.
//! * Two rows or more with the same leg label, pose and readings: one **warning** naming the
//!   first and its copies (the same measurement counted twice makes the standard deviations √2
//!   too small).

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::hash::{DefaultHasher, Hasher};

use rayon::prelude::*;

use super::MeasurementSet;
use crate::error::{Error, Result};
use crate::model::leg::LegModel;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;

/// A position or a prismatic reading this many times the mechanism's size is implausible.
pub const SIZE_FACTOR: f64 = 100.0;

/// The mechanism's size, metres: the longest leg (sum of its joints' offsets plus the
/// attachment) or the workspace region's extent, whichever is larger.
pub fn mechanism_size(mechanism: &Mechanism) -> f64 {
    let reach = mechanism
        .legs
        .iter()
        .map(|leg| {
            let chain: f64 = leg
                .joints
                .iter()
                .map(|j| (j.origin[0].powi(2) + j.origin[1].powi(2) + j.origin[2].powi(2)).sqrt())
                .sum();
            chain + leg.attachment.iter().map(|a| a * a).sum::<f64>().sqrt()
        })
        .fold(0.0, f64::max);
    let (low, high) = mechanism.workspace.region.bounds();
    let extent = ((high[0] - low[0]).powi(2) + (high[1] - low[1]).powi(2)).sqrt();
    reach.max(extent)
}

/// `value` as written, or in scientific notation when it is huge or tiny (1e308 is not 309
/// digits).
pub(super) fn compact(value: f64) -> String {
    if value == 0.0 || (1e-4..1e15).contains(&value.abs()) {
        value.to_string()
    } else {
        format!("{value:e}")
    }
}

/// Offending values of one column: count, first line and value, largest line and value.
#[derive(Clone, Default)]
struct Offenders {
    count: usize,
    first: Option<(Option<usize>, f64)>,
    largest: Option<(Option<usize>, f64)>,
}

impl Offenders {
    fn add(&mut self, line: Option<usize>, value: f64) {
        self.count += 1;
        self.first.get_or_insert((line, value));
        if self.largest.is_none_or(|(_, v)| value.abs() > v.abs()) {
            self.largest = Some((line, value));
        }
    }

    fn describe(&self) -> String {
        let at = |(line, value): (Option<usize>, f64)| match line {
            Some(line) => format!("{} at line {line}", compact(value)),
            None => format!("{} in a simulated row", compact(value)),
        };
        let first = self.first.map(at).unwrap_or_default();
        let largest = self.largest.map(at).unwrap_or_default();
        if self.count == 1 {
            first
        } else {
            format!("{} values, first {first}, largest {largest}", self.count)
        }
    }
}

/// The warnings about `data` for `mechanism` (empty when every value is plausible).
///
/// # Errors
/// A measured position [`SIZE_FACTOR`] times farther than the mechanism's size from the home
/// pose ([`Error::Measurement`] naming the line and column, or [`Error::Invalid`] for a
/// simulated pose).
pub fn check(mechanism: &Mechanism, data: &MeasurementSet) -> Result<Vec<String>> {
    let mut warnings = range_warnings(mechanism, data)?;
    warnings.extend(duplicate_warnings(mechanism, data));
    Ok(warnings)
}

/// Whether `value`, a raw reading of `leg`'s actuated joint, puts the joint where it cannot be:
/// through the nominal actuator model (gain · reading + offset: a geared reading may pass ±2π
/// while its joint does not), a revolute joint more than 2π from its home value, a prismatic
/// one beyond `limit` ([`SIZE_FACTOR`] times the mechanism's size, [`mechanism_size`]).
pub fn reading_out_of_range(leg: &LegModel, value: f64, limit: f64) -> bool {
    let joint = leg.gain * value + leg.offset;
    if leg.actuated_is_revolute() {
        (joint - leg.home_joints[leg.actuated]).abs() > TAU
    } else {
        joint.abs() > limit
    }
}

fn range_warnings(mechanism: &Mechanism, data: &MeasurementSet) -> Result<Vec<String>> {
    let size = mechanism_size(mechanism);
    let limit = SIZE_FACTOR * size;
    let home = mechanism.home_pose;
    let mut coordinates = vec![Offenders::default(); 6];
    let mut readings = vec![Offenders::default(); mechanism.legs.len()];
    for (pose, pose_readings) in data.rows() {
        for &c in &mechanism.measured {
            let value = pose.pose[c];
            if c < 3 && (value - home[c]).abs() > limit {
                let name = COORDINATES[c];
                let message = format!(
                    "{} m is more than {SIZE_FACTOR} times the mechanism's size \
                     ({size:.3} m) from the home pose ({} m): positions in millimetres instead \
                     of metres?",
                    compact(value),
                    home[c]
                );
                return Err(match (&data.source, pose.line) {
                    (Some(path), Some(line)) => Error::Measurement {
                        path: path.clone(),
                        location: format!("line {line}, column `{name}`"),
                        message,
                    },
                    _ => Error::Invalid(format!("simulated pose, `{name}`: {message}")),
                });
            }
            if c >= 3 && value.abs() > TAU {
                coordinates[c].add(pose.line, value);
            }
        }
        for (l, reading) in pose_readings.iter().enumerate() {
            let Some(value) = *reading else { continue };
            if reading_out_of_range(&mechanism.legs[l], value, limit) {
                readings[l].add(pose.line, value);
            }
        }
    }
    let mut warnings = Vec::new();
    for &c in &mechanism.measured {
        let offenders = &coordinates[c];
        if offenders.count == 0 {
            continue;
        }
        warnings.push(format!(
            "column `{}`: {} beyond ±2π rad: an orientation in degrees instead of radians?",
            COORDINATES[c],
            offenders.describe()
        ));
    }
    for (name, (leg, offenders)) in mechanism
        .actuated_names()
        .iter()
        .zip(mechanism.legs.iter().zip(&readings))
        .filter(|(_, (_, offenders))| offenders.count > 0)
    {
        warnings.push(if leg.actuated_is_revolute() {
            format!(
                "column `{name}`: revolute reading {} puts the joint (gain · reading + offset) \
                 more than 2π from its home value {} rad: readings in degrees instead of radians?",
                offenders.describe(),
                leg.home_joints[leg.actuated]
            )
        } else {
            format!(
                "column `{name}`: prismatic reading {} puts the joint (gain · reading + offset) \
                 beyond {SIZE_FACTOR} times the mechanism's size ({size:.3} m): readings in \
                 millimetres instead of metres?",
                offenders.describe()
            )
        });
    }
    Ok(warnings)
}

fn duplicate_warnings(mechanism: &Mechanism, data: &MeasurementSet) -> Vec<String> {
    // The key of a row: its leg label, measured coordinates and readings, bit for bit.
    let poses = data.poses();
    let key = |index: usize| {
        let pose = &poses[index];
        let leg = pose.leg.map_or(u64::MAX, |l| l as u64);
        let coordinates = mechanism.measured.iter().map(|&c| pose.pose[c].to_bits());
        let readings = data
            .readings(index)
            .iter()
            .map(|r| r.map_or(u64::MAX - 1, f64::to_bits));
        std::iter::once(leg).chain(coordinates).chain(readings)
    };
    // Rows sorted by a hash of their key, then by index (parallel, no per-row allocation):
    // equal keys are in one run of equal hashes, in file order; a run's rows are compared by
    // their keys (two different keys may share a hash).
    let mut order: Vec<(u64, usize)> = (0..poses.len())
        .into_par_iter()
        .map(|index| {
            let mut hasher = DefaultHasher::new();
            key(index).for_each(|word| hasher.write_u64(word));
            (hasher.finish(), index)
        })
        .collect();
    order.par_sort_unstable();
    let mut repeats: Vec<(usize, usize)> = Vec::new();
    for run in order
        .chunk_by(|a, b| a.0 == b.0)
        .filter(|run| run.len() > 1)
    {
        for (k, &(_, index)) in run.iter().enumerate().skip(1) {
            let first = run[..k]
                .iter()
                .map(|&(_, earlier)| earlier)
                .find(|&earlier| key(earlier).eq(key(index)));
            if let Some(first) = first {
                repeats.push((index, first));
            }
        }
    }
    // One warning per repeated row, listing its copies (a file of one row pasted 100 000
    // times gave 100 000 warnings).
    let mut copies: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (index, first) in repeats {
        copies.entry(first).or_default().push(index);
    }
    let mut groups: Vec<(usize, Vec<usize>)> = copies.into_iter().collect();
    for (_, indices) in &mut groups {
        indices.sort_unstable();
    }
    groups.sort_unstable_by_key(|(_, indices)| indices[0]);
    let place = |i: usize| {
        poses[i]
            .line
            .map_or(format!("simulated row {}", i + 1), |l| format!("line {l}"))
    };
    groups
        .into_iter()
        .map(|(first, indices)| {
            let shown: Vec<String> = indices.iter().take(3).map(|&i| place(i)).collect();
            let (copies, verb) = match indices.len() {
                1 => (shown[0].clone(), "repeats"),
                n if n <= 3 => (shown.join(", "), "repeat"),
                n => (
                    format!("{} and {} more rows", shown.join(", "), n - 3),
                    "repeat",
                ),
            };
            format!(
                "{copies} {verb} {} exactly (same leg, pose and readings): a measurement counted \
                 more than once makes the standard deviations too small; keep one of them",
                place(first)
            )
        })
        .collect()
}
