//! The `instrument.poses` block of a forward model: rows that also carry a platform pose
//! measured in the base frame, and that pose's noise.

use super::Builder;
use crate::error::Result;
use crate::model::instrument::{InstrumentEntry, MeasuredPoses};

impl Builder<'_> {
    /// The `poses` block: forward only; its noise a standard deviation per measured coordinate
    /// (the readings' noise is the model's `noise.readings`), at least one of them positive.
    pub(super) fn measured_poses(
        &self,
        entry: &InstrumentEntry,
        forward: bool,
        measured: &[usize],
    ) -> Result<Option<MeasuredPoses>> {
        let Some(poses) = &entry.poses else {
            return Ok(None);
        };
        if !forward {
            return Err(self.error(
                "instrument.poses",
                "a model seen through an inverse instrument fits every row's pose from its \
                 targets; measured poses beside other observations need `instrument.kinematics: \
                 forward`",
            ));
        }
        if poses.noise.contains_key("readings") {
            return Err(self.error(
                "instrument.poses.noise.readings",
                "the readings' noise is the model's `noise.readings`: the poses' noise names \
                 pose coordinates only",
            ));
        }
        let noise = self.noise("instrument.poses.noise", &poses.noise, measured)?;
        if noise.pose.iter().all(|&s| s == 0.0) {
            return Err(self.error(
                "instrument.poses.noise",
                "expected a positive standard deviation of at least one measured coordinate \
                 (SI units)",
            ));
        }
        Ok(Some(MeasuredPoses {
            noise: noise.pose,
            simulate: poses.simulate,
        }))
    }
}
