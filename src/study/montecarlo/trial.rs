//! One Monte Carlo trial of a [`Study`]: its data simulated from the trial's own seed (the real
//! mechanism drawn, the poses measured with noise), each arm's identification, and the accuracy
//! maps of the nominal and the identified models against the real mechanism.

use super::*;

impl Study {
    /// Runs trial `index`.
    pub fn trial(&self, index: usize) -> Trial {
        let seed = trial_seed(self.options.seed, index);
        Trial {
            index,
            seed,
            outcome: self.trial_values(seed).map_err(|e| e.to_string()),
        }
    }

    fn trial_values(&self, seed: u64) -> Result<TrialValues> {
        let options = SimulationOptions {
            seed: Some(seed),
            noise_scale: self.options.noise_scale,
            poses_per_leg: None,
        };
        let (real, sets) = self.trial_data(options)?;
        let real_kinematics = ForwardKinematics::new(&self.mechanism, &real.legs);
        let real_shared = real.instrument.as_deref();
        let nominal_map_rms = self.nominal_map_rms((&real.legs, real_shared), &real_kinematics)?;
        // Each map point's first forward evaluation on the real legs (through their kernels),
        // the same for every arm's map: evaluated once.
        let first: Vec<Option<KernelRows>> = self
            .map
            .iter()
            .map(|target| real_kinematics.kernel_rows_at(target))
            .collect();
        // The commanding joints of the last map, the warm starts of the next one.
        let mut joints = self.nominal_joints.clone();
        let mut arms = Vec::with_capacity(self.arms.len());
        for (arm, data) in self.arms.iter().zip(&sets) {
            let (solver, fit) = (self.options.solver, self.fit_options());
            let result = identify_one(&self.mechanism, data, arm.strategy(), solver, fit)?;
            if let Some(run) = result.runs.iter().find(|r| !r.converged) {
                return Err(Error::Solver {
                    context: format!("{}, legs {}", arm.name(), run.legs.join(", ")),
                    message: format!("did not converge: {}", run.stop_reason),
                });
            }
            let real_kinematics = (&real_kinematics, first.as_slice());
            arms.push(self.arm_trial(&result, &real, real_kinematics, &mut joints)?);
        }
        Ok(TrialValues {
            nominal_map_rms,
            real: self.real_values(&real),
            arms,
        })
    }

    /// A trial's real values and the measurements of each arm (in the order of the arms): each
    /// leg's own rows, the shared rows of one leg's count, the shared rows of D&C's count;
    /// through the instrument, what it reports at the per-leg poses, the same rows for every arm.
    fn trial_data(&self, options: SimulationOptions) -> Result<(RealValues, Vec<Measurements>)> {
        let simulated = simulated_poses(&self.mechanism);
        let experiment = match self.mechanism.forward_instrument() {
            // The selected rows of every leg's reading (touches on the trial's real bed).
            Some(instrument) => {
                let commanded = Some(self.pose_sets.shared.as_slice());
                let sets = forward_pose_sets(&simulated, instrument, options, commanded)?;
                simulate_at(&simulated, &sets, options)?
            }
            None => simulate_at(&simulated, &self.pose_sets, options)?,
        };
        let (real, data) = measured(&self.mechanism, experiment, options)?;
        let Measurements::Readings(measurements) = &data else {
            return Ok((real, vec![data; self.arms.len()]));
        };
        let labelled = measurements.filtered(|p, _| p.leg.is_some());
        let legs = measurements.legs();
        let (mut small, mut equal) = (
            MeasurementSet::new(None, legs),
            MeasurementSet::new(None, legs),
        );
        let shared = measurements.rows().filter(|(p, _)| p.leg.is_none());
        for (k, (pose, readings)) in shared.enumerate() {
            let set = if k < self.shared_count {
                &mut small
            } else {
                &mut equal
            };
            set.push(*pose, readings);
        }
        let sets = [labelled, small, equal].map(Measurements::Readings);
        Ok((real, sets.to_vec()))
    }

    /// The real value of every study parameter, from the real legs and instrument parameters.
    fn real_values(&self, real: &RealValues) -> Vec<f64> {
        self.parameters
            .iter()
            .map(|p| match p.of {
                ParameterOf::Leg { leg, column } => real.legs[leg][column],
                ParameterOf::Instrument(k) => real
                    .instrument
                    .as_ref()
                    .and_then(|values| values.get(k))
                    .copied()
                    .unwrap_or(f64::NAN),
            })
            .collect()
    }

    /// The nominal model's RMS position error over the map against the `real` legs (their
    /// forward kinematics `real_kinematics`), computed once for the study when they are fixed.
    pub(super) fn nominal_map_rms(
        &self,
        (real, real_shared): (&[Vec<f64>], Option<&[f64]>),
        real_kinematics: &ForwardKinematics<'_>,
    ) -> Result<f64> {
        match &self.fixed_real {
            Some((fixed, rms)) if fixed == real => Ok(*rms),
            _ => {
                let nominal = self.mechanism.instrument.as_ref().map(|i| i.nominal());
                self.map_rms(
                    &self.mechanism.nominal_parameters(),
                    (real_kinematics, &[]),
                    &mut self.nominal_joints.clone(),
                    nominal.as_deref().zip(real_shared),
                )
            }
        }
    }

    /// One arm's values from `result`: each study parameter's error against `real` and its
    /// predicted σ, and the RMS map error of the identified legs commanding the real ones
    /// (their forward kinematics and each map point's first evaluation, as [`Self::map_rms`]).
    fn arm_trial(
        &self,
        result: &StrategyResult,
        real: &RealValues,
        real_kinematics: (&ForwardKinematics<'_>, &[Option<KernelRows>]),
        joints: &mut Vec<Option<Joints>>,
    ) -> Result<ArmTrial> {
        let values = self.real_values(real);
        let mut errors = Vec::with_capacity(self.parameters.len());
        let mut predicted_std = Vec::with_capacity(self.parameters.len());
        for (p, real) in self.parameters.iter().zip(values) {
            let estimate = match p.of {
                ParameterOf::Leg { leg, column } => {
                    let name = &self.mechanism.legs[leg].name;
                    let leg = result.legs.iter().find(|e| &e.leg == name);
                    leg.and_then(|e| e.parameters.get(column))
                }
                ParameterOf::Instrument(k) => {
                    let instrument = result.instrument.as_ref();
                    instrument.and_then(|i| i.parameters.get(k))
                }
            };
            let estimate = estimate.ok_or_else(|| {
                Error::Invalid(format!("{}: `{}` missing", result.strategy.name(), p.name))
            })?;
            errors.push(estimate.estimate - real);
            predicted_std.push(estimate.std.unwrap_or(f64::NAN));
        }
        let identified = result_parameters(&self.mechanism, result);
        let shared: Option<Vec<f64>> = result
            .instrument
            .as_ref()
            .map(|i| i.parameters.iter().map(|p| p.estimate).collect());
        let frames = shared.as_deref().zip(real.instrument.as_deref());
        Ok(ArmTrial {
            errors,
            predicted_std,
            map_rms: self.map_rms(&identified, real_kinematics, joints, frames)?,
            alarms: Alarms::of(result),
        })
    }

    /// RMS position error over the map with `commanding` commanding the real mechanism (its
    /// forward kinematics `real`, prepared once per trial for every map, with the first
    /// evaluation at each map point when computed beforehand, [`ForwardKinematics::kernel_rows_at`]:
    /// the same poses as [`crate::evaluate::accuracy::reached_poses_from`], bit for bit);
    /// `joints` are the commanding joints of an earlier map, the warm starts of this one's
    /// inverse kinematics (then this map's).
    fn map_rms(
        &self,
        commanding: &[Vec<f64>],
        (real, first): (&ForwardKinematics<'_>, &[Option<KernelRows>]),
        joints: &mut Vec<Option<Joints>>,
        shared: Option<(&[f64], &[f64])>,
    ) -> Result<f64> {
        let mut sum = 0.0;
        let mut count = 0usize;
        let mut reached: Vec<Option<[f64; 6]>> = Vec::with_capacity(self.map.len());
        commanded_each(
            &self.mechanism,
            commanding,
            &self.map,
            joints,
            |i, command| {
                reached.push(command.and_then(|(readings, start)| {
                    let first = first.get(i).and_then(Option::as_ref);
                    real.solve_near_pose_from(readings, start, first).ok()
                }));
            },
        );
        let forward = self.mechanism.forward_instrument();
        if let (Some(instrument), Some(shared)) = (forward, shared) {
            // In the frame the observations define.
            return observed_frame_error(instrument, shared, &self.map, &reached)
                .map(|e| e.position_error.rms)
                .ok_or_else(|| {
                    Error::Invalid(format!(
                        "accuracy map: the real mechanism reaches none of the {} map points",
                        self.map.len()
                    ))
                });
        }
        for (target, reached) in self.map.iter().zip(reached) {
            if let Some(reached) = reached {
                sum += position_error(&reached, target).powi(2);
                count += 1;
            }
        }
        if count == 0 {
            return Err(Error::Invalid(format!(
                "accuracy map: the real mechanism reaches none of the {} map points",
                self.map.len()
            )));
        }
        Ok((sum / count as f64).sqrt())
    }
}
