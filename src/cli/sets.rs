//! `legwise sets`: the model's own set and each of its factor sets fitted on the same
//! measurements (or its simulation), one table.

use super::args::SetsArgs;
use super::console::Console;
use super::outputs::{input, model_inputs};
use super::verdict::Verdict;
use crate::evaluate::row_residuals::row_residuals;
use crate::files::Output;
use crate::identify::factor_set::{fit_factor_set, model_sets, FactorSetFit};
use crate::measure::Measurements;
use crate::model::with_values::with_values;
use crate::model::Mechanism;
use crate::pipeline::{simulate, SimulationSettings};
use crate::report::factor_sets::{factor_sets_json, factor_sets_text};
use crate::report::plots::render;
use crate::report::plots::row_residuals::{ResidualFigure, ResidualPanel};

pub(super) fn run(args: &SetsArgs) -> anyhow::Result<Verdict> {
    if let Some(trials) = args.trials {
        return super::sets_study::run(args, trials);
    }
    let mechanism = Mechanism::load(&args.model)?;
    let mut inputs = model_inputs(&args.model, &mechanism);
    inputs.extend(
        args.measurements
            .as_deref()
            .map(|p| input("measurement file", p)),
    );
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    super::checks::png_needs_plots(args.png, args.plots.as_deref())?;
    let format = crate::files::format(args.png);
    if args.plots.is_some() && mechanism.instrument.is_none() {
        return Err(crate::error::Error::Invalid(format!(
            "--plots: draws each row's residual through the instrument, and {} has none",
            args.model.display()
        ))
        .into());
    }
    let pictures = crate::files::prepare(args.plots.as_deref(), &[RESIDUALS], format, &inputs)?;
    let data = match &args.measurements {
        Some(path) => Some((
            Measurements::read(path, &mechanism)?,
            path.display().to_string(),
        )),
        None => None,
    };
    let (fits, title, data) = table(&mechanism, data)?;
    let mut console = Console::new(json.as_ref().is_some_and(Output::is_stdout));
    if let Some(output) = pictures.first() {
        let figure = residual_figure(&mechanism, &data, &fits)?;
        output.write("picture", &render(&figure, format)?)?;
    }
    if let Some(json) = &json {
        let text = serde_json::to_string_pretty(&factor_sets_json(&fits))? + "\n";
        json.write("JSON table", text.as_bytes())?;
    }
    console.print(&factor_sets_text(&title, &fits))?;
    if let Some(json) = &json {
        console.line(format_args!("JSON table written to {}", json.name()))?;
    }
    for output in &pictures {
        console.line(format_args!("picture written to {}", output.name()))?;
    }
    // A set the data cannot determine is an answer of the table (its rank column), not a
    // reason to distrust the others.
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}

/// Every set of `mechanism` fitted on `data` (the measurements and where they come from; the
/// model's simulated experiment when `None`), the table's title and the measurements.
///
/// # Errors
/// A simulation or a fit that fails.
pub(super) fn table(
    mechanism: &Mechanism,
    data: Option<(Measurements, String)>,
) -> anyhow::Result<(Vec<FactorSetFit>, String, Measurements)> {
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
    Ok((fits, title, data))
}

/// The picture's file name (without extension).
const RESIDUALS: &str = "row-residuals";

/// Each row's residual through the instrument where it was measured, before (the nominal
/// model) and after (the model's own set: `fits[0]`): the first reported coordinate's signed
/// residual, or the norm of a row's several.
fn residual_figure(
    mechanism: &Mechanism,
    data: &Measurements,
    fits: &[FactorSetFit],
) -> anyhow::Result<ResidualFigure> {
    let Measurements::Targets(observations) = data else {
        return Err(crate::error::Error::Invalid(
            "--plots: the residual picture needs measurements through the instrument".into(),
        )
        .into());
    };
    let own = &fits[0];
    let values: Vec<(String, f64)> = own
        .factors
        .iter()
        .map(|f| (f.name.clone(), f.estimate))
        .collect();
    let fitted = with_values(mechanism, &values)?;
    let panel = |title: String, model: &Mechanism| -> anyhow::Result<ResidualPanel> {
        let rows = row_residuals(model, observations)?
            .into_iter()
            .map(|row| {
                let value = match row.residual.as_slice() {
                    [one] => *one,
                    many => many.iter().map(|r| r * r).sum::<f64>().sqrt(),
                };
                (row.at, value)
            })
            .collect();
        Ok(ResidualPanel { title, rows })
    };
    let coordinates = mechanism
        .instrument
        .as_ref()
        .and_then(|i| i.targets.first())
        .map_or(&[][..], |t| t.coordinates());
    let quantity = match coordinates {
        [one] => format!("{one} residual"),
        _ => "residual".to_string(),
    };
    Ok(ResidualFigure {
        title: format!(
            "{}: each row's residual where it was measured",
            mechanism.name
        ),
        quantity,
        panels: vec![
            panel("before (nominal model)".into(), mechanism)?,
            panel(format!("after: `{}`", own.name), &fitted)?,
        ],
    })
}
