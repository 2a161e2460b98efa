//! `legwise simulate`.

use super::console::Console;
use super::output::Output;
use super::{SimulateArgs, Verdict};
use crate::measure::observe_simulate::{observed_from, without_pose_noise};
use crate::measure::{file, observations};
use crate::model::Mechanism;

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<Verdict> {
    let options = args.simulation.options()?;
    let mechanism = Mechanism::load(&args.model)?;
    let output = Output::prepare(
        "--out",
        &args.out,
        &super::model_inputs(&args.model, &mechanism),
    )?;
    let mut console = Console::new(output.is_stdout());
    // With an instrument, the file holds what the instrument reports (its targets' coordinates
    // in its own frame), as `identify --measurements` reads it for that model.
    let (csv, rows, source) = if mechanism.instrument.is_some() {
        let (experiment, source) = args
            .simulation
            .experiment(&without_pose_noise(&mechanism))?;
        let observed = observed_from(&mechanism, experiment, options)?;
        let rows = observed.observations.rows.len();
        let csv = observations::to_csv(&mechanism, &observed.observations)?;
        (csv, rows, source)
    } else {
        let (experiment, source) = args.simulation.experiment(&mechanism)?;
        let rows = experiment.measurements.len();
        (
            file::to_csv(&mechanism, &experiment.measurements),
            rows,
            source,
        )
    };
    output.write("measurement CSV", csv.as_bytes())?;
    console.line(source)?;
    let what = if mechanism.instrument.is_some() {
        "rows of target coordinates (instrument frame)"
    } else {
        "measured poses"
    };
    console.line(format_args!("wrote {rows} {what} to {}", output.name()))?;
    Ok(Verdict::Trusted)
}
