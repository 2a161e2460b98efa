//! The JSON report (`--json PATH`), documented in docs/report.md: built from [`Serialize`]
//! types that mirror the schema, the same for every set-up (an instrument's parameters are one
//! more block of parameters, with the same keys as a leg's). Non-finite numbers are written as
//! `null`, never as NaN.

use nalgebra::DMatrix;
use serde::Serialize;
use serde_json::{json, Value};

use super::Report;
use crate::evaluate::accuracy::{AccuracyMap, ErrorStats};
use crate::identify::estimate::{
    LegEstimate, ParameterEstimate, SolverRun, StrategyResult, Weighting,
};
use crate::identify::result::{HeldFrameTest, InstrumentEstimate};
use crate::identify::statistics::{NoiseTest, Outlier};

/// Version of the JSON layout documented in `docs/report.md`; raised when a key changes meaning or
/// disappears (new keys do not change it).
pub const SCHEMA_VERSION: u32 = 2;

/// The keys every legwise JSON document starts with: the schema and the program version.
pub fn header() -> Value {
    json!({
        "schema_version": SCHEMA_VERSION,
        "legwise_version": env!("CARGO_PKG_VERSION"),
    })
}

/// Merges the keys of the object `extra` into the object `value` (later keys win).
pub fn merge(value: &mut Value, extra: Value) {
    if let (Value::Object(target), Value::Object(source)) = (value, extra) {
        target.extend(source);
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
    results: Vec<ResultJson<'a>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    accuracy_map_before: Option<MapJson>,
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
            results: report
                .results
                .iter()
                .enumerate()
                .map(|(i, r)| ResultJson::new(report, r, maps.and_then(|m| m.after.get(i))))
                .collect(),
            accuracy_map_before: maps.map(|m| MapJson::new(&m.before)),
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
    instrument: Option<InstrumentJson<'a>>,
    legs: Vec<LegJson<'a>>,
    fixed_legs: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    accuracy_map: Option<MapJson>,
}

impl<'a> ResultJson<'a> {
    fn new(report: &'a Report<'_>, result: &'a StrategyResult, map: Option<&AccuracyMap>) -> Self {
        ResultJson {
            strategy: result.strategy.name(),
            solver: result.solver.short_name(),
            weights: match result.options.weights {
                Weighting::Unweighted => "none",
                Weighting::Noise => "noise",
            },
            robust: result.options.robust.map(|r| r.name()),
            drop_outliers: result.options.drop_outliers,
            warnings: result.all_warnings(),
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
            accuracy_map: map.map(MapJson::new),
        }
    }
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
    real: Option<f64>,
    error_before: Option<f64>,
    error_after: Option<f64>,
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
            real: (real),
            error_before: (real.map(|r| p.nominal - r)),
            error_after: (real.map(|r| p.estimate - r)),
        }
    }
}

#[derive(Debug, Serialize)]
struct InstrumentJson<'a> {
    parameters: Vec<ParameterJson<'a>>,
    rows: usize,
    unknowns: usize,
    rms_residual: f64,
    noise_test: Option<NoiseTestJson>,
    held_frame_test: Option<HeldFrameJson<'a>>,
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
            noise_test: instrument.noise_test.as_ref().map(NoiseTestJson::new),
            held_frame_test: instrument.held_frame.as_ref().map(HeldFrameJson::new),
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
struct HeldFrameJson<'a> {
    freed: &'a [String],
    chi_squared_drop: f64,
    degrees_of_freedom: usize,
    p_value: f64,
    rejected: bool,
    estimates: Vec<f64>,
}

impl<'a> HeldFrameJson<'a> {
    fn new(test: &'a HeldFrameTest) -> Self {
        HeldFrameJson {
            freed: &test.freed,
            chi_squared_drop: test.chi_squared_drop,
            degrees_of_freedom: test.degrees_of_freedom,
            p_value: test.p_value,
            rejected: test.rejected,
            estimates: test.estimates.clone(),
        }
    }
}

#[derive(Debug, Serialize)]
struct NoiseTestJson {
    chi_squared: f64,
    degrees_of_freedom: usize,
    p_value: f64,
    sigma_ratio: f64,
    residual_sigma: f64,
    expected_sigma: f64,
    excluded_rows: usize,
    rejected: bool,
}

impl NoiseTestJson {
    fn new(t: &NoiseTest) -> Self {
        NoiseTestJson {
            chi_squared: t.chi_squared,
            degrees_of_freedom: t.degrees_of_freedom,
            p_value: t.p_value,
            sigma_ratio: t.sigma_ratio,
            residual_sigma: t.residual_sigma,
            expected_sigma: t.expected_sigma,
            excluded_rows: t.excluded,
            rejected: t.rejected,
        }
    }
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
    noise_test: Option<NoiseTestJson>,
    outlier_threshold: Option<f64>,
    outliers: Vec<OutlierJson<'a>>,
    dropped: Vec<OutlierJson<'a>>,
    observability: IndicesJson,
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
            noise_test: leg.statistics.noise_test.as_ref().map(NoiseTestJson::new),
            outlier_threshold: (leg.statistics.outlier_threshold),
            outliers: leg
                .statistics
                .outliers
                .iter()
                .map(OutlierJson::new)
                .collect(),
            dropped: leg.dropped.iter().map(OutlierJson::new).collect(),
            observability: IndicesJson {
                o1: o.indices[0],
                o2: o.indices[1],
                o3: o.indices[2],
                o4: o.indices[3],
                o5: o.indices[4],
            },
            solver: result
                .runs
                .iter()
                .find(|r| r.legs.contains(&leg.leg))
                .map(|run| SolverJson::new(result, run)),
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
struct IndicesJson {
    #[serde(rename = "O1")]
    o1: f64,
    #[serde(rename = "O2")]
    o2: f64,
    #[serde(rename = "O3")]
    o3: f64,
    #[serde(rename = "O4")]
    o4: f64,
    #[serde(rename = "O5")]
    o5: f64,
}

#[derive(Debug, Serialize)]
struct RowJson {
    line: Option<usize>,
    residual: f64,
}

#[derive(Debug, Serialize)]
struct SolverJson<'a> {
    name: &'static str,
    legs: &'a [String],
    iterations: u64,
    converged: bool,
    stop_reason: &'static str,
    refinement_steps: usize,
    cost_before: f64,
    cost_after: f64,
    residual_evaluations: u64,
    jacobian_evaluations: u64,
    seconds: f64,
}

impl<'a> SolverJson<'a> {
    fn new(result: &StrategyResult, run: &'a SolverRun) -> Self {
        SolverJson {
            name: result.solver.name(),
            legs: &run.legs,
            iterations: run.iterations,
            converged: run.converged,
            stop_reason: run.stop_reason.key(),
            refinement_steps: run.refinement_steps,
            cost_before: run.initial_cost,
            cost_after: run.final_cost,
            residual_evaluations: run.residual_evaluations,
            jacobian_evaluations: run.jacobian_evaluations,
            seconds: run.seconds,
        }
    }
}

#[derive(Debug, Serialize)]
struct OutlierJson<'a> {
    line: Option<usize>,
    pose: &'a str,
    reading: f64,
    residual: f64,
    t: f64,
}

impl<'a> OutlierJson<'a> {
    fn new(o: &'a Outlier) -> Self {
        OutlierJson {
            line: o.line,
            pose: &o.pose,
            reading: o.reading,
            residual: o.residual,
            t: o.t,
        }
    }
}

/// An accuracy map (docs/report.md, "Accuracy maps").
#[derive(Debug, Serialize)]
pub struct MapJson {
    grid_m: f64,
    scale: f64,
    points: Vec<MapPointJson>,
    non_assemblable: usize,
    position_error_m: StatsJson,
    orientation_error_rad: Option<StatsJson>,
}

impl MapJson {
    /// The map's document.
    pub fn new(map: &AccuracyMap) -> Self {
        MapJson {
            grid_m: map.grid_m,
            scale: map.scale,
            points: map
                .points
                .iter()
                .map(|p| MapPointJson {
                    pose: p.pose,
                    position_error_m: (p.position_error),
                    orientation_error_rad: (p.orientation_error),
                })
                .collect(),
            non_assemblable: map.non_assemblable,
            position_error_m: StatsJson::new(&map.position_error),
            orientation_error_rad: map.orientation_error.as_ref().map(StatsJson::new),
        }
    }
}

#[derive(Debug, Serialize)]
struct MapPointJson {
    pose: [f64; 6],
    position_error_m: Option<f64>,
    orientation_error_rad: Option<f64>,
}

/// `{"rms", "median", "p95", "max"}` of an error.
#[derive(Debug, Serialize)]
pub struct StatsJson {
    rms: f64,
    median: f64,
    p95: f64,
    max: f64,
}

impl StatsJson {
    /// The statistics' document.
    pub fn new(s: &ErrorStats) -> Self {
        StatsJson {
            rms: s.rms,
            median: s.median,
            p95: s.p95,
            max: s.max,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::StatsJson;
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
        let text = serde_json::to_string(&StatsJson::new(&stats)).unwrap();
        assert_eq!(text, r#"{"rms":null,"median":0.25,"p95":null,"max":null}"#);
    }
}
