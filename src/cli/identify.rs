//! `legwise identify`.

use super::{IdentifyArgs, Untrusted};
use crate::identify::estimate::identify_with;
use crate::identify::trust::trust_issues;
use crate::measure::file;
use crate::model::Mechanism;
use crate::report::{json, terminal, IdentifyReport};

pub(super) fn run(args: &IdentifyArgs) -> anyhow::Result<()> {
    let mut mechanism = Mechanism::load(&args.model)?;
    let options = args.simulation.options()?;
    let (data, real, source) = match &args.measurements {
        Some(path) => (
            file::read(path, &mechanism)?,
            None,
            path.display().to_string(),
        ),
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
    let issues = trust_issues(&report.results);
    if !issues.is_empty() {
        return Err(Untrusted(issues).into());
    }
    Ok(())
}
