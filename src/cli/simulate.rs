//! `legwise simulate`, and the same in memory (the Python module).

use super::args::SimulateArgs;
use super::console::Console;
use super::outputs::model_inputs;
use super::verdict::Verdict;
use crate::files::Output;
use crate::model::Mechanism;
use crate::pipeline::simulate;

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<Verdict> {
    let settings = args.simulation.settings()?;
    let mechanism = Mechanism::load(&args.model)?;
    let inputs = model_inputs(&args.model, &mechanism);
    let output = Output::prepare("--out", &args.out, &inputs)?;
    let mut console = Console::new(output.is_stdout());
    // With an instrument, the file holds what the instrument reports (its targets' coordinates
    // in its own frame), as `identify --measurements` reads it for that model.
    let simulated = simulate(&mechanism, &settings)?;
    let csv = simulated.measurements.to_csv(&mechanism)?;
    output.write("measurement CSV", csv.as_bytes())?;
    console.line(&simulated.source)?;
    let what = if mechanism.instrument.is_some() {
        "rows of target coordinates (instrument frame)"
    } else {
        "measured poses"
    };
    console.line(format_args!(
        "wrote {} {what} to {}",
        simulated.measurements.rows(),
        output.name()
    ))?;
    Ok(Verdict::from_reasons(mechanism.warnings.clone()))
}

/// `legwise simulate` with the command's arguments `arguments` (those after `simulate`, without
/// `--out`): the measurement CSV the command writes, and the description of the simulation it
/// prints.
///
/// # Errors
/// As the command: a usage error (clap's message), a bad option or model, a failed simulation.
pub fn simulate_in_memory(arguments: &[String]) -> anyhow::Result<(String, String)> {
    use clap::Parser;
    let words = ["legwise", "simulate", "--out", "-"]
        .map(String::from)
        .into_iter();
    let cli = super::args::Cli::try_parse_from(words.chain(arguments.iter().cloned()))
        .map_err(|e| anyhow::anyhow!("{}", e.render().to_string().trim_end()))?;
    let super::args::Command::Simulate(args) = cli.command else {
        anyhow::bail!("not a simulation");
    };
    let settings = args.simulation.settings()?;
    let mechanism = Mechanism::load(&args.model)?;
    let simulated = simulate(&mechanism, &settings)?;
    Ok((simulated.measurements.to_csv(&mechanism)?, simulated.source))
}
