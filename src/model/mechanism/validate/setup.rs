//! The simulation and pose selection set-ups.

use super::plausible::far_from_nominal;
use super::plausible::{tiny_gain, MIN_GAIN};
use super::scale::mechanism_size;
use super::Builder;
use crate::error::Result;
use crate::model::file::ModelFile;
use crate::model::instrument::Instrument;
use crate::model::leg::LegModel;
use crate::model::mechanism::MAX_POSES_PER_LEG;
use crate::model::mechanism::{MeasurementNoise, SelectionCriterion, SelectionSetup, Simulation};
use crate::model::params::{ParamTarget, Unit};

impl Builder<'_> {
    /// The simulation block; its noise defaults to the declared (top-level) noise.
    pub(super) fn simulation(
        &self,
        file: &ModelFile,
        measured: &[usize],
        legs: &[LegModel],
        declared: Option<MeasurementNoise>,
        instrument: Option<&Instrument>,
    ) -> Result<Option<Simulation>> {
        let Some(entry) = &file.simulation else {
            return Ok(None);
        };
        for (name, value) in &entry.real {
            if !legs
                .iter()
                .any(|l| l.params.iter().any(|p| &p.name == name))
                && instrument.is_none_or(|i| i.parameter_index(name).is_none())
            {
                return Err(self.error(
                    format!("simulation.real.{name}"),
                    "no parameter has this name",
                ));
            }
            if !value.is_finite() {
                return Err(self.error(
                    format!("simulation.real.{name}"),
                    "expected a finite number",
                ));
            }
            self.real_value(name, *value, legs)?;
        }
        let noise = match &entry.noise {
            Some(entries) => self.noise("simulation.noise", entries, measured)?,
            None => declared.unwrap_or_default(),
        };
        let perturbation = match &entry.perturbation {
            Some(p) => {
                if [p.length, p.angle, p.gain]
                    .iter()
                    .any(|v| !(v.is_finite() && *v >= 0.0))
                {
                    return Err(self.error(
                        "simulation.perturbation",
                        "expected non-negative standard deviations",
                    ));
                }
                let size = mechanism_size(legs);
                if p.length > size {
                    return Err(self.error(
                        "simulation.perturbation.length",
                        format!(
                            "{} m is more than the mechanism's size ({size:.3} m): the real legs \
                             would be other mechanisms (millimetres instead of metres?)",
                            p.length
                        ),
                    ));
                }
                Some((p.length, p.angle, p.gain))
            }
            None => None,
        };
        if !(1..=MAX_POSES_PER_LEG).contains(&entry.poses_per_leg) {
            return Err(self.error(
                "simulation.poses_per_leg",
                format!("expected between 1 and {MAX_POSES_PER_LEG} poses"),
            ));
        }
        Ok(Some(Simulation {
            real: entry.real.clone(),
            perturbation,
            pose_noise: noise.pose,
            reading_noise: noise.reading,
            poses_per_leg: entry.poses_per_leg,
            seed: entry.seed,
        }))
    }

    /// A real value of a leg parameter the simulation can use: a gain of plausible magnitude
    /// (a real gain of 0 made every reading infinite), a length within the mechanism's size of
    /// its nominal value (a real length in millimetres made every pose unreachable, reported
    /// as a workspace without reachable poses).
    fn real_value(&self, name: &str, value: f64, legs: &[LegModel]) -> Result<()> {
        let field = format!("simulation.real.{name}");
        let Some(param) = legs.iter().flat_map(|l| &l.params).find(|p| p.name == name) else {
            return Ok(());
        };
        if param.target == ParamTarget::Gain && value.abs() < MIN_GAIN {
            return Err(self.error(field, tiny_gain(value)));
        }
        let size = mechanism_size(legs);
        match far_from_nominal(value, param.nominal, size) {
            Some(message) if param.unit == Unit::Metre => Err(self.error(field, message)),
            _ => Ok(()),
        }
    }

    pub(super) fn selection(
        &self,
        file: &ModelFile,
        simulation: Option<&Simulation>,
    ) -> Result<SelectionSetup> {
        let entry = file.selection.as_ref();
        let poses_per_leg = entry
            .and_then(|e| e.poses_per_leg)
            .or(simulation.map(|s| s.poses_per_leg))
            .unwrap_or(18);
        if !(1..=MAX_POSES_PER_LEG).contains(&poses_per_leg) {
            return Err(self.error(
                "selection.poses_per_leg",
                format!("expected between 1 and {MAX_POSES_PER_LEG} poses"),
            ));
        }
        let criterion = match entry.and_then(|e| e.criterion.as_deref()) {
            None | Some("D") | Some("d") => SelectionCriterion::D,
            Some("A") | Some("a") => SelectionCriterion::A,
            Some("E") | Some("e") => SelectionCriterion::E,
            Some(other) => {
                return Err(self.error(
                    "selection.criterion",
                    format!("`{other}` is not one of D, A, E"),
                ))
            }
        };
        Ok(SelectionSetup {
            poses_per_leg,
            criterion,
        })
    }
}
