//! `legwise evaluate`.

use std::path::Path;

use super::args::EvaluateArgs;
use super::outputs::{file_name, input, model_inputs, ReportFiles};
use super::verdict::Verdict;
use crate::evaluate::evaluate;
use crate::evaluate::held_out::Evaluation;
use crate::files::{prepare, Output};
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::report::evaluation::{evaluation_json, evaluation_text};
use crate::report::plots::files::{evaluate_picture, POSITION_ERRORS};

pub(super) fn run(args: &EvaluateArgs) -> anyhow::Result<Verdict> {
    super::checks::png_needs_plots(args.png, args.plots.as_deref())?;
    let mechanism = Mechanism::load(&args.model)?;
    let other = args.against.as_deref().map(Mechanism::load).transpose()?;
    let mut inputs = model_inputs(&args.model, &mechanism);
    if let (Some(path), Some(other)) = (&args.against, &other) {
        Measurements::same_layout(&mechanism, other)
            .map_err(|e| anyhow::anyhow!("--against {}: {e}", path.display()))?;
        inputs.extend(model_inputs(path, other));
    }
    inputs.push(input("measurement file", &args.measurements));
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let format = crate::files::format(args.png);
    let pictures = prepare(args.plots.as_deref(), &[POSITION_ERRORS], format, &inputs)?;
    let outputs = ReportFiles { json, pictures };
    let mut console = outputs.console();
    let evaluation = evaluate_file(&mechanism, &args.measurements)?;
    let against = match (&other, &args.against) {
        (Some(other), Some(path)) => {
            Some(evaluate_file(other, &args.measurements).map_err(|e| {
                anyhow::anyhow!(
                    "--against {}: the measurement file does not read as that model's: {e:#}",
                    path.display()
                )
            })?)
        }
        _ => None,
    };
    outputs.write_json("JSON evaluation", || {
        let value = evaluation_json(&evaluation, against.as_ref());
        Ok(serde_json::to_string_pretty(&value)? + "\n")
    })?;
    outputs.write_pictures(|| {
        // The other model (typically the nominal one) is drawn first, as "before".
        let other_name = args.against.as_deref().map(file_name);
        let model = file_name(&args.model);
        let mut drawn = Vec::from_iter(other_name.as_deref().zip(against.as_ref()));
        drawn.push((model.as_str(), &evaluation));
        Ok(vec![evaluate_picture(&drawn, format)?])
    })?;
    console.print(&evaluation_text(&mechanism, &evaluation, against.as_ref()))?;
    outputs.say_written(&mut console, "JSON")?;
    let mut issues = mechanism.warnings.clone();
    issues.extend(other.iter().flat_map(|other| other.warnings.clone()));
    issues.extend(evaluation.trust_issues());
    issues.extend(against.iter().flat_map(Evaluation::trust_issues));
    Ok(Verdict::from_reasons(issues))
}

/// Evaluates `model` on the measurement file at `path` (read in the model's layout).
fn evaluate_file(model: &Mechanism, path: &Path) -> anyhow::Result<Evaluation> {
    Ok(evaluate(model, &Measurements::read(path, model)?)?)
}
