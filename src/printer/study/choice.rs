//! Choosing the factors from the touches alone, checked on simulated printers: every factor set
//! of the model (its own and its `factor_sets:`) fitted on legwise's touches of each printer,
//! each judged by its true print error, and the set legwise recommends from what the fit
//! itself shows (no truth: [`crate::identify::set_choice`]).

use serde::Serialize;

use super::PrinterStudy;
use crate::error::Result;
use crate::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use crate::identify::set_choice::{self, Candidate};
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::Measurements;
use crate::model::with_values::with_values;
use crate::model::Mechanism;

/// One set on one printer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetOutcome {
    /// The set's name (`model` for the model's own).
    pub name: String,
    /// Its factors.
    pub factors: usize,
    /// Whether the touches determine every factor.
    pub determined: bool,
    /// RMS of the touches' leave-one-out prediction errors (m), when determined.
    pub left_out_m: Option<f64>,
    /// Akaike's criterion `χ² + 2k`.
    pub information: Option<f64>,
    /// The same corrected for few rows (AICc), the recommendation's score; `None` where the
    /// rows are too few to judge the set.
    pub information_corrected: Option<f64>,
    /// The print error of the fitted model commanding the printer (m), when determined.
    pub print_error_m: Option<f64>,
    /// Each factor's error over its σ, `(estimate − real)/σ`, by name: the factors that are
    /// parameters of the printer (a quantity has no real value of its own), when determined.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub standardized_errors: Vec<(String, f64)>,
}

/// The index of the set legwise recommends among `sets` ([`set_choice::recommended`]).
pub fn recommended(sets: &[SetOutcome]) -> Option<usize> {
    let candidates: Vec<Candidate> = sets
        .iter()
        .map(|s| Candidate {
            determined: s.determined,
            score: s.information_corrected.unwrap_or(f64::INFINITY),
            factors: s.factors,
        })
        .collect();
    set_choice::recommended(&candidates)
}

impl PrinterStudy {
    /// Every set of the model fitted on `data` (legwise's touches of a printer), with the
    /// print error each leaves on it (`real`: its forward kinematics; `real_shared`: its bed;
    /// `printer`: the drawn printer, its simulation block's `real` values).
    pub(super) fn set_outcomes(
        &self,
        data: &Measurements,
        (real, real_shared): (&ForwardKinematics<'_>, &[f64]),
        printer: &Mechanism,
    ) -> Result<Vec<SetOutcome>> {
        let truth = printer.simulation.as_ref().map(|s| &s.real);
        model_sets(&self.mechanism)
            .iter()
            .map(|set| {
                let fit = fit_factor_set(&self.mechanism, data, set)?;
                let determined = fit.observability.rank == fit.factors.len();
                let print_error_m = match determined {
                    true => Some(self.print_error(&fitted(self, &fit)?, real, real_shared)?),
                    false => None,
                };
                let standardized_errors = fit
                    .factors
                    .iter()
                    .filter(|_| determined)
                    .filter_map(|f| {
                        let value = truth?.get(&f.name)?;
                        (f.sigma > 0.0).then(|| (f.name.clone(), (f.estimate - value) / f.sigma))
                    })
                    .collect();
                Ok(SetOutcome {
                    name: fit.name.clone(),
                    factors: fit.factors.len(),
                    determined,
                    left_out_m: fit.leave_one_out.filter(|_| determined),
                    information: fit.information.is_finite().then_some(fit.information),
                    information_corrected: fit
                        .information_corrected
                        .is_finite()
                        .then_some(fit.information_corrected),
                    print_error_m,
                    standardized_errors,
                })
            })
            .collect()
    }
}

/// The model at a set's estimates.
fn fitted(study: &PrinterStudy, fit: &FactorSetFit) -> Result<Mechanism> {
    let values: Vec<(String, f64)> = fit
        .factors
        .iter()
        .map(|f| (f.name.clone(), f.estimate))
        .collect();
    with_values(&study.mechanism, &values)
}

#[cfg(test)]
mod tests {
    use super::{recommended, SetOutcome};

    fn set(name: &str, factors: usize, score: Option<f64>) -> SetOutcome {
        SetOutcome {
            name: name.into(),
            factors,
            determined: score.is_some(),
            left_out_m: None,
            information: None,
            information_corrected: score,
            print_error_m: None,
            standardized_errors: Vec::new(),
        }
    }

    #[test]
    fn a_printer_set_is_recommended_by_its_corrected_criterion() {
        let sets = [
            set("model", 6, Some(30.0)),
            set("klipper-6", 6, Some(30.0)),
            set("rods", 9, Some(29.0)),
            set("blind", 12, None),
        ];
        assert_eq!(recommended(&sets), Some(2));
        let sets = [set("model", 6, Some(30.0)), set("four", 4, Some(30.0))];
        assert_eq!(recommended(&sets), Some(1));
        assert_eq!(recommended(&[set("blind", 12, None)]), None);
    }
}
