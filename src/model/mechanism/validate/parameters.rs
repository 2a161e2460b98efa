//! The kinematic parameters: each names one quantity of one leg (a joint-origin component,
//! an actuator gain or offset, or an attachment component).

use std::collections::HashSet;

use super::Builder;
use crate::error::Result;
use crate::model::file::ParameterEntry;
use crate::model::joint::ORIGIN_COMPONENTS;
use crate::model::leg::LegModel;
use crate::model::params::{ParamTarget, Parameter, Unit};

impl Builder<'_> {
    pub(super) fn parameters(
        &self,
        entries: &[ParameterEntry],
        legs: &mut [LegModel],
    ) -> Result<()> {
        let mut names = HashSet::new();
        let mut targets = HashSet::new();
        for (p, entry) in entries.iter().enumerate() {
            let field = format!("parameters[{p}]");
            let name = entry.name.as_str();
            if name.is_empty() || name.trim() != name || name.contains(char::is_control) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!(
                        "`{name}` cannot name a parameter in reports and in `simulation.real`: \
                         expected a non-empty name without line breaks or spaces at either end"
                    ),
                ));
            }
            if !names.insert(entry.name.as_str()) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!("parameter `{}` is defined twice", entry.name),
                ));
            }
            let (leg, target) = self.target(entry, &field, legs)?;
            if !targets.insert((leg, format!("{target:?}"))) {
                return Err(self.error(
                    field,
                    format!(
                        "parameter `{}` stands for a quantity another parameter already names",
                        entry.name
                    ),
                ));
            }
            let model = &legs[leg];
            let (nominal, unit) = match target {
                ParamTarget::JointOrigin { joint, component } => (
                    model.joints[joint].origin[component],
                    if component < 3 {
                        Unit::Metre
                    } else {
                        Unit::Radian
                    },
                ),
                ParamTarget::Gain => (model.gain, Unit::One),
                ParamTarget::Offset => (
                    model.offset,
                    if model.actuated_is_revolute() {
                        Unit::Radian
                    } else {
                        Unit::Metre
                    },
                ),
                ParamTarget::Attachment { component } => (model.attachment[component], Unit::Metre),
            };
            legs[leg].params.push(Parameter {
                name: entry.name.clone(),
                target,
                nominal,
                identified: entry.identify,
                unit,
                derived: None,
                prior: self.prior_sigma(entry.prior, &field)?,
            });
        }
        Ok(())
    }

    /// The prior standard deviation of the entry at `field`, if given: finite and positive
    /// (a zero σ is a held parameter, `identify: false`).
    pub(super) fn prior_sigma(&self, prior: Option<f64>, field: &str) -> Result<Option<f64>> {
        match prior {
            Some(sigma) if !(sigma > 0.0 && sigma.is_finite()) => Err(self.error(
                format!("{field}.prior"),
                format!(
                    "expected the prior's standard deviation, a finite positive number in SI \
                     units (metres, radians, or 1 for a gain), found {sigma}; a parameter known \
                     exactly is held (`identify: false`)"
                ),
            )),
            _ => Ok(prior),
        }
    }

    fn target(
        &self,
        entry: &ParameterEntry,
        field: &str,
        legs: &[LegModel],
    ) -> Result<(usize, ParamTarget)> {
        let leg_named = |name: &str, key: &str| {
            legs.iter().position(|l| l.name == name).ok_or_else(|| {
                self.error(
                    format!("{field}.{key}"),
                    format!("no leg is named `{name}`"),
                )
            })
        };
        let component = |value: &str, key: &str, allowed: &[&str]| {
            allowed.iter().position(|c| *c == value).ok_or_else(|| {
                self.error(
                    format!("{field}.{key}"),
                    format!("`{value}` is not one of {}", allowed.join(", ")),
                )
            })
        };
        match (
            &entry.joint,
            &entry.origin,
            &entry.leg,
            &entry.actuator,
            &entry.attachment,
        ) {
            (Some(joint), Some(origin), None, None, None) => {
                let component = component(origin, "origin", &ORIGIN_COMPONENTS)?;
                for (l, leg) in legs.iter().enumerate() {
                    if let Some(j) = leg.joints.iter().position(|j| &j.name == joint) {
                        return Ok((
                            l,
                            ParamTarget::JointOrigin {
                                joint: j,
                                component,
                            },
                        ));
                    }
                }
                let known = self.robot.joints.iter().any(|j| &j.name == joint);
                Err(self.error(
                    format!("{field}.joint"),
                    if known {
                        format!("joint `{joint}` is in no leg's chain")
                    } else {
                        format!("joint `{joint}` is not in the URDF `{}`", self.urdf_name())
                    },
                ))
            }
            (None, None, Some(leg), Some(term), None) => {
                let leg = leg_named(leg, "leg")?;
                match term.as_str() {
                    "gain" => Ok((leg, ParamTarget::Gain)),
                    "offset" => Ok((leg, ParamTarget::Offset)),
                    other => Err(self.error(
                        format!("{field}.actuator"),
                        format!("`{other}` is not one of gain, offset"),
                    )),
                }
            }
            (None, None, Some(leg), None, Some(axis)) => {
                let leg = leg_named(leg, "leg")?;
                let component = component(axis, "attachment", &ORIGIN_COMPONENTS[..3])?;
                Ok((leg, ParamTarget::Attachment { component }))
            }
            _ => Err(self.error(
                field,
                format!(
                "parameter `{}` needs exactly one target: `joint` + `origin`, `leg` + `actuator`, \
                 or `leg` + `attachment`",
                entry.name
            ),
            )),
        }
    }
}
