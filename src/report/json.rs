//! The JSON report (`--json PATH`), documented in docs/report.md: built from [`Serialize`]
//! types that mirror the schema, the same for every set-up (an instrument's parameters are one
//! more block of parameters, with the same keys as a leg's). Non-finite numbers are written as
//! `null`, never as NaN.

use std::collections::BTreeMap;

use nalgebra::DMatrix;
use serde::Serialize;

use super::Report;
use crate::evaluate::accuracy::AccuracyMap;
use crate::identify::estimate::{
    LegEstimate, ParameterEstimate, SolverRun, StrategyResult, Weighting,
};
use crate::identify::result::{HeldFrameTest, InstrumentEstimate, PredictedPosition};
use crate::identify::shared_outliers::RowOutlier;
use crate::identify::statistics::{NoiseTest, Outlier};

/// Version of the JSON layout documented in `docs/report.md`; raised when a key changes meaning or
/// disappears (new keys do not change it).
pub const SCHEMA_VERSION: u32 = 2;

/// A document of its own: the schema and program versions, then the keys of `body`.
#[derive(Debug, Serialize)]
pub struct Document<T> {
    schema_version: u32,
    legwise_version: &'static str,
    #[serde(flatten)]
    body: T,
}

impl<T> Document<T> {
    /// `body` after the schema and program versions.
    pub fn new(body: T) -> Self {
        Document {
            schema_version: SCHEMA_VERSION,
            legwise_version: env!("CARGO_PKG_VERSION"),
            body,
        }
    }
}

/// The correlation matrix of a covariance matrix: `V_ij / √(V_ii V_jj)`.
pub fn correlation(covariance: &DMatrix<f64>) -> DMatrix<f64> {
    let std = covariance.diagonal().map(f64::sqrt);
    DMatrix::from_fn(covariance.nrows(), covariance.ncols(), |i, j| {
        covariance[(i, j)] / (std[i] * std[j])
    })
}

fn matrix(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    m.row_iter()
        .map(|row| row.iter().copied().collect())
        .collect()
}

impl Report<'_> {
    /// The report as the JSON document of docs/report.md.
    pub fn to_json(&self) -> ReportJson<'_> {
        ReportJson::new(self)
    }
}

/// The document of `legwise identify --json`.
#[derive(Debug, Serialize)]
pub struct ReportJson<'a> {
    schema_version: u32,
    legwise_version: &'static str,
    mechanism: &'a str,
    model: String,
    mode: Option<&'a str>,
    measurements: &'a str,
    units: &'static str,
    instrument_columns: Option<Vec<String>>,
    /// Whether nothing speaks against the run's result (exit 0; false: exit 3).
    trusted: bool,
    /// Every reason the run's result must not be trusted, as the command prints them.
    trust_issues: Vec<String>,
    results: Vec<ResultJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    accuracy_map_before: Option<&'a AccuracyMap>,
}

impl<'a> ReportJson<'a> {
    /// The document of `report`.
    pub fn new(report: &'a Report<'_>) -> Self {
        let mechanism = report.mechanism;
        let maps = report.maps.as_ref();
        ReportJson {
            schema_version: SCHEMA_VERSION,
            legwise_version: env!("CARGO_PKG_VERSION"),
            mechanism: &mechanism.name,
            model: mechanism.model_path.display().to_string(),
            mode: mechanism.mode.as_deref(),
            measurements: &report.source,
            units: "SI (m, rad); costs are 1/2 ||r||^2 in reading units squared",
            instrument_columns: mechanism.instrument.as_ref().map(|i| i.columns()),
            trusted: report.trusted(),
            trust_issues: report.trust_issues(),
            results: report
                .results
                .iter()
                .enumerate()
                .map(|(i, r)| ResultJson::new(report, r, maps.and_then(|m| m.after.get(i))))
                .collect(),
            accuracy_map_before: maps.map(|m| &m.before),
        }
    }

    /// The document as pretty-printed text with a final newline.
    ///
    /// # Errors
    /// Serialisation fails (it cannot for these types; the error is passed on, not hidden).
    pub fn to_text(&self) -> serde_json::Result<String> {
        Ok(serde_json::to_string_pretty(self)? + "\n")
    }
}

#[derive(Debug, Serialize)]
struct ResultJson<'a> {
    strategy: &'static str,
    solver: &'static str,
    weights: &'static str,
    robust: Option<&'static str>,
    drop_outliers: bool,
    warnings: Vec<String>,
    trusted: bool,
    trust_issues: Vec<String>,
    instrument: Option<InstrumentJson<'a>>,
    legs: Vec<LegJson<'a>>,
    fixed_legs: Vec<String>,
    /// The covariance of every identified parameter of the result, cross terms included.
    covariance: Option<FullCovarianceJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    accuracy_map: Option<&'a AccuracyMap>,
}

/// The covariance of every identified parameter in one matrix, rows and columns in the order
/// of `parameters` (docs/report.md, "Propagating the covariance").
#[derive(Debug, Serialize)]
struct FullCovarianceJson {
    parameters: Vec<String>,
    matrix: Vec<Vec<f64>>,
}

/// The full covariance of `result`'s identified parameters
/// ([`StrategyResult::full_covariance`]).
fn full_covariance(result: &StrategyResult) -> Option<FullCovarianceJson> {
    let (parameters, full) = result.full_covariance()?;
    Some(FullCovarianceJson {
        parameters,
        matrix: matrix(&full),
    })
}

impl<'a> ResultJson<'a> {
    fn new(
        report: &'a Report<'_>,
        result: &'a StrategyResult,
        map: Option<&'a AccuracyMap>,
    ) -> Self {
        let trust_issues = report.result_trust_issues(result);
        ResultJson {
            strategy: result.strategy.name(),
            solver: result.solver.short_name(),
            weights: match result.options.weights {
                Weighting::Unweighted | Weighting::Declared => "none",
                Weighting::Noise => "noise",
            },
            robust: result.options.robust.map(|r| r.name()),
            drop_outliers: result.options.drop_outliers,
            warnings: result_warnings(result),
            trusted: trust_issues.is_empty(),
            trust_issues,
            instrument: result
                .instrument
                .as_ref()
                .map(|i| InstrumentJson::new(report, i)),
            legs: result
                .legs
                .iter()
                .map(|leg| LegJson::new(report, result, leg))
                .collect(),
            fixed_legs: report.fixed_legs(result),
            covariance: full_covariance(result),
            accuracy_map: map,
        }
    }
}

/// A result's warnings: its own and its legs', then every reason it must not be trusted that
/// they do not already say (the predicted σ above the tolerance, a rejected noise test, …).
fn result_warnings(result: &StrategyResult) -> Vec<String> {
    let mut warnings = result.all_warnings();
    for issue in crate::identify::trust::trust_issues(std::slice::from_ref(result)) {
        if !warnings.contains(&issue) {
            warnings.push(issue);
        }
    }
    warnings
}

/// One parameter: the same keys for a leg's and for the instrument's.
#[derive(Debug, Serialize)]
struct ParameterJson<'a> {
    name: &'a str,
    unit: String,
    fixed: bool,
    nominal: f64,
    identified: f64,
    std: Option<f64>,
    degrees_of_freedom: Option<usize>,
    ci95: Option<[f64; 2]>,
    real: Option<f64>,
    error_before: Option<f64>,
    error_after: Option<f64>,
    /// The prior's σ, when the fit took one.
    #[serde(skip_serializing_if = "Option::is_none")]
    prior: Option<f64>,
    /// `1 − σ²/σ_prior²`: the share of the parameter's information from the data.
    #[serde(skip_serializing_if = "Option::is_none")]
    data_share: Option<f64>,
}

impl<'a> ParameterJson<'a> {
    fn new(p: &'a ParameterEstimate, real: Option<f64>) -> Self {
        ParameterJson {
            name: &p.name,
            unit: p.unit.to_string(),
            fixed: !p.identified,
            nominal: p.nominal,
            identified: p.estimate,
            std: (p.std),
            degrees_of_freedom: p.degrees_of_freedom,
            ci95: p
                .half_width95()
                .map(|half| [p.estimate - half, p.estimate + half]),
            real: (real),
            error_before: (real.map(|r| p.nominal - r)),
            error_after: (real.map(|r| p.estimate - r)),
            prior: p.prior,
            data_share: p.data_share,
        }
    }
}

#[derive(Debug, Serialize)]
struct InstrumentJson<'a> {
    parameters: Vec<ParameterJson<'a>>,
    rows: usize,
    unknowns: usize,
    rms_residual: f64,
    noise_test: Option<&'a NoiseTest>,
    outlier_threshold: Option<f64>,
    outliers: &'a [RowOutlier],
    dropped: &'a [RowOutlier],
    held_frame_test: Option<&'a HeldFrameTest>,
    #[serde(skip_serializing_if = "Option::is_none")]
    predicted_position: Option<&'a PredictedPosition>,
    observability: InstrumentObservabilityJson<'a>,
}

impl<'a> InstrumentJson<'a> {
    fn new(report: &Report<'_>, instrument: &'a InstrumentEstimate) -> Self {
        InstrumentJson {
            parameters: instrument
                .parameters
                .iter()
                .enumerate()
                .map(|(k, p)| ParameterJson::new(p, report.real_instrument_value(k)))
                .collect(),
            rows: instrument.rows,
            unknowns: instrument.unknowns,
            rms_residual: instrument.rms,
            noise_test: instrument.noise_test.as_ref(),
            outlier_threshold: instrument.outlier_threshold,
            outliers: &instrument.outliers,
            dropped: &instrument.dropped,
            held_frame_test: instrument.held_frame.as_ref(),
            predicted_position: instrument.predicted_position.as_ref(),
            observability: InstrumentObservabilityJson {
                rank: instrument.observability.rank,
                scaled_condition: instrument.observability.scaled_condition,
                weakest_direction: &instrument.observability.weakest_direction,
            },
        }
    }
}

#[derive(Debug, Serialize)]
struct InstrumentObservabilityJson<'a> {
    rank: usize,
    scaled_condition: f64,
    weakest_direction: &'a str,
}

#[derive(Debug, Serialize)]
struct LegJson<'a> {
    name: &'a str,
    measurements: usize,
    parameters: Vec<ParameterJson<'a>>,
    cost_before: f64,
    cost_after: f64,
    residual_sigma: Option<f64>,
    parameter_error_rms_before: Option<f64>,
    parameter_error_rms_after: Option<f64>,
    singular_values: Vec<f64>,
    condition_number: f64,
    scaled_condition_number: f64,
    warnings: Vec<String>,
    noise_test: Option<&'a NoiseTest>,
    outlier_threshold: Option<f64>,
    outliers: &'a [Outlier],
    dropped: &'a [Outlier],
    observability: BTreeMap<&'static str, f64>,
    solver: Option<SolverJson<'a>>,
    covariance_parameters: Vec<&'a str>,
    covariance: Option<Vec<Vec<f64>>>,
    correlation: Option<Vec<Vec<f64>>>,
    rows: Option<Vec<RowJson>>,
}

impl<'a> LegJson<'a> {
    fn new(report: &Report<'_>, result: &'a StrategyResult, leg: &'a LegEstimate) -> Self {
        let o = &leg.observability;
        let from_file = leg.residuals.iter().all(|r| r.line.is_some());
        LegJson {
            name: &leg.leg,
            measurements: leg.measurements,
            parameters: leg
                .parameters
                .iter()
                .enumerate()
                .map(|(i, p)| ParameterJson::new(p, report.real_value(&leg.leg, i)))
                .collect(),
            cost_before: leg.initial_cost,
            cost_after: leg.final_cost,
            residual_sigma: (leg.residual_sigma),
            parameter_error_rms_before: (report.rms_error(leg, false)),
            parameter_error_rms_after: (report.rms_error(leg, true)),
            singular_values: o.singular_values.clone(),
            condition_number: o.condition,
            scaled_condition_number: o.scaled_condition,
            warnings: o
                .warning()
                .into_iter()
                .chain(leg.warnings.iter().cloned())
                .collect(),
            noise_test: leg.statistics.noise_test.as_ref(),
            outlier_threshold: (leg.statistics.outlier_threshold),
            outliers: &leg.statistics.outliers,
            dropped: &leg.dropped,
            observability: ["O1", "O2", "O3", "O4", "O5"]
                .into_iter()
                .zip(o.indices)
                .collect(),
            solver: result
                .runs
                .iter()
                .find(|r| r.legs.contains(&leg.leg))
                .map(|run| SolverJson {
                    name: result.solver.name(),
                    run,
                }),
            covariance_parameters: leg
                .parameters
                .iter()
                .filter(|p| p.identified)
                .map(|p| p.name.as_str())
                .collect(),
            covariance: leg.covariance.as_ref().map(matrix),
            correlation: leg.covariance.as_ref().map(|v| matrix(&correlation(v))),
            rows: from_file.then(|| {
                leg.residuals
                    .iter()
                    .map(|r| RowJson {
                        line: r.line,
                        residual: r.residual,
                    })
                    .collect()
            }),
        }
    }
}

#[derive(Debug, Serialize)]
struct RowJson {
    line: Option<usize>,
    residual: f64,
}

/// A solver run: the solver's name, then the run's own keys.
#[derive(Debug, Serialize)]
struct SolverJson<'a> {
    name: &'static str,
    #[serde(flatten)]
    run: &'a SolverRun,
}

#[cfg(test)]
mod tests {
    use crate::evaluate::accuracy::ErrorStats;

    /// JSON has no NaN or infinity: a non-finite figure is written as `null`, a finite one
    /// as its value.
    #[test]
    fn non_finite_numbers_are_written_as_null() {
        let stats = ErrorStats {
            rms: f64::NAN,
            median: 0.25,
            p95: f64::INFINITY,
            max: f64::NEG_INFINITY,
        };
        let text = serde_json::to_string(&stats).unwrap();
        assert_eq!(text, r#"{"rms":null,"median":0.25,"p95":null,"max":null}"#);
    }
}
