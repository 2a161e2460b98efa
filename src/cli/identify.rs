//! `legwise identify`.

use super::IdentifyArgs;
use crate::identify::estimate::identify;
use crate::measure::{file, simulate};
use crate::model::Mechanism;
use crate::report::{json, terminal, IdentifyReport};

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<()> {
    let mechanism = Mechanism::load(&args.model)?;
    let options = args.simulation.options()?;
    let (data, real, source) = match &args.measurements {
        Some(path) => (
            file::read(path, &mechanism)?,
            None,
            path.display().to_string(),
        ),
        None => {
            let setup = simulate::setup(&mechanism)?;
            let experiment = simulate::simulate(&mechanism, options)?;
            let source = format!(
                "simulated: seed {}, {} poses per leg and {} shared, noise scale {}",
                options.seed.unwrap_or(setup.seed),
                options.poses_per_leg.unwrap_or(setup.poses_per_leg),
                options.poses_per_leg.unwrap_or(setup.poses_per_leg),
                options.noise_scale
            );
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
