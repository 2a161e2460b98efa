//! `legwise identify`.

use super::IdentifyArgs;
use crate::identify::estimate::identify;
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::{json, terminal, IdentifyReport};

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    args.simulation.options()?;
    let (data, real, source) = match &args.measurements {
        Some(path) => (
            file::read(path, &mechanism)?,
            None,
            path.display().to_string(),
        ),
        None => {
            let (experiment, source) = args.simulation.experiment(&mechanism)?;
            (experiment.measurements, Some(experiment.real), source)
        }
    };
    let mut results = Vec::new();
    for strategy in args.strategy.strategies() {
        results.push(identify(&mechanism, &data, strategy, args.solver.kind())?);
    }
    let report = IdentifyReport {
        mechanism: &mechanism,
        source,
        real,
        results,
    };
    print!("{}", terminal::render(&report));
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&json::to_json(&report))?;
        std::fs::write(path, text).map_err(|e| {
            anyhow::anyhow!("{}: cannot write the JSON report: {e}", path.display())
        })?;
        println!("\nJSON report written to {}", path.display());
    }
    Ok(())
}
