//! `legwise identify`.

use std::path::Path;

use super::console::Console;
use super::output::{Input, Output};
use super::{IdentifyArgs, Verdict};
use crate::evaluate::accuracy::{accuracy_map, map_grid, result_parameters, AccuracyMap};
use crate::identify::estimate::{identify_with, Strategy};
use crate::identify::trust::trust_issues;
use crate::measure::{file, MeasurementSet};
use crate::model::Mechanism;
use crate::report::calibrated::{calibrated_files, urdf_path, Calibration};
use crate::report::evaluation::{map_json, map_summary};
use crate::report::plots::files::{identify_picture_names, identify_pictures, Maps};
use crate::report::{json, terminal, IdentifyReport};

/// The name of standard input in messages.
const STDIN: &str = "<stdin>";

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<Verdict> {
    let options = args.simulation.options()?;
    let mut mechanism = Mechanism::load(&args.model)?;
    if mechanism.instrument.is_some() {
        return super::identify_instrument::run(args, mechanism);
    }
    let inputs = identify_inputs(args, &mechanism);
    let json_output = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let calibrated_outputs = calibrated_outputs(args, &inputs)?;
    let picture_outputs = picture_outputs(args, &inputs)?;
    check_map(args, &mechanism)?;
    let mut console = Console::new(json_output.as_ref().is_some_and(Output::is_stdout));
    let (data, real, source) = match &args.measurements {
        Some(path) => {
            let source = if is_stdin(path) {
                "standard input".to_string()
            } else {
                path.display().to_string()
            };
            (read(path, &mechanism)?, None, source)
        }
        None => {
            let (experiment, source) = args.simulation.experiment(&mechanism)?;
            // The simulated noise is the declared one scaled: so is what the fit expects.
            if let Some(noise) = &mut mechanism.noise {
                noise.pose = noise.pose.map(|s| s * options.noise_scale);
                noise.reading *= options.noise_scale;
            }
            (experiment.measurements, Some(experiment.real), source)
        }
    };
    let mut results = Vec::new();
    for strategy in args.strategy.strategies() {
        results.push(identify_with(
            &mechanism,
            &data,
            strategy,
            args.solver.kind(),
            args.fit_options(),
        )?);
    }
    let verdict = Verdict::from_reasons(trust_issues(&results));
    let report = IdentifyReport {
        mechanism: &mechanism,
        source,
        real,
        results,
    };
    let maps = accuracy_maps(args, &report)?;
    let trusted = verdict == Verdict::Trusted;
    if let Some(outputs) = calibrated_outputs.as_ref().filter(|_| trusted) {
        write_calibrated(&report, outputs)?;
    }
    // The file first: a closed terminal pipe must not lose it.
    if let Some(output) = &json_output {
        let mut value = json::to_json(&report);
        if let Some((before, after)) = &maps {
            value["accuracy_map_before"] = map_json(before);
            for (i, map) in after.iter().enumerate() {
                value["results"][i]["accuracy_map"] = map_json(map);
            }
        }
        let text = serde_json::to_string_pretty(&value)? + "\n";
        output.write("JSON report", text.as_bytes())?;
    }
    if let Some(outputs) = &picture_outputs {
        write_pictures(args, &report, maps.as_ref(), &data, outputs)?;
    }
    console.print(&terminal::render(&report))?;
    if let Some((before, after)) = &maps {
        let labels: Vec<&str> = report.results.iter().map(|r| r.strategy.name()).collect();
        console.print(&maps_text(args, &mechanism, &labels, before, after))?;
    }
    if let (Some(outputs), Some(result)) = (&calibrated_outputs, calibrated_result(&report)) {
        say_calibrated(&mut console, outputs, result.strategy.name(), trusted)?;
    }
    say_json_written(&mut console, json_output.as_ref())?;
    for output in picture_outputs.iter().flatten() {
        console.line(format_args!("picture written to {}", output.name()))?;
    }
    Ok(verdict)
}

/// True for the path `-`.
/// The files `identify` reads (model, URDF, measurements), which no output may overwrite.
pub(super) fn identify_inputs<'a>(
    args: &'a IdentifyArgs,
    mechanism: &'a Mechanism,
) -> Vec<Input<'a>> {
    let measurements = args.measurements.as_deref().filter(|p| !is_stdin(p));
    let mut inputs = super::model_inputs(&args.model, mechanism);
    inputs.extend(measurements.map(|path| Input {
        role: "measurement file",
        path,
    }));
    inputs
}

/// Whether a path names standard input (`-`).
pub(super) fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Reads the measurements from `path`, or from standard input for `-`.
fn read(path: &Path, mechanism: &Mechanism) -> anyhow::Result<MeasurementSet> {
    Ok(if is_stdin(path) {
        file::read_from(std::io::stdin().lock(), Path::new(STDIN), mechanism)?
    } else {
        file::read(path, mechanism)?
    })
}

/// `--calibrated OUT.yaml`: the model file and its URDF, checked against the inputs and against
/// the JSON report's path.
/// Says where the calibrated model (from the `strategy` result) was written, or that it was not
/// because the result must not be trusted.
pub(super) fn say_calibrated(
    console: &mut Console,
    (yaml, urdf): &(Output, Output),
    strategy: &str,
    trusted: bool,
) -> anyhow::Result<()> {
    if trusted {
        console.line(format_args!(
            "\ncalibrated model ({strategy} result) written to {} and {}",
            yaml.name(),
            urdf.name()
        ))
    } else {
        console.line(format_args!(
            "\ncalibrated model not written to {}: the result must not be trusted",
            yaml.name()
        ))
    }
}

/// Says where the JSON report was written (nothing when it went to standard output).
pub(super) fn say_json_written(
    console: &mut Console,
    output: Option<&Output>,
) -> anyhow::Result<()> {
    match output.filter(|o| !o.is_stdout()) {
        Some(output) => console.line(format_args!("\nJSON report written to {}", output.name())),
        None => Ok(()),
    }
}

/// The calibrated model's YAML and URDF outputs, checked against the inputs and `--json`.
pub(super) fn calibrated_outputs(
    args: &IdentifyArgs,
    inputs: &[Input<'_>],
) -> anyhow::Result<Option<(Output, Output)>> {
    let Some(out) = &args.after.calibrated else {
        return Ok(None);
    };
    if let Some(json) = &args.json {
        let urdf = out.with_extension("urdf");
        if [out, &urdf].iter().any(|p| same_destination(p, json)) {
            anyhow::bail!(
                "{}: --calibrated and --json would write the same file; choose another path",
                json.display()
            );
        }
    }
    if out.as_os_str() == "-" {
        anyhow::bail!(
            "--calibrated: expected a file path (the URDF is written beside it), found `-`"
        );
    }
    let urdf = urdf_path(out)?;
    Ok(Some((
        Output::prepare("--calibrated", out, inputs)?,
        Output::prepare("--calibrated", &urdf, inputs)?,
    )))
}

/// `--map`: simulation only, with a valid grid, refused before any work otherwise.
pub(super) fn check_map(args: &IdentifyArgs, mechanism: &Mechanism) -> anyhow::Result<()> {
    if let Some(grid) = args.after.map {
        if args.measurements.is_some() {
            anyhow::bail!("--map: the accuracy map needs the real parameters, known only in simulation (drop --measurements)");
        }
        map_grid(mechanism, grid, args.after.map_scale)?;
    }
    Ok(())
}

/// `--map`: the accuracy map of the nominal model, then of each result, against the real mechanism.
fn accuracy_maps(
    args: &IdentifyArgs,
    report: &IdentifyReport<'_>,
) -> anyhow::Result<Option<(AccuracyMap, Vec<AccuracyMap>)>> {
    let identified: Vec<(&str, Vec<Vec<f64>>)> = report
        .results
        .iter()
        .map(|r| (r.strategy.name(), result_parameters(report.mechanism, r)))
        .collect();
    maps_before_after(args, report.mechanism, report.real.as_deref(), &identified)
}

/// `--map`: the accuracy map of the nominal model, then of each `(name, identified legs)`, against
/// the `real` legs (known in simulation only; `None` without `--map` or without them).
pub(super) fn maps_before_after(
    args: &IdentifyArgs,
    mechanism: &Mechanism,
    real: Option<&[Vec<f64>]>,
    identified: &[(&str, Vec<Vec<f64>>)],
) -> anyhow::Result<Option<(AccuracyMap, Vec<AccuracyMap>)>> {
    let (Some(grid), Some(real)) = (args.after.map, real) else {
        return Ok(None);
    };
    let scale = args.after.map_scale;
    let nominal = mechanism.nominal_parameters();
    let before = accuracy_map(mechanism, &nominal, real, grid, scale, "map before")?;
    let mut after = Vec::new();
    for (name, parameters) in identified {
        let label = format!("map after, {name}");
        after.push(accuracy_map(
            mechanism, parameters, real, grid, scale, &label,
        )?);
    }
    Ok(Some((before, after)))
}

/// The accuracy maps in millimetres, for the terminal: `before`, then each of `after` labelled
/// with its strategy's name in `labels`.
pub(super) fn maps_text(
    args: &IdentifyArgs,
    mechanism: &Mechanism,
    labels: &[&str],
    before: &AccuracyMap,
    after: &[AccuracyMap],
) -> String {
    let slice = crate::report::plots::files::map_slice(mechanism)
        .map_or(String::new(), |slice| format!(", {slice}"));
    let mut text = format!(
        "\naccuracy map over {} of the workspace region, grid {} m{slice}:\n{}\n",
        args.after.map_scale,
        before.grid_m,
        map_summary("  before (nominal model)", before)
    );
    for (name, map) in labels.iter().zip(after) {
        let label = format!("  after, {name}");
        text.push_str(&map_summary(&label, map));
        text.push('\n');
    }
    text
}

/// The result a calibrated model holds: divide and conquer if it ran, else the first.
fn calibrated_result<'r>(
    report: &'r IdentifyReport<'_>,
) -> Option<&'r crate::identify::estimate::StrategyResult> {
    report
        .results
        .iter()
        .find(|r| r.strategy == Strategy::DivideAndConquer)
        .or(report.results.first())
}

/// Writes the calibrated model (the URDF first: the model file names it).
fn write_calibrated(report: &IdentifyReport<'_>, outputs: &(Output, Output)) -> anyhow::Result<()> {
    let Some(result) = calibrated_result(report) else {
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
    let (yaml, urdf) = outputs;
    let urdf_name = std::path::Path::new(&urdf.name())
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let files = calibrated_files(&calibration, &urdf_name)?;
    urdf.write("calibrated URDF", files.urdf.as_bytes())?;
    yaml.write("calibrated model", files.yaml.as_bytes())?;
    Ok(())
}

/// Whether two output paths name the same file (their directories compared canonically).
fn same_destination(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        let parent = p.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = parent.unwrap_or(Path::new(".")).canonicalize().ok();
        (dir, p.file_name().map(|n| n.to_os_string()))
    };
    resolve(a) == resolve(b)
}

/// `--plots DIR`: simulation only; one checked output per picture, before any work.
fn picture_outputs(
    args: &IdentifyArgs,
    inputs: &[Input<'_>],
) -> anyhow::Result<Option<Vec<Output>>> {
    let Some(dir) = &args.pictures.plots else {
        return Ok(None);
    };
    if args.measurements.is_some() {
        anyhow::bail!("--plots: the pictures compare with the real parameters, known only in simulation (drop --measurements)");
    }
    let names = identify_picture_names(args.after.map.is_some());
    let format = super::pictures::format(args.pictures.png);
    Ok(Some(super::pictures::prepare(dir, &names, format, inputs)?))
}

/// Draws the parameter errors and, with `--map`, the accuracy map with the identification
/// poses, into `outputs` (from [`picture_outputs`]).
fn write_pictures(
    args: &IdentifyArgs,
    report: &IdentifyReport<'_>,
    maps: Option<&(AccuracyMap, Vec<AccuracyMap>)>,
    data: &MeasurementSet,
    outputs: &[Output],
) -> anyhow::Result<()> {
    let maps = maps.map(|(before, after)| Maps { before, after });
    let poses: Vec<[f64; 2]> = data
        .poses()
        .iter()
        .map(|p| [p.pose[0], p.pose[1]])
        .collect();
    let format = super::pictures::format(args.pictures.png);
    let pictures = identify_pictures(report, maps, &poses, format)?;
    for (output, bytes) in outputs.iter().zip(&pictures) {
        output.write("picture", bytes)?;
    }
    Ok(())
}
