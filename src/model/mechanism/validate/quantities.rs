//! The model's quantities, the parameters derived from them, and its factor sets: each
//! expression parsed against the quantities and equal to its parameter's nominal value, each
//! factor set naming what the model has.

use std::collections::HashSet;

use super::Builder;
use crate::error::Result;
use crate::model::expression::Expression;
use crate::model::file::ModelFile;
use crate::model::instrument::Instrument;
use crate::model::leg::LegModel;
use crate::model::params::Unit;
use crate::model::quantities::{FactorSet, Quantity};

/// Largest difference between a derived parameter's expression at the nominal quantities and
/// the parameter's nominal value (the URDF's or the model file's), relative to the larger of 1
/// and the value: the two must say the same thing.
const NOMINAL_AGREEMENT: f64 = 1e-9;

impl Builder<'_> {
    /// The quantities; each derived parameter's expression.
    pub(super) fn quantities(
        &self,
        file: &ModelFile,
        legs: &mut [LegModel],
    ) -> Result<Vec<Quantity>> {
        let parameter_names: HashSet<&str> =
            file.parameters.iter().map(|p| p.name.as_str()).collect();
        let mut quantities: Vec<Quantity> = Vec::new();
        for (q, entry) in file.quantities.iter().enumerate() {
            let field = format!("quantities[{q}]");
            let name = entry.name.as_str();
            let plain = !name.is_empty()
                && name
                    .chars()
                    .next()
                    .is_some_and(|c| c.is_alphabetic() || c == '_')
                && name.chars().all(|c| c.is_alphanumeric() || c == '_');
            if !plain || name == "pi" {
                return Err(self.error(
                    format!("{field}.name"),
                    format!(
                        "`{name}` cannot be written in an expression: expected letters, digits \
                         and `_`, starting with a letter (and not `pi`)"
                    ),
                ));
            }
            if quantities.iter().any(|k| k.name == name) || parameter_names.contains(name) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!("`{name}` is already the name of a quantity or a parameter"),
                ));
            }
            if !entry.value.is_finite() {
                return Err(self.error(format!("{field}.value"), "expected a finite number"));
            }
            let unit = match entry.unit.as_str() {
                "m" => Unit::Metre,
                "rad" => Unit::Radian,
                "1" => Unit::One,
                other => {
                    return Err(self.error(
                        format!("{field}.unit"),
                        format!("`{other}` is not one of m, rad, 1 (SI units)"),
                    ))
                }
            };
            quantities.push(Quantity {
                name: name.to_string(),
                nominal: entry.value,
                unit,
                prior: self.prior_sigma(entry.prior, &field)?,
            });
        }
        let names: Vec<&str> = quantities.iter().map(|q| q.name.as_str()).collect();
        let values: Vec<f64> = quantities.iter().map(|q| q.nominal).collect();
        for (p, entry) in file.parameters.iter().enumerate() {
            let Some(text) = &entry.value else { continue };
            let field = format!("parameters[{p}].value");
            let expression = Expression::parse(text, &names)
                .map_err(|e| self.error(field.clone(), format!("`{text}`: {e}")))?;
            let parameter = legs
                .iter_mut()
                .flat_map(|l| l.params.iter_mut())
                .find(|k| k.name == entry.name)
                .expect("every parameter entry made a parameter");
            let value = expression.eval(&values);
            let tolerance = NOMINAL_AGREEMENT * parameter.nominal.abs().max(1.0);
            if !value.is_finite() || (value - parameter.nominal).abs() > tolerance {
                return Err(self.error(
                    field,
                    format!(
                        "`{text}` is {value} at the quantities' values, but `{}` is {} in the \
                         model (URDF or model file): make them agree, the expression holds the \
                         parameter to it",
                        entry.name, parameter.nominal
                    ),
                ));
            }
            parameter.derived = Some(expression);
        }
        Ok(quantities)
    }

    /// The factor sets: names unique, each factor a quantity, a parameter (not one that
    /// follows a quantity the set fits) or an instrument parameter, named once.
    pub(super) fn factor_sets(
        &self,
        file: &ModelFile,
        legs: &[LegModel],
        quantities: &[Quantity],
        instrument: Option<&Instrument>,
    ) -> Result<Vec<FactorSet>> {
        let mut sets: Vec<FactorSet> = Vec::new();
        for (s, entry) in file.factor_sets.iter().enumerate() {
            let field = format!("factor_sets[{s}]");
            if entry.name.trim().is_empty() || sets.iter().any(|k| k.name == entry.name) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!("`{}`: expected a name no other set has", entry.name),
                ));
            }
            if entry.fit.is_empty() {
                return Err(self.error(
                    format!("{field}.fit"),
                    "expected at least one quantity or parameter to fit",
                ));
            }
            for (f, factor) in entry.fit.iter().enumerate() {
                let at = format!("{field}.fit[{f}]");
                if entry.fit[..f].contains(factor) {
                    return Err(self.error(at, format!("`{factor}` is listed twice")));
                }
                let parameter = legs
                    .iter()
                    .flat_map(|l| &l.params)
                    .find(|p| &p.name == factor);
                let moved_by = parameter.and_then(|p| p.derived.as_ref()).and_then(|e| {
                    let used = e.names_used();
                    used.into_iter()
                        .map(|q| &quantities[q].name)
                        .find(|q| entry.fit.contains(q))
                });
                if let Some(quantity) = moved_by {
                    return Err(self.error(
                        at,
                        format!(
                            "`{factor}` follows `{quantity}`, which the set fits too: fit one \
                             or the other"
                        ),
                    ));
                }
                let known = parameter.is_some()
                    || quantities.iter().any(|q| &q.name == factor)
                    || instrument.is_some_and(|i| i.parameter_index(factor).is_some());
                if !known {
                    return Err(self.error(
                        at,
                        format!("`{factor}` is no quantity, parameter or instrument parameter"),
                    ));
                }
            }
            sets.push(FactorSet {
                name: entry.name.clone(),
                factors: entry.fit.clone(),
                note: entry.note.clone(),
            });
        }
        Ok(sets)
    }
}
