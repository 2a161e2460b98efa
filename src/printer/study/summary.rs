//! A printer study's figures over its printers: the medians of each calibration's print error,
//! and how the recommended factor set did against the best in hindsight.

use super::{PrinterErrors, PrinterStudyResult};
use crate::study::set_outcomes::{choice_summary, median, ChoiceSummary, SetOutcome};

/// The study's figures over the printers that succeeded.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PrinterStudySummary {
    /// Printers whose workflows ran.
    pub succeeded: usize,
    /// Median print error with the imported values, m.
    pub nominal_median: f64,
    /// Median print error after the firmware's calibration, m (a study against a firmware).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub firmware_median: Option<f64>,
    /// Median print error of legwise's calibrated model itself, m.
    pub legwise_model_median: f64,
    /// Median print error of legwise's calibration exported through the firmware, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub legwise_median: Option<f64>,
    /// `legwise_median / firmware_median`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ratio: Option<f64>,
    /// Fraction of the printers where legwise's exported calibration prints better.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub legwise_better: Option<f64>,
    /// Median of the export's loss (RMS over the bed), m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub export_loss_median: Option<f64>,
    /// Largest export loss, m.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub export_loss_max: Option<f64>,
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
        // Against a firmware: every printer has its figures.
        let compared: Option<Vec<[f64; 3]>> = ok
            .iter()
            .map(|e| Some([e.firmware?, e.legwise?, e.export_loss?]))
            .collect();
        let column = |rows: &[[f64; 3]], k: usize| median(rows.iter().map(|r| r[k]).collect());
        let firmware_median = compared.as_ref().map(|c| column(c, 0));
        let legwise_median = compared.as_ref().map(|c| column(c, 1));
        Some(PrinterStudySummary {
            succeeded: ok.len(),
            nominal_median: median_of(|e| e.nominal),
            firmware_median,
            legwise_model_median: median_of(|e| e.legwise_model),
            legwise_median,
            ratio: legwise_median.zip(firmware_median).map(|(l, f)| l / f),
            legwise_better: compared
                .as_ref()
                .map(|c| c.iter().filter(|r| r[1] < r[0]).count() as f64 / ok.len() as f64),
            export_loss_median: compared.as_ref().map(|c| column(c, 2)),
            export_loss_max: compared
                .as_ref()
                .map(|c| c.iter().map(|r| r[2]).fold(0.0, f64::max)),
        })
    }
}

impl PrinterStudyResult {
    /// The recommendation's figures (`None` without [`PrinterStudyOptions::compare_sets`] or
    /// a printer that succeeded).
    ///
    /// [`PrinterStudyOptions::compare_sets`]: super::PrinterStudyOptions::compare_sets
    pub fn choice(&self) -> Option<ChoiceSummary> {
        let printers: Vec<&[SetOutcome]> = self
            .printers
            .iter()
            .filter_map(|p| p.outcome.as_ref().ok())
            .map(|o| o.sets.as_slice())
            .filter(|sets| !sets.is_empty())
            .collect();
        choice_summary(&printers)
    }
}
