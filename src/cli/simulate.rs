//! `legwise simulate`.

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
