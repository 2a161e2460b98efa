//! The `instrument` block: the instrument frame and the targets, checked against the measured
//! coordinates (does the platform rotate?) and the legs' parameter names.

use std::collections::HashSet;

use super::scale::mechanism_size;
use super::Builder;
use crate::error::Result;
use crate::model::instrument::{
    Distances, Instrument, InstrumentEntry, Measures, MeasuresEntry, SharedParameter, Target,
    PLANAR_FRAME, PLANAR_OFFSET, SPATIAL_FRAME, SPATIAL_OFFSET,
};
use crate::model::leg::LegModel;
use crate::model::mechanism::MAX_POSES_PER_LEG;
use crate::model::params::Unit;

impl Builder<'_> {
    /// The validated instrument, if the model has the block. A model whose measured
    /// coordinates are among `x y yaw` is planar (3-DoF frame, 2-D offsets), any other is
    /// spatial (6-DoF frame, 3-D offsets).
    pub(super) fn instrument(
        &self,
        entry: Option<&InstrumentEntry>,
        measured: &[usize],
        legs: &[LegModel],
    ) -> Result<Option<Instrument>> {
        let Some(entry) = entry else {
            return Ok(None);
        };
        let spatial = measured.iter().any(|c| !matches!(c, 0 | 1 | 5));
        let rotates = measured.iter().any(|&c| c >= 3);
        let (frame_components, offset_components): (&[&str], &[&str]) = if spatial {
            (&SPATIAL_FRAME, &SPATIAL_OFFSET)
        } else {
            (&PLANAR_FRAME, &PLANAR_OFFSET)
        };
        let forward = match entry.kinematics.as_deref() {
            None | Some("inverse") => false,
            Some("forward") => true,
            Some(other) => {
                return Err(self.error(
                    "instrument.kinematics",
                    format!("`{other}` is not one of inverse, forward"),
                ))
            }
        };
        let mut parameters = self.frame(entry, frame_components)?;
        self.frame_scale(&parameters, legs)?;
        if let Some(length) = entry.frame.perturbation.map(|p| p.length) {
            let field = "instrument.frame.perturbation.length";
            self.within_size(field, "a standard deviation", length, legs)?;
        }
        let mut targets = Vec::new();
        let several = entry.targets.len() > 1;
        let mut offsets = Vec::new();
        for (k, target) in entry.targets.iter().enumerate() {
            let field = format!("instrument.targets[{k}]");
            let name = target.name.as_str();
            if name.is_empty() || name.contains(|c: char| c.is_whitespace() || c == ',' || c == '"')
            {
                return Err(self.error(
                    format!("{field}.name"),
                    format!(
                        "`{name}` cannot name measurement columns: expected a non-empty name \
                         without spaces, commas or quotes"
                    ),
                ));
            }
            if targets.iter().any(|t: &Target| t.name == name) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!("target `{name}` is defined twice"),
                ));
            }
            let measures = self.measures(&field, &target.measures, spatial, forward)?;
            if measures == Measures::Pose && !rotates {
                let which = if spatial {
                    "none of roll, pitch, yaw is measured"
                } else {
                    "yaw is not measured"
                };
                return Err(self.error(
                    format!("{field}.measures"),
                    format!(
                        "the platform does not rotate ({which}): its targets are measured by \
                         `position`"
                    ),
                ));
            }
            if target.offset.len() != offset_components.len() {
                return Err(self.error(
                    format!("{field}.offset"),
                    format!(
                        "expected [{}] ({} values, metres), found {} values",
                        offset_components.join(", "),
                        offset_components.len(),
                        target.offset.len()
                    ),
                ));
            }
            if let Some(value) = target.offset.iter().find(|v| !v.is_finite()) {
                return Err(self.error(
                    format!("{field}.offset"),
                    format!("expected finite numbers (metres), found {value}"),
                ));
            }
            let reach = target.offset.iter().map(|v| v * v).sum::<f64>().sqrt();
            self.within_size(&format!("{field}.offset"), "an offset", reach, legs)?;
            let identified = self.components(
                &format!("{field}.identify"),
                target.identify.as_deref(),
                offset_components,
            )?;
            let sigma = target.perturbation.unwrap_or(0.0);
            if !(sigma.is_finite() && sigma >= 0.0) {
                return Err(self.error(
                    format!("{field}.perturbation"),
                    format!("expected a non-negative standard deviation (metres), found {sigma}"),
                ));
            }
            let what = "a standard deviation";
            self.within_size(&format!("{field}.perturbation"), what, sigma, legs)?;
            for (c, component) in offset_components.iter().enumerate() {
                let suffix = if several {
                    format!("_{name}")
                } else {
                    String::new()
                };
                parameters.push(SharedParameter {
                    name: format!("target_{component}{suffix}"),
                    nominal: target.offset[c],
                    identified: identified[c],
                    unit: Unit::Metre,
                    perturbation: sigma,
                });
            }
            offsets.push((
                measures,
                [
                    target.offset[0],
                    target.offset[1],
                    target.offset.get(2).copied().unwrap_or(0.0),
                ],
            ));
            if let Some(touch) = target.touch {
                let single =
                    matches!(measures, Measures::Coordinates(mask) if mask.count_ones() == 1);
                if !single || !touch.is_finite() {
                    return Err(self.error(
                        format!("{field}.touch"),
                        format!(
                            "expected a finite value (metres) of a target that measures one \
                             coordinate (`measures: [z]`), found {touch} on a target measuring \
                             {:?}",
                            target.measures
                        ),
                    ));
                }
                self.within_size(
                    &format!("{field}.touch"),
                    "a touch value",
                    touch.abs(),
                    legs,
                )?;
            }
            targets.push(Target {
                name: name.to_string(),
                measures,
                spatial,
                touch: target.touch,
            });
        }
        if targets.is_empty() {
            return Err(self.error(
                "instrument.targets",
                "expected at least one target the instrument measures",
            ));
        }
        if forward {
            // The pose comes from the readings: the targets need not give it.
        } else if spatial {
            self.spatial_orientation_observable(rotates, &offsets, &targets)?;
        } else {
            self.orientation_observable(rotates, &offsets, &targets)?;
        }
        let mut names = HashSet::new();
        for parameter in &parameters {
            if !names.insert(parameter.name.as_str()) {
                return Err(self.error(
                    "instrument.targets",
                    format!(
                        "two targets give the parameter name `{}`: rename one",
                        parameter.name
                    ),
                ));
            }
            if legs
                .iter()
                .any(|l| l.params.iter().any(|p| p.name == parameter.name))
            {
                return Err(self.error(
                    "parameters",
                    format!(
                        "`{}` names an instrument parameter: rename the leg parameter",
                        parameter.name
                    ),
                ));
            }
        }
        let distances = self.distances(entry, forward, &targets)?;
        if let Some(d) = &distances {
            let field = "instrument.distances.noise";
            self.within_size(field, "a standard deviation", d.noise, legs)?;
            self.at_most("instrument.distances.simulate", d.simulate)?;
        }
        let poses = self.measured_poses(entry, forward, measured)?;
        if let Some(p) = &poses {
            self.at_most("instrument.poses.simulate", p.simulate)?;
        }
        let tolerance = match entry.tolerance {
            None => None,
            Some(t) if forward && t.is_finite() && t > 0.0 => Some(t),
            Some(t) => {
                return Err(self.error(
                    "instrument.tolerance",
                    format!(
                        "expected a positive length (metres) of a model seen through the \
                         forward kinematics (`kinematics: forward`), found {t}"
                    ),
                ))
            }
        };
        if let Some(t) = tolerance {
            self.within_size("instrument.tolerance", "a tolerance", t, legs)?;
        }
        Ok(Some(Instrument {
            parameters,
            targets,
            rotates,
            spatial,
            forward,
            distances,
            poses,
            tolerance,
        }))
    }

    /// A length of the instrument block (`what`, with its article; metres, at `field`) held to the mechanism's
    /// size (its longest leg), as `simulation.perturbation.length` is: a touch value, an offset
    /// or a tolerance written in millimetres (`touch: 2.0`, `tolerance: 100`) passed without a
    /// word.
    fn within_size(&self, field: &str, what: &str, value: f64, legs: &[LegModel]) -> Result<()> {
        let size = mechanism_size(legs);
        if size > 0.0 && value > size {
            return Err(self.error(
                field,
                format!(
                    "{what} of {value} m is more than the mechanism's size ({size:.3} m): \
                     millimetres instead of metres? (every length of a model file is in metres)"
                ),
            ));
        }
        Ok(())
    }

    /// A simulation count of the instrument block (at `field`) held to
    /// [`MAX_POSES_PER_LEG`], as the simulation's own counts are.
    fn at_most(&self, field: &str, count: usize) -> Result<()> {
        if count > MAX_POSES_PER_LEG {
            return Err(self.error(
                field,
                format!("expected at most {MAX_POSES_PER_LEG} (as every simulated count), found {count}"),
            ));
        }
        Ok(())
    }

    /// The `distances` block: forward only, a known target, a positive noise.
    fn distances(
        &self,
        entry: &InstrumentEntry,
        forward: bool,
        targets: &[Target],
    ) -> Result<Option<Distances>> {
        let Some(distances) = &entry.distances else {
            return Ok(None);
        };
        if !forward {
            return Err(self.error(
                "instrument.distances",
                "distances between rows are predicted through the forward kinematics: set \
                 `instrument.kinematics: forward`",
            ));
        }
        let Some(target) = targets.iter().position(|t| t.name == distances.target) else {
            let names: Vec<&str> = targets.iter().map(|t| t.name.as_str()).collect();
            return Err(self.error(
                "instrument.distances.target",
                format!(
                    "`{}` is not a target; expected one of {}",
                    distances.target,
                    names.join(", ")
                ),
            ));
        };
        if !(distances.noise.is_finite() && distances.noise > 0.0) {
            return Err(self.error(
                "instrument.distances.noise",
                format!(
                    "expected a positive standard deviation (metres), found {}",
                    distances.noise
                ),
            ));
        }
        Ok(Some(Distances {
            target,
            noise: distances.noise,
            simulate: distances.simulate,
        }))
    }

    /// A target's `measures`: `position`, `pose`, or (forward kinematics only) a list of its
    /// position coordinates.
    fn measures(
        &self,
        field: &str,
        entry: &MeasuresEntry,
        spatial: bool,
        forward: bool,
    ) -> Result<Measures> {
        let field = format!("{field}.measures");
        let list = match entry {
            MeasuresEntry::Word(word) => {
                return match word.as_str() {
                    "position" => Ok(Measures::Position),
                    "pose" => Ok(Measures::Pose),
                    other => Err(self.error(
                        field,
                        format!(
                            "`{other}` is not one of position, pose, or a list of coordinates \
                             such as [z]"
                        ),
                    )),
                };
            }
            MeasuresEntry::Coordinates(list) => list,
        };
        let allowed: &[&str] = if spatial {
            &["x", "y", "z"]
        } else {
            &["x", "y"]
        };
        let mut mask = 0u8;
        for (i, name) in list.iter().enumerate() {
            let Some(c) = allowed.iter().position(|a| a == name) else {
                return Err(self.error(
                    format!("{field}[{i}]"),
                    format!(
                        "`{name}` is not a position coordinate of a {} target; expected some of \
                         {}",
                        if spatial { "spatial" } else { "planar" },
                        allowed.join(", ")
                    ),
                ));
            };
            if mask & (1 << c) != 0 {
                return Err(
                    self.error(format!("{field}[{i}]"), format!("`{name}` is listed twice"))
                );
            }
            mask |= 1 << c;
        }
        if mask == 0 {
            return Err(self.error(field, "expected at least one coordinate, such as [z]"));
        }
        if !forward {
            return Err(self.error(
                field,
                "a list of coordinates does not give the platform's pose: set \
                 `instrument.kinematics: forward` (the pose then comes from the readings), or \
                 measure the target's `position`",
            ));
        }
        Ok(Measures::Coordinates(mask))
    }

    /// The frame's shared parameters, one per component of `components` (planar or spatial).
    fn frame(&self, entry: &InstrumentEntry, components: &[&str]) -> Result<Vec<SharedParameter>> {
        let frame = &entry.frame;
        let kind = if components.len() == SPATIAL_FRAME.len() {
            "spatial"
        } else {
            "planar"
        };
        let mut nominal = vec![0.0; components.len()];
        for (key, &value) in &frame.pose {
            let Some(c) = components.iter().position(|c| c == key) else {
                return Err(self.error(
                    format!("instrument.frame.pose.{key}"),
                    format!(
                        "`{key}` is not a component of a {kind} frame; expected one of {}",
                        components.join(", ")
                    ),
                ));
            };
            if !value.is_finite() {
                return Err(self.error(
                    format!("instrument.frame.pose.{key}"),
                    format!("expected a finite number, found {value}"),
                ));
            }
            nominal[c] = value;
        }
        let identified = self.components(
            "instrument.frame.identify",
            frame.identify.as_deref(),
            components,
        )?;
        let (length, angle) = frame
            .perturbation
            .map_or((0.0, 0.0), |p| (p.length, p.angle));
        for (what, value) in [("length", length), ("angle", angle)] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(self.error(
                    format!("instrument.frame.perturbation.{what}"),
                    format!("expected a non-negative standard deviation, found {value}"),
                ));
            }
        }
        Ok(components
            .iter()
            .enumerate()
            .map(|(c, component)| {
                let angular = matches!(*component, "roll" | "pitch" | "yaw");
                SharedParameter {
                    name: format!("frame_{component}"),
                    nominal: nominal[c],
                    identified: identified[c],
                    unit: if angular { Unit::Radian } else { Unit::Metre },
                    perturbation: if angular { angle } else { length },
                }
            })
            .collect())
    }

    /// Which of `allowed` an `identify` list names (all of them if it is absent).
    fn components(
        &self,
        field: &str,
        list: Option<&[String]>,
        allowed: &[&str],
    ) -> Result<Vec<bool>> {
        let Some(list) = list else {
            return Ok(vec![true; allowed.len()]);
        };
        let mut identified = vec![false; allowed.len()];
        for (i, name) in list.iter().enumerate() {
            let Some(c) = allowed.iter().position(|a| a == name) else {
                return Err(self.error(
                    format!("{field}[{i}]"),
                    format!("`{name}` is not one of {}", allowed.join(", ")),
                ));
            };
            if identified[c] {
                return Err(
                    self.error(format!("{field}[{i}]"), format!("`{name}` is listed twice"))
                );
            }
            identified[c] = true;
        }
        Ok(identified)
    }

    /// A rotating platform's orientation must follow from every row: a pose target, or two
    /// position-only targets at distinct offsets.
    fn orientation_observable(
        &self,
        rotates: bool,
        offsets: &[(Measures, [f64; 3])],
        targets: &[Target],
    ) -> Result<()> {
        if !rotates || offsets.iter().any(|(m, _)| *m == Measures::Pose) {
            return Ok(());
        }
        if offsets.len() < 2 {
            return Err(self.error(
                "instrument.targets",
                format!(
                    "the platform rotates (yaw is measured), but the single position-only \
                     target `{}` does not give its orientation: add a second position-only \
                     target at another offset, or measure the target's pose (`measures: pose`)",
                    targets[0].name
                ),
            ));
        }
        let first = offsets[0].1;
        let apart = |o: &[f64; 3]| (o[0] - first[0]).hypot(o[1] - first[1]) > 1e-9;
        if !offsets.iter().any(|(_, offset)| apart(offset)) {
            return Err(self.error(
                "instrument.targets",
                format!(
                    "targets `{}` and `{}` have the same offset: their positions do not give \
                     the platform's orientation; place them apart",
                    targets[0].name, targets[1].name
                ),
            ));
        }
        Ok(())
    }

    /// A rotating spatial platform's orientation must follow from every row: a pose target,
    /// or three position-only targets whose offsets are not on one line.
    fn spatial_orientation_observable(
        &self,
        rotates: bool,
        offsets: &[(Measures, [f64; 3])],
        targets: &[Target],
    ) -> Result<()> {
        if !rotates || offsets.iter().any(|(m, _)| *m == Measures::Pose) {
            return Ok(());
        }
        let names = targets
            .iter()
            .map(|t| format!("`{}`", t.name))
            .collect::<Vec<_>>()
            .join(", ");
        if offsets.len() < 3 {
            return Err(self.error(
                "instrument.targets",
                format!(
                    "the platform rotates (roll, pitch or yaw is measured), but the position-only \
                     targets {names} do not give its orientation: add position-only targets up \
                     to three, not on one line, or measure a target's pose (`measures: pose`)"
                ),
            ));
        }
        let first = nalgebra::Vector3::from(offsets[0].1);
        let relative: Vec<_> = offsets
            .iter()
            .map(|(_, o)| nalgebra::Vector3::from(*o) - first)
            .collect();
        let far = relative
            .iter()
            .max_by(|a, b| a.norm().total_cmp(&b.norm()))
            .copied()
            .unwrap_or_default();
        let off_line = far.norm() > 1e-9
            && relative
                .iter()
                .any(|r| far.normalize().cross(r).norm() > 1e-9);
        if !off_line {
            return Err(self.error(
                "instrument.targets",
                format!(
                    "the offsets of the position-only targets {names} lie on one line: their \
                     positions do not give the platform's rotation about it; place one off \
                     that line, or measure a target's pose (`measures: pose`)"
                ),
            ));
        }
        Ok(())
    }
}
