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
    let commanded = match &args.poses {
        Some(path) => Some(commanded_poses(path, &mechanism)?),
        None => None,
    };
    let mut console = outputs.console();
    let study = Study::prepare_at(&mechanism, options, commanded.as_deref())?;
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

/// The commanded poses of the CSV at `path`: each row's `pose.<coordinate>` cells over the
/// model's measured coordinates (the rest at home); a row without them (a distance row) is
/// skipped.
///
/// # Errors
/// The file cannot be read, a `pose.` column is missing (named), a cell is not a number (its
/// line and column), or no row holds a pose.
fn commanded_poses(path: &std::path::Path, mechanism: &Mechanism) -> anyhow::Result<Vec<[f64; 6]>> {
    let file = path.display();
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .flexible(true)
        .from_path(path)
        .map_err(|e| anyhow::anyhow!("{file}: {e}"))?;
    let header = reader
        .headers()
        .map_err(|e| anyhow::anyhow!("{file}: {e}"))?
        .clone();
    let columns: Vec<(usize, usize, String)> = mechanism
        .measured
        .iter()
        .map(|&c| {
            let name = format!("pose.{}", crate::model::mechanism::COORDINATES[c]);
            header
                .iter()
                .position(|h| h == name)
                .map(|at| (c, at, name.clone()))
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "{file}: header: no column `{name}`; expected a `pose.<coordinate>` \
                         column per measured coordinate of the model, as `legwise select` writes"
                    )
                })
        })
        .collect::<anyhow::Result<_>>()?;
    let mut poses = Vec::new();
    for (k, record) in reader.records().enumerate() {
        let line = k + 2;
        let record = record.map_err(|e| anyhow::anyhow!("{file}: line {line}: {e}"))?;
        let cells: Vec<&str> = columns
            .iter()
            .map(|(_, at, _)| record.get(*at).unwrap_or_default())
            .collect();
        if cells.iter().all(|c| c.is_empty()) {
            continue;
        }
        let mut pose = mechanism.home_pose;
        for ((coordinate, _, name), cell) in columns.iter().zip(cells) {
            pose[*coordinate] = cell.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                anyhow::anyhow!("{file}: line {line}, column `{name}`: expected a number (m or rad), found {cell:?}")
            })?;
        }
        poses.push(pose);
    }
    if poses.is_empty() {
        anyhow::bail!("{file}: no row holds a commanded pose");
    }
    Ok(poses)
}
