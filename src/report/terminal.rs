//! The terminal report: per leg, a table of every parameter, then the solver and observability.

use std::fmt::Write;

use super::evaluation::map_summary;
use super::Report;
use crate::identify::estimate::{ParameterEstimate, StrategyResult};
use crate::identify::result::InstrumentEstimate;
use crate::identify::statistics::figure;

/// Formats a number for a table cell (never prints NaN: non-finite shows as `-`).
fn number(value: Option<f64>, width: usize) -> String {
    match value {
        Some(v) if v.is_finite() => format!("{v:>width$.9}"),
        _ => format!("{:>width$}", "-"),
    }
}

fn scientific(value: Option<f64>, width: usize) -> String {
    match value {
        Some(v) if v.is_finite() => format!("{v:>width$.2e}"),
        _ => format!("{:>width$}", "-"),
    }
}

impl Report<'_> {
    /// The report as terminal text (errors in the units of the model; the maps in mm).
    pub fn terminal_text(&self) -> String {
        render(self)
    }
}

/// The whole report as text.
pub fn render(report: &Report<'_>) -> String {
    let mechanism = report.mechanism;
    let mut out = super::title("identify", mechanism);
    if let Some(mode) = &mechanism.mode {
        let _ = writeln!(out, "mode: {mode}");
    }
    let through = mechanism.instrument.as_ref().map_or(String::new(), |i| {
        format!(" (through the instrument: {})", i.columns().join(", "))
    });
    let _ = writeln!(out, "measurements: {}{through}", report.source);
    for issue in report.trust_issues() {
        let _ = writeln!(out, "WARNING: {issue}");
    }
    for result in &report.results {
        render_result(&mut out, report, result);
    }
    if let Some(maps) = &report.maps {
        render_maps(&mut out, report, maps);
    }
    out
}

/// The accuracy maps in millimetres: before, then after each result.
fn render_maps(out: &mut String, report: &Report<'_>, maps: &super::AccuracyMaps) {
    let slice = super::plots::files::map_slice(report.mechanism)
        .map_or(String::new(), |slice| format!(", {slice}"));
    let _ = writeln!(
        out,
        "\naccuracy map over {} of the workspace region, grid {} m{slice}:\n{}",
        maps.before.scale,
        maps.before.grid_m,
        map_summary("  before (nominal model)", &maps.before)
    );
    observed_frame_line(out, &maps.before);
    for (result, map) in report.results.iter().zip(&maps.after) {
        let label = format!("  after, {}", result.strategy.name());
        let _ = writeln!(out, "{}", map_summary(&label, map));
        observed_frame_line(out, map);
    }
}

/// A forward model's map error in the frame its observations define, under the map's line.
fn observed_frame_line(out: &mut String, map: &crate::evaluate::accuracy::AccuracyMap) {
    let Some(seen) = &map.observed_frame else {
        return;
    };
    let aligned = match seen.aligned.is_empty() {
        true => "nothing aligned: the observations see every frame motion".to_string(),
        false => format!(
            "aligned over the frame's motion {} (its own axes), which its reported coordinates \
             cannot see",
            seen.aligned.join(", ")
        ),
    };
    let e = &seen.position_error;
    let _ = writeln!(
        out,
        "    in the frame the observations define (target `{}` in the instrument frame; \
         {aligned}): position error RMS {:.4} mm, median {:.4} mm, p95 {:.4} mm, max {:.4} mm",
        seen.target,
        e.rms * 1e3,
        e.median * 1e3,
        e.p95 * 1e3,
        e.max * 1e3
    );
}

/// The table header of a block of parameters (with the real values' columns in simulation).
fn table_header(known: bool) -> String {
    let mut header = format!(
        "  {:<10} {:>4} {:>15} {:>15} {:>10} {:>10}",
        "parameter", "unit", "nominal", "identified", "std", "± 95 %"
    );
    if known {
        let _ = write!(
            header,
            " {:>15} {:>11} {:>11}",
            "real", "err before", "err after"
        );
    }
    header
}

/// One parameter's row of a table.
fn table_row(p: &ParameterEstimate, real: Option<f64>) -> String {
    let fixed = if p.identified { "" } else { "  (fixed)" };
    let mut row = format!(
        "  {:<10} {:>4} {} {} {} {}",
        p.name,
        p.unit.to_string(),
        number(Some(p.nominal), 15),
        number(Some(p.estimate), 15),
        scientific(p.std, 10),
        scientific(p.half_width95(), 10)
    );
    if let Some(real) = real {
        let _ = write!(
            row,
            " {} {} {}",
            number(Some(real), 15),
            scientific(Some(p.nominal - real), 11),
            scientific(Some(p.estimate - real), 11)
        );
    }
    if let Some(prior) = p.prior {
        let share = p.data_share.map_or(String::new(), |s| {
            format!(", {:.0} % from the data", 100.0 * s)
        });
        let _ = write!(row, "  (prior ±{}{share})", figure(prior));
    }
    format!("{row}{fixed}")
}

/// Every parameter estimate of the result that holds `instrument` (its legs', then the
/// instrument's).
fn result_parameters_of<'r>(
    report: &'r Report<'_>,
    instrument: &'r InstrumentEstimate,
) -> impl Iterator<Item = &'r crate::identify::result::ParameterEstimate> {
    report
        .results
        .iter()
        .filter(move |r| {
            r.instrument
                .as_ref()
                .is_some_and(|i| std::ptr::eq(i, instrument))
        })
        .flat_map(|r| r.legs.iter().flat_map(|l| &l.parameters))
        .chain(&instrument.parameters)
}

/// The note that the σ are the declared noise's, unscaled, when some parameter's are (too few
/// residual degrees of freedom to scale them by σ̂, `sandwich::SCALE_DOF`).
pub(crate) fn declared_sigma_note<'p>(
    mut parameters: impl Iterator<Item = &'p crate::identify::result::ParameterEstimate>,
) -> Option<String> {
    parameters.any(|p| p.std_from_declared_noise()).then(|| {
        format!(
            "σ from the declared noise, not scaled by σ̂: fewer than {} residual degrees of \
             freedom (docs/statistics.md, \"Few degrees of freedom\"); 95 % intervals ±1.96 σ",
            crate::identify::sandwich::SCALE_DOF
        )
    })
}

/// The instrument's block: the fit as a whole, then its parameters.
fn render_instrument(out: &mut String, report: &Report<'_>, instrument: &InstrumentEstimate) {
    let _ = writeln!(
        out,
        "\ninstrument ({} rows, {} unknowns in all; RMS residual {:.3e})",
        instrument.rows, instrument.unknowns, instrument.rms
    );
    if let Some(test) = &instrument.noise_test {
        let _ = writeln!(
            out,
            "  residuals vs declared noise: σ̂/σ {:.3}, χ² {:.1} on {} dof, p = {:.3e}{}",
            test.sigma_ratio,
            test.chi_squared,
            test.degrees_of_freedom,
            test.p_value,
            if test.rejected { " (REJECTED)" } else { "" }
        );
    }
    let priors = result_parameters_of(report, instrument)
        .filter(|p| p.prior.is_some())
        .count();
    if priors > 0 {
        let unseen = &instrument.observability.resting_on_prior;
        let _ = writeln!(
            out,
            "  priors: {priors} rows (the fit is the maximum a posteriori one; the noise test \
             counts them){}",
            match unseen.is_empty() {
                true => String::new(),
                false => format!(
                    "; the data alone cannot see {}: it rests on the priors",
                    unseen.join("; ")
                ),
            }
        );
    }
    if let (Some(limit), Some(largest)) = (
        instrument.outlier_threshold,
        instrument.outliers.first().map(|o| o.t.abs()).or(Some(0.0)),
    ) {
        let _ = writeln!(
            out,
            "  outliers: {} beyond |t| > {}{}",
            instrument.outliers.len(),
            figure(limit),
            if largest > 0.0 {
                format!(" (largest |t| {})", figure(largest))
            } else {
                String::new()
            }
        );
        for o in &instrument.outliers {
            let _ = writeln!(
                out,
                "    {}: residual {}, t = {}",
                o.place,
                figure(o.residual),
                figure(o.t)
            );
        }
    }
    for o in &instrument.dropped {
        let _ = writeln!(
            out,
            "  dropped {} (t = {} in the first fit)",
            o.place,
            figure(o.t)
        );
    }
    if let Some(note) = declared_sigma_note(result_parameters_of(report, instrument)) {
        let _ = writeln!(out, "  {note}");
    }
    if let Some(test) = &instrument.held_frame {
        let _ = writeln!(
            out,
            "  held frame ({}) vs freed: χ² drop {:.1} on {} dof, p = {:.3e}{}",
            test.freed.join(", "),
            test.chi_squared_drop,
            test.degrees_of_freedom,
            test.p_value,
            if test.rejected { " (REJECTED)" } else { "" }
        );
    }
    if let Some(predicted) = &instrument.predicted_position {
        let tolerance = predicted.tolerance.map_or(String::new(), |t| {
            let verdict = if predicted.max > t { "ABOVE" } else { "within" };
            format!("; {verdict} the model's tolerance {:.4} mm", t * 1e3)
        });
        let _ = writeln!(
            out,
            "  predicted σ of target `{}`'s position over the workspace ({} points): RMS {:.4} \
             mm, max {:.4} mm{tolerance}",
            predicted.target,
            predicted.points,
            predicted.rms * 1e3,
            predicted.max * 1e3
        );
    }
    let _ = writeln!(out, "{}", table_header(report.real.is_some()));
    for (k, p) in instrument.parameters.iter().enumerate() {
        let _ = writeln!(out, "{}", table_row(p, report.real_instrument_value(k)));
    }
}

fn render_result(out: &mut String, report: &Report<'_>, result: &StrategyResult) {
    let _ = writeln!(
        out,
        "\n=== {} — {} ===",
        result.strategy.name(),
        result.solver.name()
    );
    let _ = writeln!(out, "fit: {}", fit_text(result));
    if let Some(instrument) = &result.instrument {
        render_instrument(out, report, instrument);
    }
    let known = report.real.is_some();
    for name in report.fixed_legs(result) {
        let _ = writeln!(
            out,
            "\nleg {name}: every parameter is held fixed (identify: false); not identified"
        );
    }
    // Seen through the forward kinematics, every row holds every leg's reading: no leg has
    // rows, costs or a σ̂ of its own (the instrument block has them).
    let forward = report.mechanism.forward_instrument().is_some();
    for leg in &result.legs {
        match forward {
            true => {
                let _ = writeln!(
                    out,
                    "\nleg {} (its reading in every row: the rows are the instrument's above)",
                    leg.leg
                );
            }
            false => {
                let _ = writeln!(out, "\nleg {} ({} readings)", leg.leg, leg.measurements);
            }
        }
        let _ = writeln!(out, "{}", table_header(known));
        for (i, p) in leg.parameters.iter().enumerate() {
            let _ = writeln!(out, "{}", table_row(p, report.real_value(&leg.leg, i)));
        }
        if let (Some(before), Some(after)) =
            (report.rms_error(leg, false), report.rms_error(leg, true))
        {
            let _ = writeln!(
                out,
                "  parameter error RMS: {before:.3e} before, {after:.3e} after"
            );
        }
        if let Some(run) = result.runs.iter().find(|r| r.legs.contains(&leg.leg)) {
            let shared = if run.legs.len() > 1 {
                format!(" (one run for legs {})", run.legs.join(", "))
            } else {
                String::new()
            };
            let verdict = if run.converged {
                "converged"
            } else {
                "NOT CONVERGED"
            };
            let refined = match run.refinement_steps {
                0 => String::new(),
                1 => "; refined by 1 Gauss-Newton step".to_string(),
                n => format!("; refined by {n} Gauss-Newton steps"),
            };
            let _ = writeln!(
                out,
                "  solver: {}, {} iterations, {} residual / {} Jacobian evaluations, {:.2} ms: {verdict} ({}){refined}{shared}",
                result.solver.name(),
                run.iterations,
                run.residual_evaluations,
                run.jacobian_evaluations,
                run.seconds * 1e3,
                run.stop_reason
            );
        }
        let sigma = leg
            .residual_sigma
            .map_or("-".to_string(), |s| format!("{s:.3e}"));
        if !forward {
            let _ = writeln!(
                out,
                "  cost ½‖r‖²: {:.6e} before, {:.6e} after; residual σ̂ {sigma}",
                leg.initial_cost, leg.final_cost
            );
        }
        let values: Vec<String> = leg
            .observability
            .singular_values
            .iter()
            .map(|s| format!("{s:.4}"))
            .collect();
        let condition = if leg.observability.condition.is_finite() {
            format!("{:.1}", leg.observability.condition)
        } else {
            "infinite".into()
        };
        let _ = writeln!(
            out,
            "  singular values: [{}]; condition number {condition}",
            values.join(", ")
        );
        let [o1, o2, o3, o4, o5] = leg.observability.indices;
        let _ = writeln!(
            out,
            "  observability: O1 {o1:.4}, O2 {o2:.3e}, O3 {o3:.4}, O4 {o4:.3e}, O5 {o5:.4}"
        );
        if let Some(warning) = leg.observability.warning() {
            let _ = writeln!(out, "  warning: {warning}");
        }
        if result.instrument.is_none() {
            let no_test = why_no_noise_test(report, result);
            render_statistics(out, leg, no_test);
            if let Some(note) = declared_sigma_note(leg.parameters.iter()) {
                let _ = writeln!(out, "  {note}");
            }
        }
    }
    let warnings = result.all_warnings();
    if !warnings.is_empty() {
        let _ = writeln!(out, "\nwarnings ({}):", warnings.len());
        for warning in warnings {
            let _ = writeln!(out, "  - {warning}");
        }
    }
}

/// The fit options in words.
fn fit_text(result: &StrategyResult) -> String {
    use crate::identify::estimate::Weighting;
    let options = &result.options;
    let mut text = match (options.robust, options.weights) {
        (Some(loss), _) => format!(
            "robust {} loss scaled by the declared noise (iteratively reweighted); costs and σ̂ are of the weighted residuals, σ the noise-weighted fit's times the loss's variance factor {:.4}",
            loss.name(),
            loss.variance_factor()
        ),
        (None, Weighting::Noise) if result.instrument.is_some() => "least squares weighted by the declared noise (at the estimate); costs and residuals in measurement units, σ the sandwich of the weighted fit".to_string(),
        (None, Weighting::Noise) => "least squares weighted by the declared noise (at the estimate); costs and σ̂ are of the weighted (dimensionless) residuals".to_string(),
        (None, Weighting::Unweighted | Weighting::Declared) => "unweighted least squares".to_string(),
    };
    if options.drop_outliers {
        text.push_str("; refitted without the outlier rows");
    }
    text
}

/// Why a leg of `result` has no noise test: the model declares no noise, the run scaled it to
/// zero, or the leg has no redundancy.
fn why_no_noise_test(report: &Report<'_>, result: &StrategyResult) -> &'static str {
    match (
        report.mechanism.noise,
        result.options.expected_noise(report.mechanism),
    ) {
        (None, _) => "the model declares no `noise:` block",
        (Some(_), None) if result.options.noise_scale <= 0.0 => {
            "the declared noise is scaled to zero by --noise-scale 0"
        }
        (Some(_), None) => "every σ of the model's `noise:` block is zero",
        (Some(_), Some(_)) => "no redundancy: no more readings than parameters",
    }
}

/// The noise test and outlier lines of a leg (`no_test`: why it has no noise test, if so).
fn render_statistics(
    out: &mut String,
    leg: &crate::identify::estimate::LegEstimate,
    no_test: &str,
) {
    let stats = &leg.statistics;
    match &stats.noise_test {
        Some(test) => {
            let verdict = if test.rejected {
                "REJECTED"
            } else {
                "consistent"
            };
            let excluded = if test.excluded > 0 {
                format!(", {} outlier row(s) left out", test.excluded)
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "  noise test: {verdict}: σ̂/σ expected {}, χ² {:.4e} with {} degrees of freedom, p = {:.3e}{excluded}",
                figure(test.sigma_ratio), test.chi_squared, test.degrees_of_freedom, test.p_value
            );
        }
        None => {
            let _ = writeln!(out, "  noise test: not done ({no_test})");
        }
    }
    if let (Some(limit), Some(largest)) = (stats.outlier_threshold, stats.largest_t) {
        let _ = writeln!(
            out,
            "  outliers: {} beyond |t| > {} (largest |t| {})",
            stats.outliers.len(),
            figure(limit),
            figure(largest)
        );
    }
}
