//! Factor sets judged on simulated experiments, where the truth is known: each set's outcome
//! on one experiment (its rank, its scores, its true error over the workspace, its factors'
//! standardized errors), the set the rows alone recommend ([`crate::identify::set_choice`]),
//! and the figures over the experiments (`legwise sets --trials`, `legwise printer study
//! --sets`).

use serde::Serialize;

use crate::identify::factor_set::FactorSetFit;
use crate::identify::set_choice::{self, Candidate};

/// One factor set fitted on one simulated experiment, judged by the truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetOutcome {
    /// The set's name (`model` for the model's own).
    pub name: String,
    /// Its factors.
    pub factors: usize,
    /// Whether the rows determine every factor.
    pub determined: bool,
    /// Whether its predicted σ over the workspace is within the model's tolerance (true
    /// without either; [`set_choice::within_tolerance`]).
    pub within_tolerance: bool,
    /// RMS of the touches' leave-one-out prediction errors (m), when determined.
    pub left_out_m: Option<f64>,
    /// Akaike's criterion `χ² + 2k`.
    pub information: Option<f64>,
    /// The same corrected for few rows (AICc), the recommendation's score; `None` where the
    /// rows are too few to judge the set.
    pub information_corrected: Option<f64>,
    /// The true error over the workspace of the fitted model commanding the real mechanism
    /// (RMS position error, m; a printer's print error), when determined.
    pub true_error_m: Option<f64>,
    /// Each factor's error over its σ, `(estimate − real)/σ`, by name: the factors that are
    /// parameters of the printer (a quantity has no real value of its own), when determined.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub standardized_errors: Vec<(String, f64)>,
}

impl SetOutcome {
    /// The outcome of `fit`, judged by the truth: `true_error` its true error when the rows
    /// determine it (called only then), `truth` a parameter's real value by name (its factors'
    /// standardized errors).
    ///
    /// # Errors
    /// The true error's.
    pub fn of<E>(
        fit: &FactorSetFit,
        true_error: impl FnOnce(&FactorSetFit) -> Result<f64, E>,
        truth: impl Fn(&str) -> Option<f64>,
    ) -> Result<Self, E> {
        let determined = fit.observability.rank == fit.factors.len();
        let true_error_m = match determined {
            true => Some(true_error(fit)?),
            false => None,
        };
        let standardized_errors = fit
            .factors
            .iter()
            .filter(|_| determined)
            .filter_map(|f| {
                let value = truth(&f.name)?;
                (f.sigma > 0.0).then(|| (f.name.clone(), (f.estimate - value) / f.sigma))
            })
            .collect();
        Ok(SetOutcome {
            name: fit.name.clone(),
            factors: fit.factors.len(),
            determined,
            within_tolerance: set_choice::within_tolerance(fit),
            left_out_m: fit.leave_one_out.filter(|_| determined),
            information: fit.information.is_finite().then_some(fit.information),
            information_corrected: fit
                .information_corrected
                .is_finite()
                .then_some(fit.information_corrected),
            true_error_m,
            standardized_errors,
        })
    }
}

/// The index of the set legwise recommends among `sets` ([`set_choice::recommended`]).
pub fn recommended(sets: &[SetOutcome]) -> Option<usize> {
    let candidates: Vec<Candidate> = sets
        .iter()
        .map(|s| Candidate {
            determined: s.determined,
            score: s.information_corrected.unwrap_or(f64::INFINITY),
            factors: s.factors,
            within_tolerance: s.within_tolerance,
        })
        .collect();
    set_choice::recommended(&candidates)
}

/// One set's figures over the experiments.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SetSummary {
    /// The set's name.
    pub name: String,
    /// Its factors.
    pub factors: usize,
    /// Experiments whose rows determined it.
    pub determined: usize,
    /// Median true error over those experiments, m.
    pub median_true_error_m: f64,
    /// Experiments on which the rule recommended it.
    pub recommended: usize,
    /// Per factor that is a parameter of the model, the spread of its errors over its σ:
    /// `√(mean ((estimate − real)/σ)²)` over the experiments that determined the set (1 when
    /// the σ are honest).
    pub spread_over_sigma: Vec<(String, f64)>,
}

impl SetSummary {
    /// The report's line of its factors' spread/σ (`      spread/σ of the errors: L1 0.95, …`),
    /// `None` without any.
    pub fn spread_line(&self) -> Option<String> {
        let each: Vec<String> = self
            .spread_over_sigma
            .iter()
            .map(|(name, ratio)| format!("{name} {ratio:.2}"))
            .collect();
        (!each.is_empty()).then(|| format!("      spread/σ of the errors: {}", each.join(", ")))
    }
}

/// How the recommendation did over the experiments.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChoiceSummary {
    /// Per set.
    pub sets: Vec<SetSummary>,
    /// Median over the experiments of the recommended set's true error, m.
    pub recommended_median_m: f64,
    /// The best candidate in hindsight: the set whose median true error is the smallest among
    /// the sets every experiment determined.
    pub best_set: String,
    /// Its median true error, m.
    pub best_set_median_m: f64,
    /// `recommended_median_m / best_set_median_m`: the rule against always fitting the best
    /// candidate.
    pub ratio: f64,
    /// Median over the experiments of the smallest true error among each one's determined sets
    /// (an oracle that picks per experiment, beyond any rule: with several sets of nearly
    /// equal errors it picks their noise), m.
    pub oracle_median_m: f64,
    /// `recommended_median_m / oracle_median_m`.
    pub oracle_ratio: f64,
}

impl ChoiceSummary {
    /// The report's line comparing the recommended set with the best candidate in hindsight
    /// and the oracle, the errors in `unit` (`"µm"`: 1e6 and one decimal, else mm: 1e3 and
    /// four), each experiment called `each`; `-` for a figure there is none of (no set every
    /// experiment determines, no recommendation).
    pub fn comparison_line(&self, unit: &str, each: &str) -> String {
        let (scale, digits) = match unit {
            "µm" => (1e6, 1),
            _ => (1e3, 4),
        };
        let figure = |v: f64, digits: usize| match v.is_finite() {
            true => format!("{v:.digits$}"),
            false => "-".to_string(),
        };
        let error = |m: f64| figure(m * scale, digits);
        format!(
            "  the recommended set: median {} {unit}; the best candidate in hindsight (`{}`): {} \
             {unit}; ratio {}; the best set of each {each} (an oracle): {} {unit}, ratio {}",
            error(self.recommended_median_m),
            self.best_set,
            error(self.best_set_median_m),
            figure(self.ratio, 3),
            error(self.oracle_median_m),
            figure(self.oracle_ratio, 3)
        )
    }
}

/// How the recommendation did over `experiments` (each one's sets, in the same order; `None`
/// without any).
pub fn choice_summary(experiments: &[&[SetOutcome]]) -> Option<ChoiceSummary> {
    let first = experiments.first()?;
    let picks: Vec<Option<usize>> = experiments.iter().map(|sets| recommended(sets)).collect();
    let sets: Vec<SetSummary> = first
        .iter()
        .enumerate()
        .map(|(k, set)| {
            let errors: Vec<f64> = experiments
                .iter()
                .filter_map(|sets| sets.get(k).and_then(|s| s.true_error_m))
                .collect();
            SetSummary {
                name: set.name.clone(),
                factors: set.factors,
                determined: errors.len(),
                median_true_error_m: median(errors),
                recommended: picks.iter().filter(|p| **p == Some(k)).count(),
                spread_over_sigma: spread_over_sigma(
                    experiments.iter().filter_map(|sets| sets.get(k)),
                ),
            }
        })
        .collect();
    let chosen: Vec<f64> = experiments
        .iter()
        .zip(&picks)
        .filter_map(|(sets, pick)| pick.and_then(|k| sets[k].true_error_m))
        .collect();
    let best: Vec<f64> = experiments
        .iter()
        .filter_map(|sets| {
            sets.iter()
                .filter_map(|s| s.true_error_m)
                .min_by(f64::total_cmp)
        })
        .collect();
    let (recommended_median_m, oracle_median_m) = (median(chosen), median(best));
    let everywhere = sets
        .iter()
        .filter(|s: &&SetSummary| s.determined == experiments.len());
    let best_set =
        everywhere.min_by(|a, b| a.median_true_error_m.total_cmp(&b.median_true_error_m));
    let (best_set, best_set_median_m) = best_set.map_or((String::new(), f64::NAN), |s| {
        (s.name.clone(), s.median_true_error_m)
    });
    Some(ChoiceSummary {
        recommended_median_m,
        best_set,
        best_set_median_m,
        ratio: recommended_median_m / best_set_median_m,
        oracle_median_m,
        oracle_ratio: recommended_median_m / oracle_median_m,
        sets,
    })
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

#[cfg(test)]
mod tests {
    use super::{recommended, SetOutcome};

    fn set(name: &str, factors: usize, score: Option<f64>) -> SetOutcome {
        SetOutcome {
            name: name.into(),
            factors,
            determined: score.is_some(),
            within_tolerance: true,
            left_out_m: None,
            information: None,
            information_corrected: score,
            true_error_m: None,
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
