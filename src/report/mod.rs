//! Reports of an identification: the values (this module), terminal tables and JSON.
pub mod calibrated;
pub mod evaluation;
pub mod instrument;
pub mod instrument_calibrated;
pub mod json;
pub mod plots;
pub mod terminal;

use crate::identify::estimate::{LegEstimate, StrategyResult};
use crate::model::Mechanism;

/// Rounds `value` to `decimals` decimals so that a tiny negative number does not print as `-0.000…`.
pub fn tidy(value: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    (value * scale).round() / scale + 0.0
}

/// Everything an identification run reports.
#[derive(Debug, Clone)]
pub struct IdentifyReport<'a> {
    /// The mechanism.
    pub mechanism: &'a Mechanism,
    /// Where the measurements came from (a file, or a description of the simulation).
    pub source: String,
    /// Real parameter values per leg, known in simulation.
    pub real: Option<Vec<Vec<f64>>>,
    /// One result per strategy run.
    pub results: Vec<StrategyResult>,
}

impl IdentifyReport<'_> {
    /// Real value of parameter `p` of the leg called `leg`, if known.
    pub fn real_value(&self, leg: &str, p: usize) -> Option<f64> {
        let index = self.mechanism.leg_index(leg)?;
        self.real
            .as_ref()
            .and_then(|r| r.get(index))
            .and_then(|r| r.get(p))
            .copied()
    }

    /// RMS over a leg's identified parameters of (value − real), for `value` nominal or estimate.
    pub fn rms_error(&self, leg: &LegEstimate, estimate: bool) -> Option<f64> {
        let errors: Vec<f64> = leg
            .parameters
            .iter()
            .enumerate()
            .filter(|(_, p)| p.identified)
            .map(|(i, p)| {
                let value = if estimate { p.estimate } else { p.nominal };
                self.real_value(&leg.leg, i).map(|r| value - r)
            })
            .collect::<Option<_>>()?;
        (!errors.is_empty())
            .then(|| (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt())
    }

    /// Legs of the mechanism that `result` did not identify (every parameter held fixed).
    pub fn fixed_legs(&self, result: &StrategyResult) -> Vec<String> {
        self.mechanism
            .legs
            .iter()
            .filter(|leg| !result.legs.iter().any(|e| e.leg == leg.name))
            .map(|leg| leg.name.clone())
            .collect()
    }
}
