//! `legwise montecarlo`.

use super::args::MontecarloArgs;
use super::checks;
use super::outputs::{model_inputs, ReportFiles};
use super::verdict::Verdict;
use crate::files::{prepare, Output};
use crate::model::Mechanism;
use crate::report::plots::render;
use crate::study::montecarlo::{MonteCarloOptions, Study};
use crate::study::plots::error_distributions;
use crate::study::report::{montecarlo_json, montecarlo_text};

/// Most trials of one study.
const MAX_TRIALS: usize = 1_000_000;

/// The picture's file name (without extension).
const PICTURE: &str = "montecarlo-errors";

pub(super) fn run(args: &MontecarloArgs) -> anyhow::Result<Verdict> {
    let trials = checks::count("--trials", args.trials, 2, MAX_TRIALS)?;
    super::checks::png_needs_plots(args.png, args.plots.as_deref())?;
    let seed = checks::seed("--seed", args.seed)?;
    let noise_scale = checks::non_negative("--noise-scale", args.noise_scale)?;
    let grid = checks::positive_metres("--grid", args.grid)?;
    let poses_per_leg = checks::poses_per_leg(args.poses_per_leg)?;
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let json = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let format = crate::files::format(args.png);
    let pictures = prepare(args.plots.as_deref(), &[PICTURE], format, &inputs)?;
    let outputs = ReportFiles { json, pictures };
    let simulation = crate::measure::simulate::setup(&mechanism)?;
    let options = MonteCarloOptions {
        solver: args.solver.kind(),
        noise_scale,
        poses_per_leg,
        grid,
        map_grid: args.map,
        map_scale: args.map_scale,
        ..MonteCarloOptions::new(trials, seed.unwrap_or(simulation.seed))
    };
    let mut console = outputs.console();
    let study = Study::prepare(&mechanism, options)?;
    let result = study.run();
    outputs.write_json("JSON study", || {
        Ok(serde_json::to_string_pretty(&montecarlo_json(&result))? + "\n")
    })?;
    outputs.write_pictures(|| Ok(vec![render(&error_distributions(&result), format)?]))?;
    console.print(&montecarlo_text(&result))?;
    outputs.say_written(&mut console, "JSON")?;
    let mut reasons = mechanism.warnings.clone();
    reasons.extend(
        result
            .trials
            .iter()
            .filter_map(|t| t.outcome.as_ref().err().map(|e| (t.index, e)))
            .take(5)
            .map(|(index, reason)| format!("trial {index} failed and is left out: {reason}")),
    );
    let failed = trials - result.succeeded;
    if failed > reasons.len() - mechanism.warnings.len() {
        reasons.push(format!(
            "{failed} of {trials} trials failed in all: the statistics leave them out"
        ));
    }
    Ok(Verdict::from_reasons(reasons))
}
