//! A model with some of its values replaced: quantities (their derived parameters following),
//! leg parameters, instrument parameters. What a factor set's estimates or a firmware's values
//! describe, as a model to command or evaluate.

use super::Mechanism;
use crate::error::{Error, Result};

/// `mechanism` with the named values set (SI): a quantity (every derived parameter then
/// follows its expression), a leg parameter or an instrument parameter; everything else as it
/// is. The model a factor set's estimates describe, or a firmware's values.
///
/// # Errors
/// A name the model has no quantity or parameter of; a derived parameter that is not finite
/// at the new quantities (named with its value).
pub fn with_values(mechanism: &Mechanism, values: &[(String, f64)]) -> Result<Mechanism> {
    let mut quantities: Vec<f64> = mechanism.quantities.iter().map(|q| q.nominal).collect();
    let mut others = Vec::new();
    for (name, value) in values {
        match mechanism.quantities.iter().position(|q| &q.name == name) {
            Some(k) => quantities[k] = *value,
            None => others.push((name.as_str(), *value)),
        }
    }
    let is_parameter = |name: &str| {
        mechanism
            .legs
            .iter()
            .flat_map(|l| &l.params)
            .any(|p| p.name == name)
            || mechanism
                .instrument
                .iter()
                .flat_map(|i| &i.parameters)
                .any(|p| p.name == name)
    };
    if let Some((name, _)) = others.iter().find(|(name, _)| !is_parameter(name)) {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "quantities".into(),
            message: format!("expected a quantity or a parameter `{name}`, found none"),
        });
    }
    for p in mechanism.legs.iter().flat_map(|l| &l.params) {
        if let Some(e) = &p.derived {
            let value: f64 = e.eval(&quantities);
            if !value.is_finite() {
                return Err(Error::Model {
                    path: mechanism.model_path.clone(),
                    field: format!("parameters.{}.value", p.name),
                    message: format!("not finite at the quantities given ({value})"),
                });
            }
        }
    }
    let value_of = |name: &str| others.iter().find(|(n, _)| *n == name).map(|(_, v)| *v);
    Ok(mechanism.edited(|parts| {
        for (q, value) in parts.quantities.iter_mut().zip(&quantities) {
            q.nominal = *value;
        }
        for p in parts.legs.iter_mut().flat_map(|l| &mut l.params) {
            if let Some(e) = &p.derived {
                p.nominal = e.eval(&quantities);
            }
            if let Some(value) = value_of(&p.name) {
                p.nominal = value;
            }
        }
        for p in parts.instrument.iter_mut().flat_map(|i| &mut i.parameters) {
            if let Some(value) = value_of(&p.name) {
                p.nominal = value;
            }
        }
    }))
}
