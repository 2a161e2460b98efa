//! `legwise simulate`.

use super::SimulateArgs;
use crate::measure::{file, simulate};
use crate::model::Mechanism;

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    let experiment = simulate::simulate(&mechanism, args.simulation.options()?)?;
    file::write(&args.out, &mechanism, &experiment.measurements)?;
    println!(
        "wrote {} measured poses to {}",
        experiment.measurements.poses.len(),
        args.out.display()
    );
    Ok(())
}
