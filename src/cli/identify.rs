//! `legwise identify`.

use std::path::Path;

use super::console::Console;
use super::output::{Input, Output};
use super::{IdentifyArgs, Verdict};
use crate::identify::estimate::identify_with;
use crate::identify::trust::trust_issues;
use crate::measure::{file, MeasurementSet};
use crate::model::Mechanism;
use crate::report::{json, terminal, IdentifyReport};

/// The name of standard input in messages.
const STDIN: &str = "<stdin>";

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<Verdict> {
    let options = args.simulation.options()?;
    let mut mechanism = Mechanism::load(&args.model)?;
    let measurements = args.measurements.as_deref().filter(|p| !is_stdin(p));
    let mut inputs = super::model_inputs(&args.model, &mechanism);
    inputs.extend(measurements.map(|path| Input {
        role: "measurement file",
        path,
    }));
    let json_output = args
        .json
        .as_deref()
        .map(|path| Output::prepare("--json", path, &inputs))
        .transpose()?;
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
    // The file first: a closed terminal pipe must not lose it.
    if let Some(output) = &json_output {
        let text = serde_json::to_string_pretty(&json::to_json(&report))? + "\n";
        output.write("JSON report", text.as_bytes())?;
    }
    console.print(&terminal::render(&report))?;
    if let Some(output) = json_output.filter(|o| !o.is_stdout()) {
        console.line(format_args!("\nJSON report written to {}", output.name()))?;
    }
    Ok(verdict)
}

/// True for the path `-`.
fn is_stdin(path: &Path) -> bool {
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
