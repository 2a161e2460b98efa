//! One Monte Carlo trial through the instrument: the real legs and the real instrument (frame
//! and target offsets: the simulation block's values, else a perturbation with the instrument's
//! own sizes drawn from the trial's seed), what the instrument reports at the selected per-leg
//! poses with the trial's noise, and the joint and two-stage identifications of the same rows.
//! Each arm's errors cover the identified instrument parameters and the legs'; its map is the
//! identified legs commanding the real ones (the instrument only measures).

use super::{Arm, ArmTrial, ParameterOf, Study, TrialValues};
use crate::error::{Error, Result};
use crate::evaluate::accuracy::result_parameters;
use crate::identify::result::{Strategy, StrategyResult};
use crate::identify::shared_estimate::identify_shared;
use crate::kinematics::inverse::Joints;
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::observe_simulate::{observed_from, without_pose_noise};
use crate::measure::simulate::{simulate_at, SimulationOptions};

impl Arm {
    /// The identification through the instrument of an instrument arm (`None` for the others).
    fn shared_strategy(self) -> Option<Strategy> {
        Some(self.strategy()).filter(|s| s.through_instrument())
    }
}

impl Study {
    /// The values of the trial with seed `seed` of a study through the instrument.
    pub(super) fn instrument_trial_values(&self, seed: u64) -> Result<TrialValues> {
        let options = SimulationOptions {
            seed: Some(seed),
            noise_scale: self.options.noise_scale,
            poses_per_leg: None,
        };
        let quiet = without_pose_noise(&self.mechanism);
        let experiment = simulate_at(&quiet, &self.pose_sets, options)?;
        let observed = observed_from(&self.mechanism, experiment, options)?;
        let real_kinematics = ForwardKinematics::new(&self.mechanism, &observed.real);
        let nominal_map_rms = self.nominal_map_rms(&observed.real, &real_kinematics)?;
        let mut joints = self.nominal_joints.clone();
        let mut arms = Vec::with_capacity(self.arms.len());
        for &arm in &self.arms {
            let strategy = arm.shared_strategy().ok_or_else(|| {
                Error::Invalid(format!("{}: not an arm through the instrument", arm.name()))
            })?;
            let result = identify_shared(
                &self.mechanism,
                &observed.observations,
                strategy,
                self.fit_options(),
            )?;
            if let Some(run) = result.runs.iter().find(|r| !r.converged) {
                return Err(Error::Solver {
                    context: arm.name().into(),
                    message: format!("did not converge: {}", run.stop_reason),
                });
            }
            arms.push(self.shared_arm_trial(
                &result,
                (&observed.real, &observed.real_shared),
                &real_kinematics,
                &mut joints,
            )?);
        }
        Ok(TrialValues {
            nominal_map_rms,
            real: self.real_values(&observed.real, &observed.real_shared),
            arms,
        })
    }

    /// One arm's values from `result` against the real legs and instrument `(legs, shared)`.
    fn shared_arm_trial(
        &self,
        result: &StrategyResult,
        (real, real_shared): (&[Vec<f64>], &[f64]),
        real_kinematics: &ForwardKinematics<'_>,
        joints: &mut Vec<Option<Joints>>,
    ) -> Result<ArmTrial> {
        let mut errors = Vec::with_capacity(self.parameters.len());
        let mut predicted_std = Vec::with_capacity(self.parameters.len());
        for p in &self.parameters {
            let (estimate, value) = match p.of {
                ParameterOf::Instrument(k) => (
                    result.instrument.as_ref().and_then(|i| i.parameters.get(k)),
                    real_shared[k],
                ),
                ParameterOf::Leg { leg, column } => (
                    result
                        .legs
                        .iter()
                        .find(|l| l.leg == self.mechanism.legs[leg].name)
                        .and_then(|l| l.parameters.get(column)),
                    real[leg][column],
                ),
            };
            let estimate = estimate.ok_or_else(|| {
                Error::Invalid(format!("{}: `{}` missing", result.strategy.name(), p.name))
            })?;
            errors.push(estimate.estimate - value);
            predicted_std.push(estimate.std.unwrap_or(f64::NAN));
        }
        let identified = result_parameters(&self.mechanism, result);
        Ok(ArmTrial {
            errors,
            predicted_std,
            map_rms: self.map_rms(&identified, real_kinematics, joints)?,
        })
    }
}
