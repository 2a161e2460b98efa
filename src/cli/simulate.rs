//! `legwise simulate`.

use super::console::Console;
use super::output::Output;
use super::{SimulateArgs, Verdict};
use crate::measure::file;
use crate::model::Mechanism;

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<Verdict> {
    args.simulation.options()?;
    let mechanism = Mechanism::load(&args.model)?;
    let output = Output::prepare(
        "--out",
        &args.out,
        &super::model_inputs(&args.model, &mechanism),
    )?;
    let mut console = Console::new(output.is_stdout());
    let (experiment, source) = args.simulation.experiment(&mechanism)?;
    let csv = file::to_csv(&mechanism, &experiment.measurements);
    output.write("measurement CSV", csv.as_bytes())?;
    console.line(source)?;
    console.line(format_args!(
        "wrote {} measured poses to {}",
        experiment.measurements.poses.len(),
        output.name()
    ))?;
    Ok(Verdict::Trusted)
}
