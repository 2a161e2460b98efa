//! `legwise evaluate`.

use super::console::Console;
use super::output::{Input, Output};
use super::{EvaluateArgs, Verdict};
use crate::evaluate::held_out::evaluate;
use crate::evaluate::report::{evaluation_json, evaluation_text};
use crate::measure::file;
use crate::model::Mechanism;

pub(super) fn run(args: &EvaluateArgs) -> anyhow::Result<Verdict> {
    let mechanism = Mechanism::load(&args.model)?;
    let other = args.against.as_deref().map(Mechanism::load).transpose()?;
    let mut inputs = super::model_inputs(&args.model, &mechanism);
    if let (Some(path), Some(other)) = (&args.against, &other) {
        inputs.extend(super::model_inputs(path, other));
    }
    inputs.push(Input {
        role: "measurement file",
        path: &args.measurements,
    });
    let json_output = args
        .json
        .as_deref()
        .map(|path| Output::prepare("--json", path, &inputs))
        .transpose()?;
    if args.plots.is_some() {
        anyhow::bail!("--plots: the evaluation pictures are not available in this build yet");
    }
    let mut console = Console::new(json_output.as_ref().is_some_and(Output::is_stdout));
    let evaluation = evaluate(&mechanism, &file::read(&args.measurements, &mechanism)?)?;
    let against = match &other {
        Some(other) => Some(evaluate(other, &file::read(&args.measurements, other)?)?),
        None => None,
    };
    // The file first: a closed terminal pipe must not lose it.
    if let Some(output) = &json_output {
        let value = evaluation_json(&evaluation, against.as_ref());
        let text = serde_json::to_string_pretty(&value)? + "\n";
        output.write("JSON evaluation", text.as_bytes())?;
    }
    console.print(&evaluation_text(&mechanism, &evaluation, against.as_ref()))?;
    if let Some(output) = json_output.filter(|o| !o.is_stdout()) {
        console.line(format_args!("\nJSON written to {}", output.name()))?;
    }
    Ok(Verdict::Trusted)
}
