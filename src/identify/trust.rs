//! Whether an identification's results can be trusted: one sentence per problem found.

use super::estimate::StrategyResult;

/// One sentence per reason not to trust `results`: each solver run that did not converge,
/// naming the strategy, the solver, the legs and why it stopped. Empty when every run converged.
pub fn trust_issues(results: &[StrategyResult]) -> Vec<String> {
    results
        .iter()
        .flat_map(|result| {
            result
                .runs
                .iter()
                .filter(|run| !run.converged)
                .map(move |run| {
                    format!(
                        "{} ({}) did not converge for leg{} {}: {} after {} iterations and {} \
                         residual evaluations; the estimate must not be trusted",
                        result.solver.name(),
                        result.strategy.name(),
                        if run.legs.len() == 1 { "" } else { "s" },
                        run.legs.join(", "),
                        run.stop_reason,
                        run.iterations,
                        run.residual_evaluations
                    )
                })
        })
        .collect()
}
