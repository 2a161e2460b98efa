//! The joint fit through an instrument weighted by the declared noise (docs/statistics.md,
//! "Weights"): generalised least squares on the residuals' variances, each residual by the
//! inverse of its expected variance under the declared noise (`V`'s diagonal,
//! [`IdentificationProblem::row_variances`]: a height by the probe's σ, a distance by its own,
//! a measured pose's rows by the pose and reading noise), evaluated at the estimate: weights at
//! the start, a fit, then weights at the estimate and a fit from it until they agree. The
//! covariance of the weighted estimate is the sandwich of [`super::sandwich`] on the weighted
//! rows ([`super::sandwich::NoiseLoadings::scaled`]), which holds whatever correlation `V` has beyond its
//! diagonal.

use nalgebra::DVector;

use super::fit::inverse;
use super::problem::IdentificationProblem;
use crate::model::mechanism::MeasurementNoise;
use crate::solver::{solve_bordered, SolverOutcome};

/// Most fits of [`weighted_joint_fit`].
const MAX_WEIGHTINGS: usize = 20;

/// Largest relative change of a residual's weight between two fits at which the weights are
/// consistent with the estimate.
const WEIGHT_TOLERANCE: f64 = 1e-12;

/// A joint fit weighted by the declared noise: its outcome (the iterations and evaluations of
/// every fit), and `√w` of every residual (the weights the estimate minimises).
#[derive(Debug, Clone)]
pub struct WeightedFit {
    /// The last fit's outcome, with every fit's iterations and evaluations.
    pub outcome: SolverOutcome,
    /// `√w_i` per residual, in the problem's row order.
    pub scales: Vec<f64>,
}

/// What a sequence of solves spent.
#[derive(Debug, Default)]
struct Spent {
    iterations: u64,
    residuals: u64,
    jacobians: u64,
}

impl Spent {
    fn add(&mut self, outcome: &SolverOutcome) {
        self.iterations += outcome.iterations;
        self.residuals += outcome.residual_evaluations;
        self.jacobians += outcome.jacobian_evaluations;
    }
}

/// The joint fit of `problem` (unweighted, as built) from `x0` weighted by `noise`, each
/// weight times `mask[i]` when given (0 leaves a dropped row out); `Ok(None)` when a
/// residual's expected variance is zero (nothing to weight it by: the caller fits unweighted
/// and says so).
///
/// # Errors
/// The variances cannot be evaluated, or the solver's error, as text.
pub fn weighted_joint_fit(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    noise: &MeasurementNoise,
    mask: Option<&[f64]>,
) -> Result<Option<WeightedFit>, String> {
    let weights_at = |x: &DVector<f64>| -> Result<Option<Vec<f64>>, String> {
        let variances = problem.row_variances(x, noise).map_err(|e| e.to_string())?;
        Ok(inverse(&variances).map(|w| match mask {
            Some(mask) => w.iter().zip(mask).map(|(w, m)| w * m).collect(),
            None => w,
        }))
    };
    let Some(mut weights) = weights_at(x0)? else {
        return Ok(None);
    };
    let fit = |weights: &[f64], from: &DVector<f64>| {
        let weighted = problem.clone().with_weights(weights);
        solve_bordered(&weighted, from.clone()).map_err(|e| e.to_string())
    };
    let mut spent = Spent::default();
    let mut outcome = fit(&weights, x0)?;
    spent.add(&outcome);
    for _ in 1..MAX_WEIGHTINGS {
        let Some(next) = weights_at(&outcome.x)? else {
            return Ok(None);
        };
        let change = next
            .iter()
            .zip(&weights)
            .filter(|(_, b)| **b > 0.0)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0, f64::max);
        if change <= WEIGHT_TOLERANCE {
            break;
        }
        weights = next;
        outcome = fit(&weights, &outcome.x)?;
        spent.add(&outcome);
    }
    // The last fit's outcome, with every fit's counts.
    outcome.iterations = spent.iterations;
    outcome.residual_evaluations = spent.residuals;
    outcome.jacobian_evaluations = spent.jacobians;
    Ok(Some(WeightedFit {
        outcome,
        scales: weights.iter().map(|w| w.sqrt()).collect(),
    }))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::weighted_joint_fit;
    use crate::identify::problem::IdentificationProblem;
    use crate::measure::Measurements;
    use crate::model::Mechanism;
    use crate::pipeline::{simulate, SimulationSettings};
    use crate::solver::solve_bordered;

    /// A probe's heights all have the probe's variance whatever the parameters: the weights at
    /// the first estimate are the starting ones, so the weighted fit is one solve, its
    /// counts that solve's (and the weights `1/σ²`).
    #[test]
    fn weights_that_do_not_change_make_one_solve() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mechanism = Mechanism::load(&root.join("models/delta-probe.yaml")).unwrap();
        let simulated = simulate(&mechanism, &SimulationSettings::default()).unwrap();
        let Measurements::Targets(observations) = simulated.measurements else {
            panic!("a probe's touches");
        };
        let problem = IdentificationProblem::through_instrument(&mechanism, &observations).unwrap();
        let noise = mechanism.noise.unwrap();
        let x0 = problem.start();
        let fit = weighted_joint_fit(&problem, &x0, &noise, None)
            .unwrap()
            .unwrap();
        let sigma = noise.pose[2];
        let weights = vec![1.0 / (sigma * sigma); problem.residuals(&x0).unwrap().len()];
        for scale in &fit.scales {
            assert!((scale * sigma - 1.0).abs() < 1e-12, "{scale}");
        }
        let once = solve_bordered(&problem.clone().with_weights(&weights), x0).unwrap();
        assert!(once.iterations > 0);
        // One solve's counts (to a step: the weights are 1/σ² to round-off, and a solve's
        // last steps are decided at round-off), not twenty solves'.
        let near = |a: u64, b: u64| a >= 1 && a <= b + 1 && b <= a + 1;
        assert!(
            near(fit.outcome.iterations, once.iterations),
            "{} vs {}",
            fit.outcome.iterations,
            once.iterations
        );
        assert!(near(
            fit.outcome.residual_evaluations,
            once.residual_evaluations
        ));
        assert!(near(
            fit.outcome.jacobian_evaluations,
            once.jacobian_evaluations
        ));
        assert!((fit.outcome.x - &once.x).norm() <= 1e-12 * once.x.norm());
    }
}
