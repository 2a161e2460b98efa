//! Values no real mechanism has, caught before they reach a solver or a grid:
//! * a real-valued field beyond [`MAX_MAGNITUDE`] in magnitude (metres, radians or a gain) is an
//!   error naming the field, instead of a failure far away (a rank deficiency, an infinite
//!   grid);
//! * an angle beyond ±2π rad (a revolute joint's home value or actuator offset, an orientation
//!   of the home pose, of a workspace range or of the instrument frame, and a URDF joint
//!   origin's `rpy` in a leg's chain) is accepted with a warning: degrees instead of radians?
//!   The measurement checks apply the same rule to readings.
//!
//! [`Mechanism::refused_value`] applies the rules the loader applies to a parameter's value
//! (its magnitude, a gain's, a length's distance from nominal) to any value, such as an
//! identified one: an estimate the model itself would refuse is not a calibration.

use std::f64::consts::TAU;

use serde_json::Value;

use super::scale::mechanism_size;
use super::Builder;
use crate::error::Result;
use crate::model::file::ModelFile;
use crate::model::leg::LegModel;
use crate::model::params::Unit;
use crate::model::Mechanism;

/// Largest magnitude of a real value in a model file: a million metres, radians or gain.
pub(super) const MAX_MAGNITUDE: f64 = 1e6;

/// Smallest gain magnitude accepted: the reciprocal of the largest value a model file may hold
/// (a gain of 1e-300 makes every reading 1e300 times the joint's motion, and the solvers
/// never recover from it).
pub(super) const MIN_GAIN: f64 = 1.0 / MAX_MAGNITUDE;

/// Why a gain below [`MIN_GAIN`] in magnitude is refused.
pub(super) fn tiny_gain(gain: f64) -> String {
    format!(
        "{gain:e} is not a plausible gain: legwise expects gains of magnitude {MIN_GAIN:e} to \
         1e6 (about ±1 for readings converted to radians or metres)"
    )
}

/// The pose components that are angles.
const ANGLES: [&str; 3] = ["roll", "pitch", "yaw"];

impl Builder<'_> {
    /// Refuses the first real value of `file` beyond [`MAX_MAGNITUDE`] (whole numbers such as
    /// the seed or counts are checked where they are read).
    pub(super) fn magnitudes(&self, file: &ModelFile) -> Result<()> {
        // The file as a tree of values: every field with its path, whatever its type.
        let tree = serde_json::to_value(file).unwrap_or(Value::Null);
        match beyond(&tree, String::new()) {
            Some((field, value)) => Err(self.error(field, too_large(value).unwrap_or_default())),
            None => Ok(()),
        }
    }
}

/// Why the loader refuses `value`, of magnitude beyond [`MAX_MAGNITUDE`] (the text of
/// [`Builder::magnitudes`]).
fn too_large(value: f64) -> Option<String> {
    (value.abs() > MAX_MAGNITUDE).then(|| {
        format!(
            "{value:e} is not a plausible value; legwise reads metres, radians and gains, and \
             expects magnitudes up to {MAX_MAGNITUDE:e}"
        )
    })
}

/// Why the loader refuses the length `value` (metres), more than the mechanism's size `size`
/// from its nominal value `nominal` (the rule of `simulation.real`).
pub(super) fn far_from_nominal(value: f64, nominal: f64, size: f64) -> Option<String> {
    ((value - nominal).abs() > size).then(|| {
        format!(
            "{value} m is {} m from the nominal value {nominal} m, more than the mechanism's \
             size ({size:.3} m): millimetres instead of metres?",
            (value - nominal).abs()
        )
    })
}

impl Mechanism {
    /// Why the model loader would refuse `value` for a parameter of unit `unit` and nominal
    /// value `nominal` (`None`: it would load): a magnitude beyond [`MAX_MAGNITUDE`], a gain (the
    /// one dimensionless kind of parameter) below 1e-6 in magnitude, a length more than the
    /// mechanism's size (its longest leg) from its nominal value. Non-finite values are left
    /// to the caller.
    pub fn refused_value(&self, unit: Unit, nominal: f64, value: f64) -> Option<String> {
        if !value.is_finite() {
            return None;
        }
        too_large(value).or_else(|| match unit {
            Unit::One => (value.abs() < MIN_GAIN).then(|| tiny_gain(value)),
            Unit::Metre => far_from_nominal(value, nominal, mechanism_size(&self.legs)),
            Unit::Radian => None,
        })
    }
}

/// The first real number of `tree` (at path `path`) beyond [`MAX_MAGNITUDE`], with its path.
fn beyond(tree: &Value, path: String) -> Option<(String, f64)> {
    let join = |key: &str| match path.as_str() {
        "" => key.to_string(),
        _ => format!("{path}.{key}"),
    };
    match tree {
        Value::Number(n) if n.is_f64() => n
            .as_f64()
            .filter(|v| v.abs() > MAX_MAGNITUDE)
            .map(|v| (path, v)),
        Value::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, item)| beyond(item, format!("{path}[{i}]"))),
        Value::Object(fields) => fields
            .iter()
            .find_map(|(key, item)| beyond(item, join(key))),
        _ => None,
    }
}

impl Builder<'_> {
    /// The warnings for the angles of `file` beyond ±2π rad (`legs` built from it), each
    /// naming the model file and the field.
    pub(super) fn degree_warnings(&self, file: &ModelFile, legs: &[LegModel]) -> Vec<String> {
        degree_warnings(file, legs)
            .into_iter()
            .map(|warning| format!("{}: {warning}", self.path.display()))
            .collect()
    }
}

impl Builder<'_> {
    /// The warnings for the origin angles (`rpy`) of the legs' URDF joints beyond ±2π rad,
    /// each naming the URDF and the joint: `rpy="0 0 90"` turned a joint's frame by 90 rad
    /// without a word.
    pub(super) fn urdf_degree_warnings(&self, legs: &[LegModel]) -> Vec<String> {
        let mut warnings = Vec::new();
        for joint in legs.iter().flat_map(|leg| &leg.joints) {
            for (k, angle) in ANGLES.iter().enumerate() {
                let value = joint.origin[3 + k];
                if value.abs() > TAU {
                    warnings.push(format!(
                        "{}: joint `{}`: <origin rpy> {angle} {value} rad is beyond ±2π: an angle \
                         in degrees instead of radians? (every angle of a URDF is in radians)",
                        self.urdf_path.display(),
                        joint.name
                    ));
                }
            }
        }
        warnings
    }
}

/// The warnings for the angles of `file` beyond ±2π rad (`legs` built from it).
fn degree_warnings(file: &ModelFile, legs: &[LegModel]) -> Vec<String> {
    let mut angles: Vec<(String, f64)> = Vec::new();
    let orientation = |prefix: &str, pose: &std::collections::BTreeMap<String, f64>| {
        pose.iter()
            .filter(|(name, _)| ANGLES.contains(&name.as_str()))
            .map(|(name, &v)| (format!("{prefix}.{name}"), v))
            .collect::<Vec<_>>()
    };
    angles.extend(orientation("home.pose", &file.home.pose));
    for (l, (leg, entry)) in legs.iter().zip(&file.legs).enumerate() {
        if leg.actuated_is_revolute() {
            angles.push((format!("legs[{l}].actuator.offset"), leg.offset));
        }
        for (name, &value) in &entry.home {
            let joint = leg.joints.iter().find(|j| &j.name == name);
            if joint.is_some_and(|j| j.kind == crate::model::joint::JointKind::Revolute) {
                angles.push((format!("legs[{l}].home.{name}"), value));
            }
        }
    }
    for (name, range) in file.workspace.ranges.iter() {
        if ANGLES.contains(&name.as_str()) {
            let widest = if range[0].abs() > range[1].abs() {
                range[0]
            } else {
                range[1]
            };
            angles.push((format!("workspace.ranges.{name}"), widest));
        }
    }
    if let Some(instrument) = &file.instrument {
        angles.extend(orientation("instrument.frame.pose", &instrument.frame.pose));
    }
    angles
        .into_iter()
        .filter(|(_, v)| v.abs() > TAU)
        .map(|(field, v)| {
            format!(
                "{field}: {v} rad is beyond ±2π: an angle in degrees instead of radians? (every \
                 angle of a model file is in radians)"
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use serde_json::json;

    use super::{beyond, mechanism_size, MAX_MAGNITUDE};
    use crate::model::params::Unit;
    use crate::model::Mechanism;

    #[test]
    fn a_value_is_refused_by_the_loader_s_rules_only_beyond_their_limits() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/5r.yaml");
        let m = Mechanism::load(Path::new(path)).unwrap();
        let size = mechanism_size(&m.legs);
        // Magnitude: any kind, up to 1e6.
        assert_eq!(m.refused_value(Unit::Radian, 0.0, -MAX_MAGNITUDE), None);
        let large = m.refused_value(Unit::Radian, 0.0, 1.5e6).unwrap();
        assert!(
            large.starts_with("1.5e6 is not a plausible value"),
            "{large}"
        );
        // A gain: at least 1e-6 in magnitude, either sign.
        assert_eq!(m.refused_value(Unit::One, 1.0, -1e-6), None);
        let tiny = m.refused_value(Unit::One, 1.0, 9e-7).unwrap();
        assert!(tiny.starts_with("9e-7 is not a plausible gain"), "{tiny}");
        // A length: within the mechanism's size of its nominal value.
        assert_eq!(m.refused_value(Unit::Metre, 0.0, size), None);
        let far = m.refused_value(Unit::Metre, 0.0, -1.01 * size).unwrap();
        assert!(far.ends_with("millimetres instead of metres?"), "{far}");
        assert_eq!(m.refused_value(Unit::Radian, 0.0, -1.01 * size), None);
        // Non-finite values are named elsewhere.
        assert_eq!(m.refused_value(Unit::One, 1.0, f64::NAN), None);
    }

    #[test]
    fn a_value_is_absurd_only_beyond_the_largest_magnitude_and_is_named_by_its_path() {
        let at_limit = json!({"home": {"pose": {"x": MAX_MAGNITUDE, "y": -MAX_MAGNITUDE}}});
        assert_eq!(beyond(&at_limit, String::new()), None);
        let over = json!({"legs": [{"home": {"A1": 0.5}}, {"home": {"A2": -1.5e6}}]});
        assert_eq!(
            beyond(&over, String::new()),
            Some(("legs[1].home.A2".to_string(), -1.5e6))
        );
        // Integers are counts and seeds, not measures: never absurd by size.
        assert_eq!(
            beyond(&json!({"seed": 9_000_000_000_u64}), String::new()),
            None
        );
    }
}
