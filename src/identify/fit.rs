//! One problem fitted as [`FitOptions`] ask: plain least squares, weighted by the declared
//! noise, or with a robust loss (iteratively reweighted, [`super::robust`]). The result carries
//! the problem as finally weighted, so its residuals, Jacobian and statistics match the fit.

use nalgebra::DVector;

use super::problem::IdentificationProblem;
use super::result::{FitOptions, Weighting};
use super::robust::{self, RobustError};
use super::solve_from::{solve_from, FitError};
use super::statistics::{row_variances, FitKind};
use crate::model::mechanism::MeasurementNoise;
use crate::solver::{SolverKind, SolverOutcome};

/// A fitted problem.
pub(super) struct Fitted<'a> {
    /// The problem with the weights of the fit (none, the noise's, or the final robust ones).
    pub(super) problem: IdentificationProblem<'a>,
    /// The solver's outcome (of the last weighted solve for a robust fit), at the estimate.
    pub(super) outcome: SolverOutcome,
    /// Least squares or robust.
    pub(super) kind: FitKind,
}

/// Fits `problem` from `x0` with `solver` as `options` ask; `noise` is the declared noise (only
/// if some σ is non-zero).
pub(super) fn fit<'a>(
    problem: &IdentificationProblem<'a>,
    x0: &DVector<f64>,
    solver: SolverKind,
    options: FitOptions,
    noise: Option<&MeasurementNoise>,
) -> Result<Fitted<'a>, FitError> {
    let needs_noise = |what: &str| FitError::NeedsNoise(what.to_string());
    let weighted = match (options.weights, options.robust) {
        (Weighting::Noise, None) => {
            let noise = noise.ok_or_else(|| needs_noise("--weights noise"))?;
            let variances = row_variances(problem, x0, noise).map_err(FitError::Block)?;
            let weights = inverse(&variances).ok_or_else(|| {
                needs_noise("--weights noise (a row's expected residual variance is zero)")
            })?;
            problem.clone().with_weights(&weights)
        }
        _ => problem.unweighted(),
    };
    let outcome = solve_from(&weighted, x0, solver)?;
    let Some(loss) = options.robust else {
        return Ok(Fitted {
            problem: weighted,
            outcome,
            kind: FitKind::LeastSquares,
        });
    };
    let option = format!("--robust {}", loss.name());
    let noise = noise.ok_or_else(|| needs_noise(&option))?;
    let variances = row_variances(problem, &outcome.x, noise).map_err(FitError::Block)?;
    let sigma: Vec<f64> = inverse(&variances)
        .ok_or_else(|| {
            needs_noise(&format!(
                "{option} (a row's expected residual variance is zero)"
            ))
        })?
        .iter()
        .map(|w| 1.0 / w.sqrt())
        .collect();
    let robust = robust::fit(problem, &outcome.x, loss, &sigma, solver).map_err(|e| match e {
        RobustError::Block(e) => FitError::Block(e),
        RobustError::Solver(message) => FitError::Solver(message),
    })?;
    let mut outcome = robust.outcome;
    outcome.x = robust.x;
    Ok(Fitted {
        problem: problem.clone().with_weights(&robust.weights),
        outcome,
        kind: FitKind::Robust,
    })
}

/// `1 / v` for every variance, if all are positive and finite.
fn inverse(variances: &[f64]) -> Option<Vec<f64>> {
    variances
        .iter()
        .map(|&v| (v > 0.0 && v.is_finite()).then(|| 1.0 / v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::inverse;

    /// Weights are `1/v` only when every variance is a usable one: a zero variance (a row no
    /// declared noise reaches) or an infinite one must refuse the weighting, not give an
    /// infinite or a zero weight.
    #[test]
    fn only_positive_finite_variances_are_inverted() {
        assert_eq!(inverse(&[4.0, 0.5]), Some(vec![0.25, 2.0]));
        assert_eq!(inverse(&[4.0, 0.0]), None);
        assert_eq!(inverse(&[f64::INFINITY, 4.0]), None);
        assert_eq!(inverse(&[-1.0]), None);
        assert_eq!(inverse(&[f64::NAN]), None);
        assert_eq!(inverse(&[]), Some(vec![]));
    }
}
