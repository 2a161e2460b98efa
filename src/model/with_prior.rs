//! A model whose fit takes a previous calibration as its prior (`identify --prior FILE`).

use super::prior_covariance::PriorCovariance;
use super::Mechanism;
use crate::error::{Error, Result};

/// `mechanism` with the calibration `prior` as the prior of its fit.
///
/// # Errors
/// A parameter the calibration names that the model does not have.
pub fn with_prior(mechanism: &Mechanism, prior: &PriorCovariance) -> Result<Mechanism> {
    let legs = mechanism.legs.iter().flat_map(|l| &l.params);
    let mut known = legs.map(|p| p.name.as_str()).collect::<Vec<_>>();
    if let Some(instrument) = &mechanism.instrument {
        known.extend(instrument.parameters.iter().map(|p| p.name.as_str()));
    }
    if let Some((i, name)) = prior
        .parameters
        .iter()
        .enumerate()
        .find(|(_, n)| !known.contains(&n.as_str()))
    {
        return Err(Error::Model {
            path: prior.source.clone(),
            field: format!("calibration.parameters[{i}]"),
            message: format!(
                "`{name}` is not a parameter of {}: a prior from another model",
                mechanism.model_path.display()
            ),
        });
    }
    Ok(mechanism.edited(|parts| parts.prior_covariance = Some(prior.clone())))
}
