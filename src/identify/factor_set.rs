//! One factor set of the model fitted (`factor_sets:` in the model file): its quantities,
//! parameters and instrument parameters the unknowns, everything else held at nominal.
//!
//! The fit is the model's own problem (the same residual blocks and forward rows, the same
//! dual-number Jacobian) seen through a change of unknowns: the problem's unknowns `x` (every
//! leg parameter the set moves, directly or through a quantity, and the set's instrument
//! parameters) are a function `x = g(θ)` of the set's factors `θ`, the derived parameters by
//! their expressions; its Jacobian is `∂r/∂x · ∂g/∂θ` (the expressions' derivatives by dual
//! numbers). Weighted by the declared noise as the default fit is, solved by
//! Levenberg–Marquardt; σ from the declared noise (a firmware-sized set of touches has too few
//! degrees of freedom to estimate it), the residual's own scale printed beside it.

use nalgebra::DVector;

use super::factor_unknowns::{FactorPrior, InFactors, Source, Unknowns};
use super::observability::{analyse, Observability};
use super::problem::IdentificationProblem;
use super::result::FitOptions;
use super::statistics::leverages;
use crate::error::{Error, Result};
use crate::evaluate::predicted_pose::predicted_pose_sigma;
use crate::evaluate::predicted_position::predicted_position_of;
use crate::identify::result::PredictedPosition;
use crate::measure::Measurements;
use crate::model::params::Unit;
use crate::model::quantities::FactorSet;
use crate::model::Mechanism;
use crate::solver::{solve, SolverKind};

/// One factor's estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct FactorEstimate {
    /// Its name (a quantity, a parameter or an instrument parameter).
    pub name: String,
    /// Its nominal value, SI units.
    pub nominal: f64,
    /// Its estimate, SI units.
    pub estimate: f64,
    /// Its standard deviation from the declared noise (`NaN` without one or when the set
    /// cannot determine it).
    pub sigma: f64,
    /// SI unit.
    pub unit: Unit,
    /// Its prior's standard deviation (model file `prior:` on the parameter or quantity), if
    /// any: the set's fit is then the maximum a posteriori one.
    pub prior: Option<f64>,
}

impl FactorEstimate {
    /// The share of the factor's information that comes from the data, `1 − σ²/σ_prior²` in
    /// `[0, 1]`; `None` without a prior or a σ.
    pub fn data_share(&self) -> Option<f64> {
        let prior = self.prior?;
        self.sigma
            .is_finite()
            .then(|| (1.0_f64 - (self.sigma / prior).powi(2)).clamp(0.0, 1.0))
    }
}

/// A factor set fitted.
#[derive(Debug, Clone)]
pub struct FactorSetFit {
    /// The set's name.
    pub name: String,
    /// Where the set comes from, if the model says.
    pub note: Option<String>,
    /// Each factor, in the set's order.
    pub factors: Vec<FactorEstimate>,
    /// Residuals of the fit.
    pub rows: usize,
    /// Residuals minus the factors the data determine (their rank; with priors the
    /// [`Self::effective_factors`], rounded).
    pub degrees_of_freedom: usize,
    /// RMS of the residuals (measurement units: metres, radians).
    pub rms: f64,
    /// `Σ (r_i / σ_i)²` at the estimate, `NaN` without a declared noise.
    pub chi_square: f64,
    /// The rank answer at the estimate (in the factors).
    pub observability: Observability,
    /// The predicted σ of the first target's position over the workspace (forward
    /// instruments with a `workspace.grid`), or of the end effector's from measured poses
    /// (no instrument).
    pub predicted: Option<PredictedPosition>,
    /// RMS of each row's leave-one-out prediction error, measurement units: the residual the
    /// row would have if the set were fitted without it, `r_i / (1 − h_ii)` (`h` the leverages
    /// of the weighted Jacobian; exact for a linear model, to first order here). `None` when a
    /// row is the only one to see some factor (`h_ii` = 1) or the set is rank-deficient.
    pub leave_one_out: Option<f64>,
    /// The factors the data determine, `k`: their number (the rank), or with priors the trace
    /// of the data's rows' hat matrix (a factor resting on its prior counts for the share the
    /// data give it).
    pub effective_factors: f64,
    /// The directions of the factors the data alone cannot see, which rest on the priors
    /// (column-scaled); empty without priors or when the data see every factor.
    pub resting_on_prior: Vec<String>,
    /// Akaike's information criterion with the declared noise: `χ² + 2 k` (`k` the
    /// [`Self::effective_factors`]); `NaN` without a declared noise. Lower is better, between
    /// sets fitted on the same rows.
    pub information: f64,
    /// Akaike's criterion corrected for few rows (Hurvich and Tsai's AICc): `χ² + 2k +
    /// 2k(k + 1)/(n − k − 1)` over `n` rows; infinite when `n ≤ k + 1` (the rows cannot judge
    /// the set), `NaN` without a declared noise. Lower is better, between sets on the same rows.
    pub information_corrected: f64,
    /// Weighted solves until the weights at the estimate were the ones it was fitted with (1
    /// when the rows' variances do not depend on the factors, as a probe's heights).
    pub weightings: usize,
}

impl FactorSetFit {
    /// `√(χ² / dof)`: the residual's scale against the declared noise (1 when they agree);
    /// with priors `dof` is the rows less the effective factors.
    pub fn scale(&self) -> f64 {
        match self.factors.iter().any(|f| f.prior.is_some()) {
            false => (self.chi_square / self.degrees_of_freedom as f64).sqrt(),
            true => (self.chi_square / (self.rows as f64 - self.effective_factors)).sqrt(),
        }
    }
}

/// Most reweighting rounds (the row variances at the estimate, as the default fit's).
const MAX_WEIGHTINGS: usize = 20;

/// Largest relative change of a row's weight at which the weights are consistent.
const WEIGHT_TOLERANCE: f64 = 1e-12;

/// Fits `set` of `mechanism` on `data`.
///
/// # Errors
/// Measurements of the other kind than the model's, a leg without rows, a pose out of reach
/// at the start, or the solver's failure.
pub fn fit_factor_set(
    mechanism: &Mechanism,
    data: &Measurements,
    set: &FactorSet,
) -> Result<FactorSetFit> {
    let uses_factor = |expression: &crate::model::expression::Expression| {
        expression
            .names_used()
            .iter()
            .any(|&q| set.factors.contains(&mechanism.quantities[q].name))
    };
    // The problem's unknowns: every leg parameter the set moves, its instrument parameters.
    let inner = mechanism.edited(|parts| {
        for leg in &mut parts.legs {
            for p in &mut leg.params {
                p.identified =
                    set.factors.contains(&p.name) || p.derived.as_ref().is_some_and(&uses_factor);
            }
        }
        if let Some(instrument) = parts.instrument.as_mut() {
            for p in &mut instrument.parameters {
                p.identified = set.factors.contains(&p.name);
            }
        }
    });
    let problem = set_problem(&inner, data)?;
    let names = problem.names();
    let derived_of = |name: &str| {
        inner
            .legs
            .iter()
            .flat_map(|l| &l.params)
            .find(|p| p.name == name)
            .and_then(|p| p.derived.clone())
    };
    // A parameter named by the set is its own factor; any other unknown follows the set's
    // quantities (the model's checks refuse a set naming a parameter and its quantity).
    let sources = names
        .iter()
        .map(|name| match set.factors.iter().position(|f| f == name) {
            Some(k) => Source::Factor(k),
            None => Source::Derived(derived_of(name).expect("a moved parameter is derived")),
        })
        .collect();
    let unknowns = Unknowns {
        sources,
        quantities: mechanism.quantities.iter().map(|q| q.nominal).collect(),
        factor_of_quantity: mechanism
            .quantities
            .iter()
            .map(|q| set.factors.iter().position(|f| f == &q.name))
            .collect(),
    };
    let factors = set_factors(&inner, set);
    let theta0 = DVector::from_iterator(factors.len(), factors.iter().map(|f| f.nominal));
    let noise = FitOptions::default().expected_noise(&inner);
    let priors: Vec<FactorPrior> = factors
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            f.prior.map(|sigma| FactorPrior {
                factor: k,
                mean: f.nominal,
                sigma,
            })
        })
        .collect();
    if let (Some(first), None) = (factors.iter().find(|f| f.prior.is_some()), &noise) {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: format!("prior of `{}`", first.name),
            message: format!(
                "factor set `{}`: a prior is weighed against the data by the declared noise, \
                 and the model declares none (`noise:`)",
                set.name
            ),
        });
    }
    let solver_error = |e: argmin::core::Error| {
        Error::Invalid(format!("factor set `{}`: the solver failed: {e}", set.name))
    };
    let block =
        |e: super::problem::BlockError| Error::Invalid(format!("factor set `{}`: {e}", set.name));
    let weights_at = |theta: &DVector<f64>| -> Result<Option<Vec<f64>>> {
        let Some(noise) = &noise else { return Ok(None) };
        let x = unknowns.x(theta);
        // Through an instrument every row's variance (a height, a distance, a pose); at
        // measured poses each reading's.
        let variances = match problem.instrument() {
            Some(_) => problem
                .row_variances(&x, noise)
                .map_err(|e| Error::Invalid(format!("factor set `{}`: {e}", set.name)))?,
            None => super::statistics::row_variances(&problem, &x, noise).map_err(block)?,
        };
        Ok(super::fit::inverse(&variances))
    };
    let mut weights = weights_at(&theta0)?;
    let weighted = |w: &Option<Vec<f64>>| match w {
        Some(w) => problem.clone().with_weights(w),
        None => problem.unweighted(),
    };
    let mut current = weighted(&weights);
    let mut theta = theta0;
    let mut weightings = 0;
    for _ in 0..MAX_WEIGHTINGS {
        weightings += 1;
        let view = InFactors {
            problem: &current,
            unknowns: &unknowns,
            priors: &priors,
        };
        theta = solve(&view, theta, SolverKind::LevenbergMarquardt)
            .map_err(solver_error)?
            .x;
        let next = weights_at(&theta)?;
        let change = match (&next, &weights) {
            (Some(a), Some(b)) => a
                .iter()
                .zip(b)
                .map(|(a, b)| (a / b - 1.0).abs())
                .fold(0.0, f64::max),
            _ => 0.0,
        };
        weights = next;
        current = weighted(&weights);
        if change <= WEIGHT_TOLERANCE {
            break;
        }
    }
    let x = unknowns.x(&theta);
    let g = unknowns.jacobian(&theta);
    let raw = problem.residuals(&x).map_err(block)?;
    let (weighted_r, data_c) = current.residuals_and_jacobian(&x).map_err(block)?;
    let data_c = data_c * &g;
    let view = InFactors {
        problem: &current,
        unknowns: &unknowns,
        priors: &priors,
    };
    let c = view.with_prior_jacobian(data_c.clone());
    let factor_names: Vec<String> = set.factors.clone();
    let observability = analyse(&c, &factor_names);
    let rows = raw.len();
    let full_rank = observability.rank == factors.len();
    let resting_on_prior = match priors.is_empty() {
        true => Vec::new(),
        false => analyse(&data_c, &factor_names).null_directions,
    };
    // σ and χ² need every row weighted by its declared variance (none zero).
    let covariance = match (full_rank, &weights) {
        (true, Some(_)) => (c.transpose() * &c).try_inverse(),
        _ => None,
    };
    // Each data row's leverage (with priors, in the fit with their rows).
    let data_leverages: Vec<f64> = leverages(&c).into_iter().take(rows).collect();
    let effective_factors = match priors.is_empty() {
        true => observability.rank as f64,
        false => data_leverages.iter().sum(),
    };
    let factors = factors
        .into_iter()
        .enumerate()
        .map(|(k, f)| FactorEstimate {
            estimate: theta[k],
            sigma: covariance
                .as_ref()
                .map_or(f64::NAN, |cov| cov[(k, k)].max(0.0).sqrt()),
            ..f
        })
        .collect();
    let predicted = covariance.as_ref().and_then(|cov| {
        let params: Vec<Vec<f64>> = inner
            .legs
            .iter()
            .enumerate()
            .map(|(l, _)| problem_leg_parameters(&problem, l, &x))
            .collect();
        let shared = problem.shared_values(&x);
        let named: Vec<(&str, f64)> = names
            .iter()
            .map(|n| n.as_str())
            .zip(x.iter().copied())
            .collect();
        let covariance = &g * cov * g.transpose();
        match inner.instrument {
            Some(_) => predicted_position_of(&inner, (&params, &shared), &named, &covariance),
            None => predicted_pose_sigma(&inner, &params, &covariance),
        }
    });
    let leave_one_out = full_rank
        .then(|| leave_one_out_rms(raw.as_slice(), &data_leverages))
        .flatten();
    let chi_square = match weights {
        Some(_) => weighted_r.norm_squared(),
        None => f64::NAN,
    };
    Ok(FactorSetFit {
        leave_one_out,
        weightings,
        effective_factors,
        resting_on_prior,
        information: chi_square + 2.0 * effective_factors,
        information_corrected: corrected_information(chi_square, effective_factors, rows),
        name: set.name.clone(),
        note: set.note.clone(),
        factors,
        rows,
        // With priors, the rows less the effective factors (rounded).
        degrees_of_freedom: rows.saturating_sub(effective_factors.round() as usize),
        rms: (raw.norm_squared() / rows.max(1) as f64).sqrt(),
        chi_square,
        observability,
        predicted,
    })
}

/// AICc: `χ² + 2k + 2k(k + 1)/(n − k − 1)`, infinite for `n ≤ k + 1` (`k` may be an
/// effective number of factors, [`FactorSetFit::effective_factors`]).
pub fn corrected_information(chi_square: f64, k: f64, n: usize) -> f64 {
    let n = n as f64;
    let room = n - k - 1.0;
    match room > 0.0 {
        true => chi_square + 2.0 * k + 2.0 * k * (k + 1.0) / room,
        false => chi_square + f64::INFINITY,
    }
}

/// Largest leverage at which a row still has a leave-one-out prediction.
const MAX_LEVERAGE: f64 = 1.0 - 1e-9;

/// RMS of `r_i / (1 − h_ii)`; `None` when a leverage reaches [`MAX_LEVERAGE`] or no row.
fn leave_one_out_rms(residuals: &[f64], leverages: &[f64]) -> Option<f64> {
    if residuals.is_empty() || leverages.iter().any(|h| h.is_nan() || *h >= MAX_LEVERAGE) {
        return None;
    }
    let sum: f64 = residuals
        .iter()
        .zip(leverages)
        .map(|(r, h)| (r / (1.0 - h)).powi(2))
        .sum();
    Some((sum / residuals.len() as f64).sqrt())
}

/// Every factor of `set` at its nominal value, named and with its unit.
fn set_factors(mechanism: &Mechanism, set: &FactorSet) -> Vec<FactorEstimate> {
    set.factors
        .iter()
        .map(|name| {
            let quantity = mechanism.quantities.iter().find(|q| &q.name == name);
            let parameter = mechanism
                .legs
                .iter()
                .flat_map(|l| &l.params)
                .find(|p| &p.name == name);
            let shared = mechanism
                .instrument
                .as_ref()
                .and_then(|i| i.parameters.iter().find(|p| &p.name == name));
            let (nominal, unit, prior) = match (quantity, parameter, shared) {
                (Some(q), _, _) => (q.nominal, q.unit, q.prior),
                (_, Some(p), _) => (p.nominal, p.unit, p.prior),
                (_, _, Some(s)) => (s.nominal, s.unit, None),
                _ => unreachable!("the model's factor sets name what it has"),
            };
            FactorEstimate {
                name: name.clone(),
                nominal,
                estimate: nominal,
                sigma: f64::NAN,
                unit,
                prior,
            }
        })
        .collect()
}

/// Leg `leg`'s whole parameter vector at the unknowns `x` (nominal where `problem` does not
/// identify it).
fn problem_leg_parameters(
    problem: &IdentificationProblem<'_>,
    leg: usize,
    x: &DVector<f64>,
) -> Vec<f64> {
    match problem.slots().iter().find(|s| s.leg == leg) {
        Some(slot) => problem.leg_parameters(slot, x),
        None => problem.mechanism().legs[leg].nominal(),
    }
}

/// The problem of every leg and the instrument on `data` (measured poses: every leg's rows).
fn set_problem<'m>(
    mechanism: &'m Mechanism,
    data: &Measurements,
) -> Result<IdentificationProblem<'m>> {
    match data {
        Measurements::Targets(observations) => {
            IdentificationProblem::through_instrument(mechanism, observations)
        }
        Measurements::Readings(set) => {
            if mechanism.instrument.is_some() {
                return Err(Measurements::poses_for_an_instrument(mechanism));
            }
            let legs = mechanism.identified_legs();
            let blocks = legs.iter().flat_map(|&l| set.leg_blocks(l)).collect();
            Ok(IdentificationProblem::new(mechanism, &legs, blocks))
        }
    }
}

/// The model's own set (`model`: every parameter it identifies, legs in model order, then the
/// instrument's) and the sets of its `factor_sets:`, in file order.
pub fn model_sets(mechanism: &Mechanism) -> Vec<FactorSet> {
    let legs = mechanism.legs.iter().flat_map(|l| &l.params);
    let shared = mechanism.instrument.iter().flat_map(|i| &i.parameters);
    let own: Vec<String> = legs
        .filter(|p| p.identified)
        .map(|p| p.name.clone())
        .chain(shared.filter(|p| p.identified).map(|p| p.name.clone()))
        .collect();
    let mut sets = vec![FactorSet {
        name: "model".to_string(),
        factors: own,
        note: Some("the model's own identified parameters".to_string()),
    }];
    sets.extend(mechanism.factor_sets.iter().cloned());
    sets
}

#[cfg(test)]
mod tests {
    use super::{corrected_information, leave_one_out_rms};

    /// AICc at known numbers (χ² 10, k 3, n 10: 10 + 6 + 24/6 = 20); with rows too few to judge
    /// the set (n ≤ k + 1) it is +∞ whatever χ², never −∞ or NaN (which would make the
    /// unjudgeable set the best); an effective k need not be whole.
    #[test]
    fn the_corrected_criterion_is_infinite_without_room() {
        assert!((corrected_information(10.0, 3.0, 10) - 20.0).abs() < 1e-12);
        let half = corrected_information(4.0, 2.5, 7);
        assert!((half - (4.0 + 5.0 + 2.0 * 2.5 * 3.5 / 3.5)).abs() < 1e-12);
        for (k, n) in [(6.0, 7), (6.0, 6), (6.5, 7)] {
            let v = corrected_information(1.0, k, n);
            assert!(v.is_infinite() && v > 0.0, "k {k}, n {n}: {v}");
        }
    }

    /// A mean fitted to 0, 1, 2, 5: residuals −2, −1, 0, 3, each leverage 1/4, so each row
    /// left out is predicted with error r·4/3; the RMS of those against the formula. A leverage
    /// of 1 leaves no prediction.
    #[test]
    fn leave_one_out_errors_are_residuals_over_the_room_left() {
        let rms = leave_one_out_rms(&[-2.0, -1.0, 0.0, 3.0], &[0.25; 4]).unwrap();
        // Refitting without row i gives the mean of the others: its distance to row i.
        let values = [0.0, 1.0, 2.0, 5.0];
        let direct: f64 = (0..4)
            .map(|i| {
                let others: f64 = (0..4).filter(|&j| j != i).map(|j| values[j]).sum::<f64>() / 3.0;
                (values[i] - others).powi(2)
            })
            .sum::<f64>()
            / 4.0;
        assert!(
            (rms - direct.sqrt()).abs() < 1e-15,
            "{rms} vs {}",
            direct.sqrt()
        );
        assert_eq!(leave_one_out_rms(&[1.0, 0.0], &[1.0, 0.5]), None);
        assert_eq!(leave_one_out_rms(&[], &[]), None);
    }
}
