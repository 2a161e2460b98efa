//! A printer study's figures over its printers: the medians of each calibration's print error,
//! and how the recommended factor set did against the best in hindsight.

use super::{recommended, PrinterErrors, PrinterStudyResult, SetOutcome};

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
    /// Per factor that is a parameter of the printers, the spread of its errors over its σ:
    /// `√(mean ((estimate − real)/σ)²)` over the printers that determined the set (1 when the
    /// σ are honest).
    pub spread_over_sigma: Vec<(String, f64)>,
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
                    spread_over_sigma: spread_over_sigma(
                        printers.iter().filter_map(|sets| sets.get(k)),
                    ),
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

/// Per factor named in `outcomes`' standardized errors, `√(mean z²)` over the outcomes, in
/// the order the factors first appear.
fn spread_over_sigma<'o>(outcomes: impl Iterator<Item = &'o SetOutcome>) -> Vec<(String, f64)> {
    let mut sums: Vec<(String, f64, usize)> = Vec::new();
    for outcome in outcomes {
        for (name, z) in &outcome.standardized_errors {
            match sums.iter_mut().find(|(n, _, _)| n == name) {
                Some(entry) => {
                    entry.1 += z * z;
                    entry.2 += 1;
                }
                None => sums.push((name.clone(), z * z, 1)),
            }
        }
    }
    sums.into_iter()
        .map(|(name, sum, count)| (name, (sum / count as f64).sqrt()))
        .collect()
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
