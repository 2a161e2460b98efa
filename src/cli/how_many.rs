//! `legwise how-many`: a thin shell over [`crate::study::how_many`].

use std::fmt::Write as _;

use super::args::HowManyArgs;
use super::checks;
use super::console::Console;
use super::outputs::model_inputs;
use super::verdict::Verdict;
use crate::files::Output;
use crate::model::Mechanism;
use crate::report::plots::count_curve::{CountCurve, CountSeries};
use crate::report::plots::render;
use crate::study::how_many::{default_counts, predicted_by_count, CountPoint};

/// Most rows asked for at one count.
const MAX_COUNT: usize = 100_000;

pub(super) fn run(args: &HowManyArgs) -> anyhow::Result<Verdict> {
    let counts = match &args.counts {
        Some(counts) => counts
            .iter()
            .map(|&c| checks::count("--counts", c, 1, MAX_COUNT))
            .collect::<anyhow::Result<Vec<usize>>>()?,
        None => Vec::new(),
    };
    let seed = checks::seed("--seed", args.seed)?;
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    checks::png_needs_plots(args.png, args.plots.as_deref())?;
    let format = crate::files::format(args.png);
    let pictures = crate::files::prepare(args.plots.as_deref(), &[PICTURE], format, &inputs)?;
    let counts = match counts.is_empty() {
        true => default_counts(mechanism.selection.poses_per_leg),
        false => counts,
    };
    let points = predicted_by_count(&mechanism, &counts, seed)?;
    let mut console = Console::new(json.as_ref().is_some_and(Output::is_stdout));
    if let Some(json) = &json {
        let text = serde_json::to_string_pretty(&table_json(&points))? + "\n";
        json.write("JSON table", text.as_bytes())?;
    }
    if let Some(output) = pictures.first() {
        output.write("picture", &render(&curve(&mechanism, &points), format)?)?;
    }
    console.print(&table_text(&mechanism, &points))?;
    if let Some(json) = &json {
        console.line(format_args!("JSON table written to {}", json.name()))?;
    }
    for output in &pictures {
        console.line(format_args!("picture written to {}", output.name()))?;
    }
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}

/// The picture's file name (without extension).
const PICTURE: &str = "how-many";

/// The curves: the design's RMS and max, identify's RMS, at every count that has them.
fn curve(mechanism: &Mechanism, points: &[CountPoint]) -> CountCurve {
    let of = |f: &dyn Fn(&CountPoint) -> Option<f64>| -> Vec<(usize, f64)> {
        points
            .iter()
            .filter_map(|p| f(p).map(|v| (p.count, v)))
            .collect()
    };
    CountCurve {
        title: format!(
            "{}: predicted σ over the workspace against the rows",
            mechanism.name
        ),
        model_count: Some(mechanism.selection.poses_per_leg),
        series: vec![
            CountSeries {
                name: "design σ, RMS".into(),
                points: of(&|p| p.design.as_ref().map(|d| d.rms)),
            },
            CountSeries {
                name: "design σ, max".into(),
                points: of(&|p| p.design.as_ref().map(|d| d.max)),
            },
            CountSeries {
                name: "identify's σ, RMS".into(),
                points: of(&|p| p.predicted.as_ref().ok().map(|d| d.rms)),
            },
        ],
    }
}

/// The table as JSON: per count, the predicted σ or why there is none.
fn table_json(points: &[CountPoint]) -> serde_json::Value {
    serde_json::Value::Array(
        points
            .iter()
            .map(|p| match &p.predicted {
                Ok(predicted) => serde_json::json!({
                    "count": p.count, "predicted": predicted, "design": p.design,
                }),
                Err(reason) => serde_json::json!({"count": p.count, "none": reason}),
            })
            .collect(),
    )
}

/// The table as text.
fn table_text(mechanism: &Mechanism, points: &[CountPoint]) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "legwise how-many: {} (model's own count {}): the predicted σ of the target over the \
         workspace after the default fit on N selected rows",
        mechanism.name, mechanism.selection.poses_per_leg
    );
    let _ = writeln!(
        t,
        "\n{:>7}  {:>24}  {:>26}  within tolerance",
        "rows", "design σ RMS / max (m)", "identify's RMS / max (m)"
    );
    for p in points {
        match &p.predicted {
            Ok(q) => {
                let within = q.tolerance.map_or("-".to_string(), |t| {
                    (if q.max <= t { "yes" } else { "no" }).to_string()
                });
                let design = p.design.as_ref().map_or("-".to_string(), |d| {
                    format!("{:.3e} / {:.3e}", d.rms, d.max)
                });
                let identify = format!("{:.3e} / {:.3e}", q.rms, q.max);
                let _ = writeln!(t, "{:>7}  {design:>24}  {identify:>26}  {within}", p.count);
            }
            Err(reason) => {
                let _ = writeln!(t, "{:>7}  {reason}", p.count);
            }
        }
    }
    let _ = writeln!(
        t,
        "\nEach row is `legwise identify --model {} --poses-per-leg N` (the rows `legwise select` \
         picks, the simulated experiment, the default fit). design σ: from the declared noise \
         alone, what the rows' placement promises; identify's: as `identify` reports it, with \
         12 or more residual degrees of freedom a sandwich of the experiment's residuals, which \
         varies with its noise. Where the design σ stops falling, more rows stop paying.",
        mechanism.model_path.display()
    );
    t
}
