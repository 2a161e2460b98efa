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
    let models = Models::load(args)?;
    let mut inputs = model_inputs(&args.model, &models.model);
    if let (Some(path), Some(other)) = (&args.against, &models.other) {
        inputs.extend(model_inputs(path, other));
    }
    inputs.push(input("measurement file", &args.measurements));
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let format = crate::files::format(args.png);
    let pictures = prepare(args.plots.as_deref(), &[POSITION_ERRORS], format, &inputs)?;
    let outputs = ReportFiles { json, pictures };
    let mut console = outputs.console();
    let (evaluation, against) =
        models.evaluate(args, |model| Measurements::read(&args.measurements, model))?;
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
        Ok(vec![evaluate_picture(&models.model, &drawn, format)?])
    })?;
    console.print(&evaluation_text(
        &models.model,
        &evaluation,
        against.as_ref(),
    ))?;
    outputs.say_written(&mut console, "JSON")?;
    Ok(Verdict::from_reasons(
        models.trust_issues(&evaluation, against.as_ref()),
    ))
}

/// The model evaluated and the one it is compared with (`--against`), loaded and checked to
/// read the same measurement file.
#[derive(Debug)]
pub(super) struct Models {
    /// `--model`.
    pub(super) model: Mechanism,
    /// `--against`, if given.
    pub(super) other: Option<Mechanism>,
}

impl Models {
    /// The models of `args`.
    ///
    /// # Errors
    /// A model that does not load, or two models that read different measurement files.
    pub(super) fn load(args: &EvaluateArgs) -> anyhow::Result<Models> {
        let model = Mechanism::load(&args.model)?;
        let other = args.against.as_deref().map(Mechanism::load).transpose()?;
        if let (Some(path), Some(other)) = (&args.against, &other) {
            Measurements::same_layout(&model, other)
                .map_err(|e| anyhow::anyhow!("--against {}: {e}", path.display()))?;
        }
        Ok(Models { model, other })
    }

    /// Evaluates each model on the measurements `read` gives in its layout: the model's
    /// evaluation and the other's.
    ///
    /// # Errors
    /// Measurements that do not read as a model's, or an evaluation that fails.
    pub(super) fn evaluate(
        &self,
        args: &EvaluateArgs,
        read: impl Fn(&Mechanism) -> crate::Result<Measurements>,
    ) -> anyhow::Result<(Evaluation, Option<Evaluation>)> {
        let evaluation = evaluate(&self.model, &read(&self.model)?)?;
        let against = match (&self.other, &args.against) {
            (Some(other), Some(path)) => Some(evaluated(other, &read, path)?),
            _ => None,
        };
        Ok((evaluation, against))
    }

    /// Why the evaluations must not be trusted: the models' warnings and the evaluations'.
    pub(super) fn trust_issues(
        &self,
        evaluation: &Evaluation,
        against: Option<&Evaluation>,
    ) -> Vec<String> {
        let mut issues = self.model.warnings.clone();
        issues.extend(self.other.iter().flat_map(|other| other.warnings.clone()));
        issues.extend(evaluation.trust_issues());
        issues.extend(against.iter().flat_map(|a| a.trust_issues()));
        issues
    }
}

/// The evaluation of the `--against` model `other` (file `path`).
fn evaluated(
    other: &Mechanism,
    read: impl Fn(&Mechanism) -> crate::Result<Measurements>,
    path: &Path,
) -> anyhow::Result<Evaluation> {
    let evaluation = read(other).and_then(|data| evaluate(other, &data));
    evaluation.map_err(|e| {
        anyhow::anyhow!(
            "--against {}: the measurement file does not read as that model's: {e:#}",
            path.display()
        )
    })
}
