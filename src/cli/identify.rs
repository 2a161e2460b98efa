//! `legwise identify`.

use super::IdentifyArgs;
use crate::evaluate::accuracy::{accuracy_map, result_parameters, AccuracyMap};
use crate::evaluate::report::{map_json, map_summary};
use crate::identify::estimate::{identify, Strategy};
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::calibrated::{refuse_overwriting_inputs, write_calibrated, Calibration};
use crate::report::{json, terminal, IdentifyReport};

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    args.simulation.options()?;
    check_outputs(args, &mechanism)?;
    let (data, real, source) = match &args.measurements {
        Some(path) => (
            file::read(path, &mechanism)?,
            None,
            path.display().to_string(),
        ),
        None => {
            let (experiment, source) = args.simulation.experiment(&mechanism)?;
            (experiment.measurements, Some(experiment.real), source)
        }
    };
    let mut results = Vec::new();
    for strategy in args.strategy.strategies() {
        results.push(identify(&mechanism, &data, strategy, args.solver.kind())?);
    }
    let report = IdentifyReport {
        mechanism: &mechanism,
        source,
        real,
        results,
    };
    print!("{}", terminal::render(&report));
    let maps = accuracy_maps(args, &report)?;
    write_calibrated_model(args, &report)?;
    write_pictures(args, &report, maps.as_ref(), &data)?;
    if let Some(path) = &args.json {
        let mut value = json::to_json(&report);
        if let Some((before, after)) = &maps {
            value["accuracy_map_before"] = map_json(before);
            for (i, map) in after.iter().enumerate() {
                value["results"][i]["accuracy_map"] = map_json(map);
            }
        }
        let text = serde_json::to_string_pretty(&value)?;
        crate::report::calibrated::write_atomically(path, &text).map_err(|e| {
            anyhow::anyhow!("{}: cannot write the JSON report: {e}", path.display())
        })?;
        println!("\nJSON report written to {}", path.display());
    }
    Ok(())
}

/// Refuses outputs that would overwrite an input, and a map without a simulation, before any work.
fn check_outputs(args: &IdentifyArgs, mechanism: &Mechanism) -> anyhow::Result<()> {
    let mut inputs = vec![
        mechanism.model_path.as_path(),
        mechanism.urdf_path.as_path(),
    ];
    inputs.extend(args.measurements.as_deref());
    let calibrated_urdf = args
        .after
        .calibrated
        .as_ref()
        .map(|p| p.with_extension("urdf"));
    let outputs: Vec<_> = args
        .json
        .iter()
        .chain(&args.after.calibrated)
        .chain(&calibrated_urdf)
        .map(|p| p.as_path())
        .collect();
    refuse_overwriting_inputs(&outputs, &inputs)?;
    if let Some(dir) = &args.pictures.plots {
        if args.measurements.is_some() {
            anyhow::bail!("--plots: the pictures compare with the real parameters, known only in simulation (drop --measurements)");
        }
        crate::report::plots::output::check_directory(dir)?;
    }
    if let Some(grid) = args.after.map {
        if args.measurements.is_some() {
            anyhow::bail!("--map: the accuracy map needs the real parameters, known only in simulation (drop --measurements)");
        }
        crate::evaluate::accuracy::map_grid(mechanism, grid, args.after.map_scale)?;
    }
    Ok(())
}

/// `--map`: the accuracy map of the nominal model, then of each result, against the real mechanism.
fn accuracy_maps(
    args: &IdentifyArgs,
    report: &IdentifyReport<'_>,
) -> anyhow::Result<Option<(AccuracyMap, Vec<AccuracyMap>)>> {
    let (Some(grid), Some(real)) = (args.after.map, report.real.as_ref()) else {
        return Ok(None);
    };
    let mechanism = report.mechanism;
    let scale = args.after.map_scale;
    let nominal = mechanism.nominal_parameters();
    let before = accuracy_map(mechanism, &nominal, real, grid, scale, "map before")?;
    println!("\naccuracy map over {scale} of the workspace region, grid {grid} m:");
    println!("{}", map_summary("  before (nominal model)", &before));
    let mut after = Vec::new();
    for result in &report.results {
        let identified = result_parameters(mechanism, result);
        let label = format!("  after, {}", result.strategy.name());
        let map = accuracy_map(mechanism, &identified, real, grid, scale, &label)?;
        println!("{}", map_summary(&label, &map));
        after.push(map);
    }
    Ok(Some((before, after)))
}

/// `--calibrated OUT.yaml`: the divide-and-conquer result if there is one, else the first.
fn write_calibrated_model(args: &IdentifyArgs, report: &IdentifyReport<'_>) -> anyhow::Result<()> {
    let Some(out) = &args.after.calibrated else {
        return Ok(());
    };
    let Some(result) = report
        .results
        .iter()
        .find(|r| r.strategy == Strategy::DivideAndConquer)
        .or(report.results.first())
    else {
        return Ok(());
    };
    let note = (report.results.len() > 1).then(|| {
        format!(
            "Several strategies ran; this is the {} result.",
            result.strategy.name()
        )
    });
    let calibration = Calibration {
        mechanism: report.mechanism,
        result,
        source: &report.source,
        real: report.real.as_deref(),
        note: note.as_deref(),
    };
    let inputs: Vec<_> = args.measurements.iter().map(|p| p.as_path()).collect();
    let urdf = write_calibrated(&calibration, out, &inputs)?;
    println!(
        "\ncalibrated model ({} result) written to {} and {}",
        result.strategy.name(),
        out.display(),
        urdf.display()
    );
    Ok(())
}

/// `--plots DIR`: the parameter errors and, with `--map`, the accuracy map with the
/// identification poses.
fn write_pictures(
    args: &IdentifyArgs,
    report: &IdentifyReport<'_>,
    maps: Option<&(AccuracyMap, Vec<AccuracyMap>)>,
    data: &crate::measure::MeasurementSet,
) -> anyhow::Result<()> {
    use crate::report::plots::files::{write_identify_plots, Maps};
    let Some(dir) = &args.pictures.plots else {
        return Ok(());
    };
    let format = if args.pictures.png {
        crate::report::plots::Format::Png
    } else {
        crate::report::plots::Format::Svg
    };
    let maps = maps.map(|(before, after)| Maps { before, after });
    let poses: Vec<[f64; 2]> = data.poses.iter().map(|p| [p.pose[0], p.pose[1]]).collect();
    let inputs = [
        report.mechanism.model_path.as_path(),
        report.mechanism.urdf_path.as_path(),
    ];
    let written = write_identify_plots(dir, format, report, maps, &poses, &inputs)?;
    for path in written {
        println!("picture written to {}", path.display());
    }
    Ok(())
}
