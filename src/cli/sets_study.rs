//! `legwise sets --trials N`: a thin shell over [`crate::study::set_study`].

use std::fmt::Write as _;

use super::args::SetsArgs;
use super::checks;
use super::console::Console;
use super::outputs::model_inputs;
use super::verdict::Verdict;
use crate::files::Output;
use crate::model::Mechanism;
use crate::study::set_study::{set_study, SetStudyResult, MAP_GRID, MAP_SCALE};

/// Most trials of one study.
const MAX_TRIALS: usize = 100_000;

pub(super) fn run(args: &SetsArgs, trials: i64) -> anyhow::Result<Verdict> {
    let trials = checks::count("--trials", trials, 1, MAX_TRIALS)?;
    let seed = checks::seed("--seed", Some(args.seed))?.unwrap_or(1);
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let result = set_study(&mechanism, trials, seed)?;
    let mut console = Console::new(json.as_ref().is_some_and(Output::is_stdout));
    if let Some(json) = &json {
        let text = serde_json::to_string_pretty(&study_json(&result))? + "\n";
        json.write("JSON study", text.as_bytes())?;
    }
    console.print(&study_text(&mechanism, &result))?;
    if let Some(json) = &json {
        console.line(format_args!("JSON study written to {}", json.name()))?;
    }
    let mut reasons = mechanism.warnings.clone();
    let failed = result.trials.iter().filter(|t| t.outcome.is_err()).count();
    if failed > 0 {
        reasons.push(format!(
            "{failed} of {} trials failed (their reasons are in the report)",
            result.trials.len()
        ));
    }
    Ok(Verdict::from_reasons(reasons))
}

/// The study as text.
fn study_text(mechanism: &Mechanism, result: &SetStudyResult) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "legwise sets --trials: {} simulated experiments of {} (seed {}), each set's true error \
         the RMS position error over {} map points ({} m grid over {} of the workspace)",
        result.trials.len(),
        mechanism.name,
        result.seed,
        result.map_points,
        MAP_GRID,
        MAP_SCALE
    );
    if let Some(choice) = result.choice() {
        let _ = writeln!(
            t,
            "  every set (median true error over the experiments that determine it; how often \
             the rows recommend it: the lowest AICc of the sets they determine within the tolerance):"
        );
        for set in &choice.sets {
            let _ = writeln!(
                t,
                "    {:<14} {:>2} factors  determined {:>5}  {:>10} mm  recommended {:>5}",
                set.name,
                set.factors,
                set.determined,
                // `-` for a set no experiment determined.
                Some(set.median_true_error_m * 1e3)
                    .filter(|v| v.is_finite())
                    .map_or("-".to_string(), |v| format!("{v:.4}")),
                set.recommended
            );
            if let Some(line) = set.spread_line() {
                let _ = writeln!(t, "{line}");
            }
        }
        let _ = writeln!(t, "{}", choice.comparison_line("mm", "experiment"));
    }
    for trial in &result.trials {
        if let Err(reason) = &trial.outcome {
            let _ = writeln!(t, "  trial {} failed: {reason}", trial.index);
        }
    }
    t
}

/// The study as JSON: the summary and every trial.
fn study_json(result: &SetStudyResult) -> serde_json::Value {
    let trials: Vec<serde_json::Value> = result
        .trials
        .iter()
        .map(|t| match &t.outcome {
            Ok(sets) => serde_json::json!({"index": t.index, "seed": t.seed, "sets": sets}),
            Err(reason) => serde_json::json!({"index": t.index, "seed": t.seed, "failed": reason}),
        })
        .collect();
    serde_json::json!({
        "seed": result.seed,
        "trials": result.trials.len(),
        "map_points": result.map_points,
        "map_grid_m": MAP_GRID,
        "choice": result.choice(),
        "per_trial": trials,
    })
}
