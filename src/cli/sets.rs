//! `legwise sets`: the model's own set and each of its factor sets fitted on the same
//! measurements (or its simulation), one table.

use super::args::SetsArgs;
use super::console::Console;
use super::outputs::{input, model_inputs};
use super::verdict::Verdict;
use crate::files::Output;
use crate::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::pipeline::{simulate, SimulationSettings};
use crate::report::factor_sets::{factor_sets_json, factor_sets_text};

pub(super) fn run(args: &SetsArgs) -> anyhow::Result<Verdict> {
    let mechanism = Mechanism::load(&args.model)?;
    let mut inputs = model_inputs(&args.model, &mechanism);
    inputs.extend(
        args.measurements
            .as_deref()
            .map(|p| input("measurement file", p)),
    );
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let data = match &args.measurements {
        Some(path) => Some((
            Measurements::read(path, &mechanism)?,
            path.display().to_string(),
        )),
        None => None,
    };
    let (fits, title) = table(&mechanism, data)?;
    let mut console = Console::new(json.as_ref().is_some_and(Output::is_stdout));
    if let Some(json) = &json {
        let text = serde_json::to_string_pretty(&factor_sets_json(&fits))? + "\n";
        json.write("JSON table", text.as_bytes())?;
    }
    console.print(&factor_sets_text(&title, &fits))?;
    if let Some(json) = &json {
        console.line(format_args!("JSON table written to {}", json.name()))?;
    }
    // A set the data cannot determine is an answer of the table (its rank column), not a
    // reason to distrust the others.
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}

/// Every set of `mechanism` fitted on `data` (the measurements and where they come from; the
/// model's simulated experiment when `None`), and the table's title.
///
/// # Errors
/// A simulation or a fit that fails.
pub(super) fn table(
    mechanism: &Mechanism,
    data: Option<(Measurements, String)>,
) -> anyhow::Result<(Vec<FactorSetFit>, String)> {
    let (data, source) = match data {
        Some(given) => given,
        None => {
            let simulated = simulate(mechanism, &SimulationSettings::default())?;
            (simulated.measurements, simulated.source)
        }
    };
    let fits = model_sets(mechanism)
        .iter()
        .map(|set| fit_factor_set(mechanism, &data, set))
        .collect::<crate::error::Result<Vec<_>>>()?;
    let title = format!("Factor sets of {} on {source}", mechanism.name);
    Ok((fits, title))
}
