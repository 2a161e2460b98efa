//! Reports of an identification: the one [`Report`] value of every set-up, its terminal text,
//! its JSON document, the calibrated model and the pictures.
pub mod calibrated;
pub mod evaluation;
pub mod factor_sets;
pub mod json;
pub mod next_steps;
pub mod plots;
pub mod selection;
pub mod terminal;
pub mod workspace;

use crate::evaluate::accuracy::AccuracyMap;
use crate::identify::estimate::{LegEstimate, Strategy, StrategyResult};
use crate::identify::trust::{implausible_estimates, trust_issues};
use crate::measure::Measurements;
use crate::model::Mechanism;

/// Rounds `value` to `decimals` decimals so that a tiny negative number does not print as `-0.000…`.
pub fn tidy(value: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    (value * scale).round() / scale + 0.0
}

/// The first line of a command's terminal report: `legwise COMMAND: NAME (MODEL FILE)`.
pub fn title(command: &str, mechanism: &Mechanism) -> String {
    format!(
        "legwise {command}: {} ({})\n",
        mechanism.name,
        mechanism.model_path.display()
    )
}

/// Everything an identification run reports, for every set-up (with or without an
/// instrument): made by [`crate::run`] or [`crate::identify()`].
#[derive(Debug, Clone)]
pub struct Report<'a> {
    /// The mechanism.
    pub mechanism: &'a Mechanism,
    /// Where the measurements came from (a file, or a description of the simulation).
    pub source: String,
    /// The measurements identified from.
    pub measurements: Measurements,
    /// The real parameters, known in simulation.
    pub real: Option<RealValues>,
    /// One result per strategy run.
    pub results: Vec<StrategyResult>,
    /// The accuracy maps before and after (simulation, when asked for).
    pub maps: Option<AccuracyMaps>,
}

/// The real parameters of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct RealValues {
    /// Per leg, every parameter (model order).
    pub legs: Vec<Vec<f64>>,
    /// Every instrument parameter (the instrument's order), for a model with an instrument.
    pub instrument: Option<Vec<f64>>,
}

/// The accuracy maps of a simulated run: where the nominal model and each result command the
/// real mechanism (docs/report.md).
#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyMaps {
    /// The nominal model's.
    pub before: AccuracyMap,
    /// Each result's, in the order of [`Report::results`].
    pub after: Vec<AccuracyMap>,
}

impl Report<'_> {
    /// Real value of parameter `p` of the leg called `leg`, if known.
    pub fn real_value(&self, leg: &str, p: usize) -> Option<f64> {
        let index = self.mechanism.leg_index(leg)?;
        self.real
            .as_ref()
            .and_then(|r| r.legs.get(index))
            .and_then(|r| r.get(p))
            .copied()
    }

    /// Real value of the instrument's parameter `k`, if known.
    pub fn real_instrument_value(&self, k: usize) -> Option<f64> {
        self.real
            .as_ref()
            .and_then(|r| r.instrument.as_ref())
            .and_then(|values| values.get(k))
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

    /// The result a calibrated model holds: divide and conquer if it ran, else the first.
    pub fn calibrated_result(&self) -> Option<&StrategyResult> {
        self.results
            .iter()
            .find(|r| r.strategy == Strategy::DivideAndConquer)
            .or(self.results.first())
    }

    /// The results the verdict judges: every result, but through an instrument only the
    /// calibrated one (the two-stage identification is a comparison: its own misfit is shown,
    /// not held against the run).
    pub fn judged_results(&self) -> &[StrategyResult] {
        if self.mechanism.instrument.is_some() {
            &self.results[..self.results.len().min(1)]
        } else {
            &self.results
        }
    }

    /// The reasons the run's result must not be trusted (empty: nothing found), one line
    /// each; the command line prints them as warnings and exits with status 3.
    pub fn trust_issues(&self) -> Vec<String> {
        let mut issues = self.mechanism.warnings.clone();
        issues.extend(trust_issues(self.judged_results()));
        let implausible: Vec<String> = self
            .judged_results()
            .iter()
            .flat_map(|result| implausible_estimates(self.mechanism, result))
            .collect();
        // An implausible estimate is the reason a calibrated model would not load: named once.
        if implausible.is_empty() {
            issues.extend(self.calibrated_model_refused());
        }
        issues.extend(implausible);
        issues
    }

    /// The reasons `result` (one of [`Self::results`]) must not be trusted on its own (empty:
    /// nothing found), by the rules of [`Self::trust_issues`]: the model's warnings, then what
    /// speaks against this result. Unlike the run's verdict, a comparison result (the
    /// two-stage identification through an instrument) is judged too.
    pub fn result_trust_issues(&self, result: &StrategyResult) -> Vec<String> {
        let mut issues = self.mechanism.warnings.clone();
        issues.extend(trust_issues(std::slice::from_ref(result)));
        issues.extend(implausible_estimates(self.mechanism, result));
        issues
    }

    /// Whether nothing speaks against `result` on its own ([`Self::result_trust_issues`] is
    /// empty): the verdict to print beside that result, where [`Self::trusted`] is the run's.
    pub fn result_trusted(&self, result: &StrategyResult) -> bool {
        self.result_trust_issues(result).is_empty()
    }

    /// Whether nothing speaks against the result ([`Self::trust_issues`] is empty).
    pub fn trusted(&self) -> bool {
        self.trust_issues().is_empty()
    }
}
