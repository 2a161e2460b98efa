//! The measurements of one Monte Carlo trial through the instrument: the real legs and the
//! real instrument (frame and target offsets: the simulation block's values, else a
//! perturbation with the instrument's own sizes drawn from the trial's seed) and what the
//! instrument reports at the selected per-leg poses with the trial's noise, the same rows for
//! the joint and the two-stage identification.

use super::Study;
use crate::error::Result;
use crate::measure::observe_simulate::{observed_from, without_pose_noise};
use crate::measure::simulate::{simulate_at, SimulationOptions};
use crate::measure::Measurements;
use crate::report::RealValues;

impl Study {
    /// A trial's real values and each arm's measurements (the same for every arm).
    pub(super) fn instrument_trial_data(
        &self,
        options: SimulationOptions,
    ) -> Result<(RealValues, Vec<Measurements>)> {
        let quiet = without_pose_noise(&self.mechanism);
        let experiment = simulate_at(&quiet, &self.pose_sets, options)?;
        let observed = observed_from(&self.mechanism, experiment, options)?;
        let real = RealValues {
            legs: observed.real,
            instrument: Some(observed.real_shared),
        };
        let data = Measurements::Targets(observed.observations);
        Ok((real, vec![data; self.arms.len()]))
    }
}
