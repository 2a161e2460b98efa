//! The measurement noise blocks: the top-level `noise` and `simulation.noise`.

use std::collections::BTreeMap;

use super::Builder;
use crate::error::Result;
use crate::model::mechanism::{MeasurementNoise, COORDINATES};

impl Builder<'_> {
    /// Validates a noise block called `field` (`noise` or `simulation.noise`): every key is
    /// `readings` or a measured coordinate, every value a finite non-negative standard deviation.
    pub(super) fn noise(
        &self,
        field: &str,
        entries: &BTreeMap<String, f64>,
        measured: &[usize],
    ) -> Result<MeasurementNoise> {
        let mut noise = MeasurementNoise::default();
        for (name, &sigma) in entries {
            let field = format!("{field}.{name}");
            if !(sigma.is_finite() && sigma >= 0.0) {
                return Err(self.error(
                    field,
                    format!("expected a non-negative standard deviation (SI units), found {sigma}"),
                ));
            }
            match COORDINATES.iter().position(|c| c == name) {
                _ if name == "readings" => noise.reading = sigma,
                Some(i) if measured.contains(&i) => noise.pose[i] = sigma,
                _ => {
                    let names: Vec<&str> = measured.iter().map(|&i| COORDINATES[i]).collect();
                    return Err(self.error(
                        field,
                        format!(
                            "expected `readings` or a measured coordinate ({})",
                            names.join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(noise)
    }
}
