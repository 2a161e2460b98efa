//! Priors in the joint fit through an instrument (docs/statistics.md §8): the fits that cannot
//! weigh a prior refuse it by field, and each prior's share of the data in the estimate.

use nalgebra::DMatrix;

use super::problem::IdentificationProblem;
use super::result::{FitOptions, LegEstimate, Strategy, Weighting};
use crate::error::{Error, Result};
use crate::model::Mechanism;

/// Each prior's data share, `1 − σ_d²/σ_prior²` from the declared noise's covariance
/// `declared` of the problem's unknowns, written into the legs' parameter estimates.
pub(super) fn set_data_shares(
    problem: &IdentificationProblem<'_>,
    declared: &DMatrix<f64>,
    legs: &mut [LegEstimate],
) {
    for (column, name) in problem.names().iter().enumerate() {
        let Some(sigma) = problem.prior_sigma(column) else {
            continue;
        };
        let variance = declared[(column, column)].max(0.0);
        let share = (1.0 - variance / sigma.powi(2)).clamp(0.0, 1.0);
        let parameters = legs.iter_mut().flat_map(|l| l.parameters.iter_mut());
        if let Some(p) = parameters
            .filter(|p| p.identified)
            .find(|p| &p.name == name)
        {
            p.data_share = Some(share);
        }
    }
}

/// A prior is weighed against the data by the declared noise: refused when the fit is not the
/// joint least-squares one weighted by it.
pub(super) fn refuse_priors_without_weights(
    mechanism: &Mechanism,
    problem: &IdentificationProblem<'_>,
    strategy: Strategy,
    options: FitOptions,
) -> Result<()> {
    let Some(first) = problem.prior_rows().first() else {
        return Ok(());
    };
    let why = if strategy != Strategy::Joint {
        Some(format!(
            "the {} strategy fits without priors",
            strategy.name()
        ))
    } else if options.weights == Weighting::Unweighted {
        Some("--weights none leaves nothing to weigh the prior against".to_string())
    } else if let Some(loss) = options.robust {
        Some(format!(
            "--robust {} would bend the prior's row as it bends an outlier's",
            loss.name()
        ))
    } else if options.expected_noise(mechanism).is_none() {
        Some("the model declares no measurement noise (`noise:`) to weigh it against".into())
    } else {
        None
    };
    match why {
        Some(why) => Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: format!("prior of {}", first.name),
            message: format!(
                "a fit with priors is the joint least-squares one weighted by the declared noise \
                 (the maximum a posteriori estimate); {why}"
            ),
        }),
        None => Ok(()),
    }
}
