//! The commands kept in memory (the Python module's entries): the command's own arguments,
//! parser, checks and readers, the measurements as CSV text, the outputs returned instead of
//! written — so that the reports and the messages cannot drift from the command line's.

use std::path::{Path, PathBuf};

use super::args::{Cli, Command, PrinterArgs, PrinterCommand};
use super::evaluate::Models;
use super::identify::{check_map, prepared, read, write_calibrated};
use super::outputs::{input, model_inputs};
use super::printer_export::ExportOutputs;
use super::usage::usage_line;
use crate::files::Output;
use crate::measure::Measurements;
use crate::model::Mechanism;
use crate::pipeline;
use crate::report::calibrated::CalibratedModel;
use crate::report::evaluation::{evaluation_json, evaluation_text};

/// How messages name measurements given in memory.
pub const MEMORY_NAME: &str = "<memory>";

/// The command `words` (`identify`, …) and the caller's `arguments` parsed by the command
/// line's parser.
///
/// # Errors
/// A usage error, on one line as the command line prints it.
fn parsed(words: &[&str], arguments: &[String]) -> anyhow::Result<Command> {
    use clap::Parser;
    let words: Vec<String> = words
        .iter()
        .map(|w| w.to_string())
        .chain(arguments.iter().cloned())
        .collect();
    let cli = Cli::try_parse_from(std::iter::once("legwise".to_string()).chain(words.clone()))
        .map_err(|e| anyhow::anyhow!("{}", usage_line(&e, &words)))?;
    Ok(cli.command)
}

/// The options that write files, refused in memory (the outputs are returned instead).
fn refuse_files(files: &[(bool, &str)]) -> anyhow::Result<()> {
    if let Some((_, flag)) = files.iter().find(|(given, _)| *given) {
        anyhow::bail!("{flag}: writes a file; in memory the report is returned instead");
    }
    Ok(())
}

/// Measurements for `mechanism` parsed from the CSV text `csv` (named [`MEMORY_NAME`]).
fn from_text(csv: &str, mechanism: &Mechanism) -> crate::Result<Measurements> {
    Measurements::read_from(csv.as_bytes(), Path::new(MEMORY_NAME), mechanism)
}

/// What `legwise identify` gives a caller that keeps it in memory (the Python module): the JSON
/// report (docs/report.md), the terminal report, why the result must not be trusted (empty
/// when it may be: the command's exit 0), and the calibrated model to write.
#[derive(Debug, Clone)]
pub struct IdentifyOutputs {
    /// The JSON report, as `--json` writes it.
    pub json: String,
    /// The terminal report.
    pub text: String,
    /// One line per reason not to trust the result (the command's warnings and exit 3).
    pub trust_issues: Vec<String>,
    /// The calibrated model, `None` without a result.
    calibrated: Option<CalibratedModel>,
    /// The model file and the measurement file read (which no output may overwrite).
    read: (PathBuf, Option<PathBuf>),
}

impl IdentifyOutputs {
    /// Writes the calibrated model as `legwise identify --calibrated out` does: `out` and the
    /// URDF beside it (extension `urdf`), atomically, never over the model, its URDF or the
    /// measurement file; refused when the result must not be trusted. Returns what it says
    /// (the files written).
    ///
    /// # Errors
    /// An untrusted result (with the reasons), no result, a path that would overwrite an
    /// input, or a file that cannot be written.
    pub fn write_calibrated(&self, out: &Path) -> anyhow::Result<String> {
        let Some(model) = &self.calibrated else {
            anyhow::bail!("no calibrated model: the run identified nothing");
        };
        if !self.trust_issues.is_empty() {
            anyhow::bail!(
                "calibrated model not written to {}: the result must not be trusted ({})",
                out.display(),
                self.trust_issues.join("; ")
            );
        }
        let (model_path, measurements) = &self.read;
        let mut inputs = model_inputs(model_path, model.mechanism());
        inputs.extend(
            measurements
                .as_deref()
                .map(|p| input("measurement file", p)),
        );
        let files = Output::prepare_calibrated(out, None, &inputs)?;
        write_calibrated(model, &files)?;
        Ok(format!(
            "calibrated model ({} result) written to {} and {}",
            model.strategy(),
            files.0.name(),
            files.1.name()
        ))
    }
}

/// `legwise identify` with the command's arguments `arguments` (those after `identify`), the
/// measurements read as they say, or parsed from the CSV text `csv` (named [`MEMORY_NAME`] in
/// messages); the outputs kept in memory (`--json`, `--calibrated`, `--plots` are refused).
///
/// # Errors
/// As the command: a usage error (clap's message), a bad option, model or measurement, a
/// failed identification.
pub fn identify_in_memory(
    arguments: &[String],
    csv: Option<&str>,
) -> anyhow::Result<IdentifyOutputs> {
    let Command::Identify(args) = parsed(&["identify"], arguments)? else {
        anyhow::bail!("not an identification");
    };
    refuse_files(&[
        (args.json.is_some(), "--json"),
        (args.calibrated.is_some(), "--calibrated"),
        (args.plots.is_some(), "--plots"),
    ])?;
    if csv.is_some() && args.measurements.is_some() {
        anyhow::bail!("--measurements: the measurements are given in memory already");
    }
    let (mechanism, settings, map_scale) = prepared(&args)?;
    let measurements = match (csv, &args.measurements) {
        (Some(text), _) => Some(from_text(text, &mechanism)?),
        (None, Some(path)) => Some(read(path, &mechanism)?),
        (None, None) => None,
    };
    if measurements.is_some() && args.map.is_some() {
        anyhow::bail!("--map: the accuracy map needs the real parameters, known only in simulation (drop the measurements)");
    }
    check_map(&args, &mechanism, map_scale)?;
    let report = match &measurements {
        Some(data) => pipeline::identify(&mechanism, data, &settings)?,
        None => pipeline::run(&mechanism, &settings)?,
    };
    Ok(IdentifyOutputs {
        json: report.to_json().to_text()?,
        text: report.terminal_text(),
        trust_issues: report.trust_issues(),
        calibrated: report.calibrated_model(),
        read: (args.model.clone(), args.measurements.clone()),
    })
}

/// `legwise simulate` with the command's arguments `arguments` (those after `simulate`, without
/// `--out`): the measurement CSV the command writes, and the description of the simulation it
/// prints.
///
/// # Errors
/// As the command: a usage error (clap's message), a bad option or model, a failed simulation.
pub fn simulate_in_memory(arguments: &[String]) -> anyhow::Result<(String, String)> {
    let Command::Simulate(args) = parsed(&["simulate", "--out", "-"], arguments)? else {
        anyhow::bail!("not a simulation");
    };
    let settings = args.simulation.settings()?;
    let mechanism = Mechanism::load(&args.model)?;
    let simulated = pipeline::simulate(&mechanism, &settings)?;
    Ok((simulated.measurements.to_csv(&mechanism)?, simulated.source))
}

/// `legwise select` with the command's arguments `arguments` (those after `select`, without
/// `--out`): the pose file the command writes (measurement CSV layout, readings empty) and the
/// report it prints.
///
/// # Errors
/// As the command: a usage error (clap's message), a bad option or model, a failed selection.
pub fn select_in_memory(arguments: &[String]) -> anyhow::Result<(String, String)> {
    let Command::Select(args) = parsed(&["select", "--out", "-"], arguments)? else {
        anyhow::bail!("not a selection");
    };
    let (poses_per_leg, mechanism) = super::select::checked(&args)?;
    let selection = super::select::selected(&args, &mechanism, poses_per_leg)?;
    Ok((selection.csv, selection.text))
}

/// What `legwise evaluate` gives a caller that keeps it in memory: the JSON evaluation
/// (docs/report.md), the terminal report, and why it must not be trusted (the command's exit
/// 3).
#[derive(Debug, Clone)]
pub struct EvaluateOutputs {
    /// The JSON evaluation, as `--json` writes it.
    pub json: String,
    /// The terminal report.
    pub text: String,
    /// One line per reason not to trust the evaluation.
    pub trust_issues: Vec<String>,
}

/// `legwise evaluate` with the command's arguments `arguments` (those after `evaluate`), the
/// measurements read from `--measurements`, or parsed from the CSV text `csv` (named
/// [`MEMORY_NAME`]); `--json` and `--plots` are refused.
///
/// # Errors
/// As the command: a usage error, a bad model or measurement, a failed evaluation.
pub fn evaluate_in_memory(
    arguments: &[String],
    csv: Option<&str>,
) -> anyhow::Result<EvaluateOutputs> {
    let given = arguments
        .iter()
        .any(|a| a == "--measurements" || a.starts_with("--measurements="));
    if csv.is_some() && given {
        anyhow::bail!("--measurements: the measurements are given in memory already");
    }
    let memory = ["--measurements", MEMORY_NAME];
    let words: &[&str] = if csv.is_some() { &memory } else { &[] };
    let command = parsed(&[&["evaluate"], words].concat(), arguments)?;
    let Command::Evaluate(args) = command else {
        anyhow::bail!("not an evaluation");
    };
    refuse_files(&[
        (args.json.is_some(), "--json"),
        (args.plots.is_some(), "--plots"),
    ])?;
    let models = Models::load(&args)?;
    let (evaluation, against) = models.evaluate(&args, |model| match csv {
        Some(text) => from_text(text, model),
        None => Measurements::read(&args.measurements, model),
    })?;
    Ok(EvaluateOutputs {
        json: serde_json::to_string_pretty(&evaluation_json(&evaluation, against.as_ref()))? + "\n",
        text: evaluation_text(&models.model, &evaluation, against.as_ref()),
        trust_issues: models.trust_issues(&evaluation, against.as_ref()),
    })
}

/// `legwise sets` with the command's arguments `arguments` (those after `sets`), the
/// measurements read from `--measurements`, or parsed from the CSV text `csv` (named
/// [`MEMORY_NAME`]), or simulated without either: the JSON table and the terminal text.
///
/// # Errors
/// As the command: a usage error, a bad model or measurement, a failed fit.
pub fn sets_in_memory(arguments: &[String], csv: Option<&str>) -> anyhow::Result<(String, String)> {
    let Command::Sets(args) = parsed(&["sets"], arguments)? else {
        anyhow::bail!("not a factor-set table");
    };
    refuse_files(&[(args.json.is_some(), "--json")])?;
    if csv.is_some() && args.measurements.is_some() {
        anyhow::bail!("--measurements: the measurements are given in memory already");
    }
    let mechanism = Mechanism::load(&args.model)?;
    let data = match (csv, &args.measurements) {
        (Some(text), _) => Some((from_text(text, &mechanism)?, MEMORY_NAME.to_string())),
        (None, Some(path)) => Some((
            Measurements::read(path, &mechanism)?,
            path.display().to_string(),
        )),
        (None, None) => None,
    };
    let (fits, title, _) = super::sets::table(&mechanism, data)?;
    let json = serde_json::to_string_pretty(&crate::report::factor_sets::factor_sets_json(&fits))?;
    Ok((
        json + "\n",
        crate::report::factor_sets::factor_sets_text(&title, &fits),
    ))
}

/// `legwise printer import` with the command's arguments `arguments` (those after `printer
/// import`): writes the model, its URDF and the probe CSV into `--out`'s directory, as the
/// command does, and returns what the command prints (conventions, values read, files written).
///
/// # Errors
/// As the command: a usage error, bad firmware files (named by file, line and field), a
/// directory that cannot be written.
pub fn printer_import_in_memory(arguments: &[String]) -> anyhow::Result<String> {
    let Command::Printer(PrinterArgs {
        command: PrinterCommand::Import(args),
    }) = parsed(&["printer", "import"], arguments)?
    else {
        anyhow::bail!("not a printer import");
    };
    super::printer::imported(&args)
}

/// `legwise printer export` with the command's arguments `arguments` (those after `printer
/// export`, without `--out`): the firmware's lines and what the command reports about them.
///
/// # Errors
/// As the command: a usage error, a calibrated model that is not an imported printer, a firmware
/// file without its step settings, a fit that fails.
pub fn printer_export_in_memory(arguments: &[String]) -> anyhow::Result<ExportOutputs> {
    let Command::Printer(PrinterArgs {
        command: PrinterCommand::Export(args),
    }) = parsed(&["printer", "export", "--out", "-"], arguments)?
    else {
        anyhow::bail!("not a printer export");
    };
    super::printer_export::exported(&args)
}
