//! `legwise identify` for a model with an `instrument` block: the measurements are the targets'
//! coordinates in the instrument frame; the legs and the instrument are identified together
//! (joint, Schur complement) and in two stages, and the report compares both.

use std::io::Read;
use std::path::Path;

use super::console::Console;
use super::identify::{
    calibrated_outputs, check_map, identify_inputs, is_stdin, maps_before_after, maps_text,
};
use super::output::Output;
use super::{IdentifyArgs, SolverArg, StrategyArg, Verdict, WeightsArg};
use crate::evaluate::accuracy::shared_result_parameters;
use crate::identify::shared_estimate::{identify_shared, trust_issues, SharedStrategy};
use crate::measure::observations::{self, Observations};
use crate::measure::observe_simulate::{observed_from, without_pose_noise};
use crate::model::Mechanism;
use crate::report::evaluation::map_json;
use crate::report::instrument::{render, to_json, InstrumentReport};
use crate::report::instrument_calibrated::calibrated_files;

/// The options an identification through the instrument does not offer (yet), refused before
/// any work.
fn refuse_unsupported(args: &IdentifyArgs) -> anyhow::Result<()> {
    let refused = [
        (args.solver != SolverArg::Lm, "--solver gn"),
        (args.strategy != StrategyArg::Dc, "--strategy"),
        (args.weights != WeightsArg::None, "--weights"),
        (args.robust.is_some(), "--robust"),
        (args.drop_outliers, "--drop-outliers"),
        (args.pictures.plots.is_some(), "--plots"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(on, _)| *on) {
        anyhow::bail!(
            "{flag}: not available for a model with an instrument block (the legs and the \
             instrument are identified with Levenberg-Marquardt, jointly and in two stages)"
        );
    }
    Ok(())
}

pub(super) fn run(args: &IdentifyArgs, mut mechanism: Mechanism) -> anyhow::Result<Verdict> {
    refuse_unsupported(args)?;
    let options = args.simulation.options()?;
    let inputs = identify_inputs(args, &mechanism);
    let json_output = Output::prepare_optional("--json", args.json.as_deref(), &inputs)?;
    let calibrated_outputs = calibrated_outputs(args, &inputs)?;
    check_map(args, &mechanism)?;
    let mut console = Console::new(json_output.as_ref().is_some_and(Output::is_stdout));
    let (data, real, real_shared, source) = match &args.measurements {
        Some(path) => (
            read(path, &mechanism)?,
            None,
            None,
            path.display().to_string(),
        ),
        None => {
            let (experiment, source) = args
                .simulation
                .experiment(&without_pose_noise(&mechanism))?;
            let observed = observed_from(&mechanism, experiment, options)?;
            // The simulated noise is the declared one scaled: so is what the fit expects.
            if let Some(noise) = &mut mechanism.noise {
                noise.pose = noise.pose.map(|s| s * options.noise_scale);
                noise.reading *= options.noise_scale;
            }
            (
                observed.observations,
                Some(observed.real),
                Some(observed.real_shared),
                source,
            )
        }
    };
    let mut results = Vec::new();
    for strategy in [SharedStrategy::Joint, SharedStrategy::TwoStage] {
        results.push(identify_shared(&mechanism, &data, strategy)?);
    }
    // The verdict is the joint result's (the one --calibrated writes); the two-stage result is
    // a comparison, its own misfit shown in the report.
    let verdict = Verdict::from_reasons(trust_issues(&results[..1]));
    let report = InstrumentReport {
        mechanism: &mechanism,
        source,
        real,
        real_shared,
        results,
    };
    // The accuracy maps compare the identified legs with the real ones: the mechanism, not
    // the instrument (which only measures).
    let identified: Vec<(&str, Vec<Vec<f64>>)> = report
        .results
        .iter()
        .map(|r| (r.strategy.name(), shared_result_parameters(&mechanism, r)))
        .collect();
    let maps = maps_before_after(args, &mechanism, report.real.as_deref(), &identified)?;
    let trusted = verdict == Verdict::Trusted;
    if let (Some((yaml, urdf)), true) = (&calibrated_outputs, trusted) {
        let urdf_name = Path::new(&urdf.name())
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let real = report.real.as_deref().zip(report.real_shared.as_deref());
        let files = calibrated_files(
            &mechanism,
            &report.results[0],
            &report.source,
            real,
            &urdf_name,
        )?;
        urdf.write("calibrated URDF", files.urdf.as_bytes())?;
        yaml.write("calibrated model", files.yaml.as_bytes())?;
    }
    if let Some(output) = &json_output {
        let mut value = to_json(&report);
        if let Some((before, after)) = &maps {
            value["accuracy_map_before"] = map_json(before);
            for (i, map) in after.iter().enumerate() {
                value["results"][i]["accuracy_map"] = map_json(map);
            }
        }
        let text = serde_json::to_string_pretty(&value)? + "\n";
        output.write("JSON report", text.as_bytes())?;
    }
    console.print(&render(&report))?;
    if let Some((before, after)) = &maps {
        let labels: Vec<&str> = identified.iter().map(|(name, _)| *name).collect();
        console.print(&maps_text(args, &mechanism, &labels, before, after))?;
    }
    if let Some(outputs) = &calibrated_outputs {
        super::identify::say_calibrated(&mut console, outputs, "joint", trusted)?;
    }
    super::identify::say_json_written(&mut console, json_output.as_ref())?;
    Ok(verdict)
}

/// Reads the instrument measurements from `path`, or from standard input for `-`.
fn read(path: &Path, mechanism: &Mechanism) -> anyhow::Result<Observations> {
    Ok(if is_stdin(path) {
        let mut text = String::new();
        std::io::stdin()
            .lock()
            .read_to_string(&mut text)
            .map_err(|error| crate::error::Error::Io {
                path: "<stdin>".into(),
                error,
            })?;
        observations::parse(&text, Path::new("<stdin>"), mechanism)?
    } else {
        observations::read(path, mechanism)?
    })
}
