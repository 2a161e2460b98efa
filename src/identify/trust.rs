//! Whether a finished identification can be trusted: the reasons it cannot (each a sentence),
//! empty when it can. A non-empty list ends the command with exit code 3.

use super::estimate::StrategyResult;

/// The reasons the results must not be trusted: every leg whose residuals reject the declared
/// measurement noise (see [`super::statistics`]).
pub fn trust_issues(results: &[StrategyResult]) -> Vec<String> {
    let mut issues = Vec::new();
    for result in results {
        for leg in &result.legs {
            if let Some(test) = leg.statistics.noise_test.as_ref().filter(|t| t.rejected) {
                issues.push(format!(
                    "{}: leg {}: the residuals reject the declared noise (σ̂ {:.3e} times the \
                     declared scatter, p = {:.2e}): check the units (degrees vs radians, \
                     millimetres vs metres), the outliers and the model",
                    result.strategy.name(),
                    leg.leg,
                    test.sigma_ratio,
                    test.p_value
                ));
            }
        }
    }
    issues
}
