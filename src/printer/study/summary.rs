//! A printer study's figures over its printers: the medians of each calibration's print error,
//! and how the recommended factor set did against the best in hindsight.

use super::{recommended, PrinterErrors, PrinterStudyResult, SetOutcome};

/// The study's figures over the printers that succeeded.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PrinterStudySummary {
    /// Printers whose both workflows ran.
    pub succeeded: usize,
    /// Median print error with the imported values, m.
    pub nominal_median: f64,
    /// Median print error after the firmware's calibration, m.
    pub firmware_median: f64,
    /// Median print error of legwise's calibrated model itself, m.
    pub legwise_model_median: f64,
    /// Median print error of legwise's calibration exported through the firmware, m.
    pub legwise_median: f64,
    /// `legwise_median / firmware_median`.
    pub ratio: f64,
    /// Fraction of the printers where legwise's exported calibration prints better.
    pub legwise_better: f64,
    /// Median of the export's loss (RMS over the bed), m.
    pub export_loss_median: f64,
    /// Largest export loss, m.
    pub export_loss_max: f64,
}

impl PrinterStudyResult {
    /// The figures over the printers that succeeded (`None` if none did).
    pub fn summary(&self) -> Option<PrinterStudySummary> {
        let ok: Vec<&PrinterErrors> = self
            .printers
            .iter()
            .filter_map(|p| p.outcome.as_ref().ok().map(|o| &o.errors))
            .collect();
        if ok.is_empty() {
            return None;
        }
        let median_of = |f: fn(&PrinterErrors) -> f64| median(ok.iter().map(|e| f(e)).collect());
        let firmware_median = median_of(|e| e.firmware);
        let legwise_median = median_of(|e| e.legwise);
        Some(PrinterStudySummary {
            succeeded: ok.len(),
            nominal_median: median_of(|e| e.nominal),
            firmware_median,
            legwise_model_median: median_of(|e| e.legwise_model),
            legwise_median,
            ratio: legwise_median / firmware_median,
            legwise_better: ok.iter().filter(|e| e.legwise < e.firmware).count() as f64
                / ok.len() as f64,
            export_loss_median: median_of(|e| e.export_loss),
            export_loss_max: ok.iter().map(|e| e.export_loss).fold(0.0, f64::max),
        })
    }
}

/// One set's figures over the printers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SetSummary {
    /// The set's name.
    pub name: String,
    /// Its factors.
    pub factors: usize,
    /// Printers whose touches determined it.
    pub determined: usize,
    /// Median print error over those printers, m.
    pub median_print_error_m: f64,
    /// Printers on which the rule recommended it.
    pub recommended: usize,
}

/// How the recommendation did over the printers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChoiceSummary {
    /// Per set.
    pub sets: Vec<SetSummary>,
    /// Median over the printers of the recommended set's print error, m.
    pub recommended_median_m: f64,
    /// Median over the printers of the best set's in hindsight (the smallest print error of
    /// the determined sets), m.
    pub best_median_m: f64,
    /// `recommended_median_m / best_median_m`.
    pub ratio: f64,
}

impl PrinterStudyResult {
    /// The recommendation's figures (`None` without [`PrinterStudyOptions::compare_sets`] or
    /// a printer that succeeded).
    pub fn choice(&self) -> Option<ChoiceSummary> {
        let printers: Vec<&[SetOutcome]> = self
            .printers
            .iter()
            .filter_map(|p| p.outcome.as_ref().ok())
            .map(|o| o.sets.as_slice())
            .filter(|sets| !sets.is_empty())
            .collect();
        let first = printers.first()?;
        let picks: Vec<Option<usize>> = printers.iter().map(|sets| recommended(sets)).collect();
        let sets = first
            .iter()
            .enumerate()
            .map(|(k, set)| {
                let errors: Vec<f64> = printers
                    .iter()
                    .filter_map(|sets| sets.get(k).and_then(|s| s.print_error_m))
                    .collect();
                SetSummary {
                    name: set.name.clone(),
                    factors: set.factors,
                    determined: errors.len(),
                    median_print_error_m: median(errors),
                    recommended: picks.iter().filter(|p| **p == Some(k)).count(),
                }
            })
            .collect();
        let chosen: Vec<f64> = printers
            .iter()
            .zip(&picks)
            .filter_map(|(sets, pick)| pick.and_then(|k| sets[k].print_error_m))
            .collect();
        let best: Vec<f64> = printers
            .iter()
            .filter_map(|sets| {
                sets.iter()
                    .filter_map(|s| s.print_error_m)
                    .min_by(f64::total_cmp)
            })
            .collect();
        let (recommended_median_m, best_median_m) = (median(chosen), median(best));
        Some(ChoiceSummary {
            sets,
            recommended_median_m,
            best_median_m,
            ratio: recommended_median_m / best_median_m,
        })
    }
}

/// The median of `values` (the mean of the middle two for an even count).
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => values[n / 2],
        _ => 0.5 * (values[n / 2 - 1] + values[n / 2]),
    }
}
