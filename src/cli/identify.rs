//! `legwise identify`: the arguments as [`Settings`], one library call ([`crate::run`] or
//! [`crate::identify`]), then the outputs (JSON, calibrated model, pictures, terminal text).

use std::path::Path;

use super::args::{IdentifyArgs, RobustArg, SolverArg, StrategyArg, WeightsArg};
use super::console::Console;
use super::outputs::{file_name, input, model_inputs, ReportFiles};
use super::verdict::Verdict;
use crate::evaluate::accuracy::map_grid;
use crate::files::{Input, Output};
use crate::identify::estimate::{FitOptions, Strategy, Weighting};
use crate::identify::robust::RobustLoss;
use crate::measure::{Measurements, STDIN_NAME};
use crate::model::prior_covariance::PriorCovariance;
use crate::model::with_prior::with_prior;
use crate::model::Mechanism;
use crate::pipeline::{self, MapSettings, Settings, SimulationSettings};
use crate::report::calibrated::CalibratedModel;
use crate::report::plots::files::{identify_picture_names, identify_pictures};

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<Verdict> {
    let (mechanism, settings, map_scale) = prepared(args)?;
    let inputs = identify_inputs(args, &mechanism);
    let json_path = args.json.as_deref();
    let json = Output::prepare_optional("--json", json_path, &inputs)?;
    let calibrated = match &args.calibrated {
        Some(out) => Some(Output::prepare_calibrated(out, json_path, &inputs)?),
        None => None,
    };
    let pictures = picture_outputs(args, &inputs)?;
    check_map(args, &mechanism, map_scale)?;
    let outputs = ReportFiles { json, pictures };
    let mut console = outputs.console();
    let report = match &args.measurements {
        Some(path) => pipeline::identify_owned(&mechanism, read(path, &mechanism)?, &settings)?,
        None => pipeline::run(&mechanism, &settings)?,
    };
    let verdict = Verdict::from_reasons(report.trust_issues());
    let trusted = verdict == Verdict::Trusted;
    if let (Some(files), Some(model)) = (
        calibrated.as_ref().filter(|_| trusted),
        report.calibrated_model(),
    ) {
        write_calibrated(&model, files)?;
    }
    outputs.write_json("JSON report", || Ok(report.to_json().to_text()?))?;
    outputs.write_pictures(|| Ok(identify_pictures(&report, crate::files::format(args.png))?))?;
    console.print(&report.terminal_text())?;
    if let (Some(files), Some(result)) = (&calibrated, report.calibrated_result()) {
        say_calibrated(&mut console, files, result.strategy.name(), trusted)?;
    }
    outputs.say_written(&mut console, "JSON report")?;
    Ok(verdict)
}

/// The checks of `args` made before any work, the model, the library's settings and the map's
/// scale.
///
/// # Errors
/// A bad option or combination of options, or a model that does not load.
pub(super) fn prepared(args: &IdentifyArgs) -> anyhow::Result<(Mechanism, Settings, f64)> {
    let simulation = args.simulation.settings()?;
    let map_scale = args.map_scale()?;
    super::checks::png_needs_plots(args.png, args.plots.as_deref())?;
    if let (Some(path), Some(flag)) = (&args.measurements, args.simulation.first_given()) {
        anyhow::bail!(
            "{flag}: a simulation option, but the measurements are read from {}; drop {flag} \
             (or --measurements, to simulate)",
            path.display()
        );
    }
    let mut mechanism = Mechanism::load(&args.model)?;
    if let Some(path) = &args.prior {
        mechanism = with_prior(&mechanism, &PriorCovariance::read(path)?)?;
    }
    if mechanism.instrument.is_some() {
        refuse_unsupported(args)?;
    }
    let settings = settings(args, &mechanism, simulation, map_scale);
    Ok((mechanism, settings, map_scale))
}

/// The library's settings from the command line: the strategies asked for (through an
/// instrument, the model's: joint and two-stage), the fit, the simulation and the map.
fn settings(
    args: &IdentifyArgs,
    model: &Mechanism,
    simulation: SimulationSettings,
    map_scale: f64,
) -> Settings {
    Settings {
        strategies: match (&model.instrument, args.strategy) {
            (Some(_), _) => Vec::new(),
            (None, StrategyArg::Dc) => vec![Strategy::DivideAndConquer],
            (None, StrategyArg::Traditional) => vec![Strategy::Traditional],
            (None, StrategyArg::Both) => vec![Strategy::DivideAndConquer, Strategy::Traditional],
        },
        solver: args.solver.kind(),
        fit: FitOptions {
            weights: match args.weights {
                None => Weighting::Declared,
                Some(WeightsArg::None) => Weighting::Unweighted,
                Some(WeightsArg::Noise) => Weighting::Noise,
            },
            robust: args.robust.map(|r| match r {
                RobustArg::Huber => RobustLoss::Huber,
                RobustArg::Cauchy => RobustLoss::Cauchy,
            }),
            drop_outliers: args.drop_outliers,
            ..FitOptions::default()
        },
        simulation,
        map: args.map.map(|grid_m| MapSettings {
            grid_m,
            scale: map_scale,
        }),
    }
}

/// The options an identification through the instrument does not offer (yet), refused before
/// any work.
fn refuse_unsupported(args: &IdentifyArgs) -> anyhow::Result<()> {
    let refused = [
        (args.solver != SolverArg::Lm, "--solver gn"),
        (args.strategy != StrategyArg::Dc, "--strategy"),
        (args.plots.is_some(), "--plots"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(on, _)| *on) {
        anyhow::bail!(
            "{flag}: not available for a model with an instrument block (the legs and the \
             instrument are identified with Levenberg-Marquardt, jointly and in two stages; \
             `--weights none|noise`, `--robust` and `--drop-outliers` apply to the joint fit)"
        );
    }
    Ok(())
}

/// The files `identify` reads (model, URDF, measurements), which no output may overwrite.
fn identify_inputs<'a>(args: &'a IdentifyArgs, mechanism: &'a Mechanism) -> Vec<Input<'a>> {
    let measurements = args.measurements.as_deref().filter(|p| !is_stdin(p));
    let mut inputs = model_inputs(&args.model, mechanism);
    inputs.extend(measurements.map(|path| input("measurement file", path)));
    inputs.extend(
        args.prior
            .as_deref()
            .map(|path| input("prior calibration", path)),
    );
    inputs
}

/// Whether a path names standard input (`-`).
fn is_stdin(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Reads the measurements from `path`, or from standard input for `-`.
pub(super) fn read(path: &Path, mechanism: &Mechanism) -> anyhow::Result<Measurements> {
    Ok(if is_stdin(path) {
        Measurements::read_from(std::io::stdin().lock(), Path::new(STDIN_NAME), mechanism)?
    } else {
        Measurements::read(path, mechanism)?
    })
}

/// Says where the calibrated model (from the `strategy` result) was written, or that it was not
/// because the result must not be trusted.
fn say_calibrated(
    console: &mut Console,
    (yaml, urdf): &(Output, Output),
    strategy: &str,
    trusted: bool,
) -> anyhow::Result<()> {
    let (yaml, urdf) = (yaml.name(), urdf.name());
    console.line(if trusted {
        format!("\ncalibrated model ({strategy} result) written to {yaml} and {urdf}")
    } else {
        format!("\ncalibrated model not written to {yaml}: the result must not be trusted")
    })
}

/// `--map`: simulation only, with a valid grid, refused before any work otherwise.
pub(super) fn check_map(
    args: &IdentifyArgs,
    mechanism: &Mechanism,
    map_scale: f64,
) -> anyhow::Result<()> {
    if let Some(grid) = args.map {
        if args.measurements.is_some() {
            anyhow::bail!("--map: the accuracy map needs the real parameters, known only in simulation (drop --measurements)");
        }
        map_grid(mechanism, grid, map_scale)?;
    }
    Ok(())
}

/// Writes the calibrated model `model` (the URDF first: the model file names it).
pub(super) fn write_calibrated(
    model: &CalibratedModel,
    (yaml, urdf): &(Output, Output),
) -> anyhow::Result<()> {
    let files = model.files(&file_name(Path::new(&urdf.name())))?;
    urdf.write("calibrated URDF", files.urdf.as_bytes())?;
    yaml.write("calibrated model", files.yaml.as_bytes())?;
    Ok(())
}

/// `--plots DIR`: simulation only; one checked output per picture, before any work.
fn picture_outputs(args: &IdentifyArgs, inputs: &[Input<'_>]) -> anyhow::Result<Vec<Output>> {
    if args.plots.is_some() && args.measurements.is_some() {
        anyhow::bail!("--plots: the pictures compare with the real parameters, known only in simulation (drop --measurements)");
    }
    let names = identify_picture_names(args.map.is_some());
    let format = crate::files::format(args.png);
    Ok(crate::files::prepare(
        args.plots.as_deref(),
        &names,
        format,
        inputs,
    )?)
}
