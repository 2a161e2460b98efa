//! Choosing the factors from the touches alone, checked on simulated printers: every factor set
//! of the model (its own and its `factor_sets:`) fitted on legwise's touches of each printer,
//! each judged by its true print error, and the set legwise recommends from what the fit
//! itself shows (no truth: [`crate::identify::set_choice`]).

use super::PrinterStudy;
use crate::error::Result;
use crate::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use crate::kinematics::platform::ForwardKinematics;
use crate::measure::Measurements;
use crate::model::with_values::with_values;
use crate::model::Mechanism;
use crate::study::set_outcomes::SetOutcome;

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
                SetOutcome::of(
                    &fit,
                    |fit| self.print_error(&fitted(self, fit)?, real, real_shared),
                    |name| truth?.get(name).copied(),
                )
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
