//! `legwise evaluate`.

use std::path::Path;

use super::args::EvaluateArgs;
use super::console::Console;
use super::verdict::Verdict;
use crate::evaluate::evaluate;
use crate::evaluate::held_out::Evaluation;
use crate::files::{Input, Output};
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::report::evaluation::{evaluation_json, evaluation_text};
use crate::report::plots::files::{evaluate_picture, POSITION_ERRORS};

pub(super) fn run(args: &EvaluateArgs) -> anyhow::Result<Verdict> {
    let mechanism = Mechanism::load(&args.model)?;
    let other = args.against.as_deref().map(Mechanism::load).transpose()?;
    if let (Some(path), Some(other)) = (&args.against, &other) {
        Measurements::same_layout(&mechanism, other)
            .map_err(|e| anyhow::anyhow!("--against {}: {e}", path.display()))?;
    }
    let mut inputs = super::checks::model_inputs(&args.model, &mechanism);
    if let (Some(path), Some(other)) = (&args.against, &other) {
        inputs.extend(super::checks::model_inputs(path, other));
    }
    inputs.push(Input {
        role: "measurement file",
        path: &args.measurements,
    });
    let json_output = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let format = crate::files::format(args.png);
    let picture_output =
        crate::files::prepare_one(args.plots.as_deref(), POSITION_ERRORS, format, &inputs)?;
    let mut console = Console::new(json_output.as_ref().is_some_and(Output::is_stdout));
    let evaluation = evaluate_file(&mechanism, &args.measurements)?;
    let against = other
        .as_ref()
        .map(|other| evaluate_file(other, &args.measurements))
        .transpose()?;
    // The file first: a closed terminal pipe must not lose it.
    if let Some(output) = &json_output {
        let value = evaluation_json(&evaluation, against.as_ref());
        let text = serde_json::to_string_pretty(&value)? + "\n";
        output.write("JSON evaluation", text.as_bytes())?;
    }
    if let Some(output) = &picture_output {
        // The other model (typically the nominal one) is drawn first, as "before".
        let (model, other_name) = (
            file_name(&args.model),
            args.against.as_deref().map(file_name),
        );
        let mut drawn = Vec::new();
        if let (Some(name), Some(against)) = (&other_name, &against) {
            drawn.push((name.as_str(), against));
        }
        drawn.push((model.as_str(), &evaluation));
        output.write("picture", &evaluate_picture(&drawn, format)?)?;
    }
    console.print(&evaluation_text(&mechanism, &evaluation, against.as_ref()))?;
    if let Some(output) = json_output.filter(|o| !o.is_stdout()) {
        console.line(format_args!("\nJSON written to {}", output.name()))?;
    }
    if let Some(output) = picture_output {
        console.line(format_args!("picture written to {}", output.name()))?;
    }
    Ok(Verdict::Trusted)
}

/// Evaluates `model` on the measurement file at `path` (read in the model's layout).
fn evaluate_file(model: &Mechanism, path: &Path) -> anyhow::Result<Evaluation> {
    Ok(evaluate(model, &Measurements::read(path, model)?)?)
}

/// A model's file name, for the picture's legend.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
