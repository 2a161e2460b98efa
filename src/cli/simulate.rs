//! `legwise simulate`.

use super::SimulateArgs;
use crate::measure::file;
use crate::model::Mechanism;

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    let (experiment, source) = args.simulation.experiment(&mechanism)?;
    file::write(&args.out, &mechanism, &experiment.measurements)?;
    println!("{source}");
    println!(
        "wrote {} measured poses to {}",
        experiment.measurements.poses.len(),
        args.out.display()
    );
    Ok(())
}
