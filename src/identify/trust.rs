//! Whether an identification's result can be trusted: the reasons it must not be, one line
//! each. The command line prints them as warnings and exits with status 3.
//!
//! Checked:
//! * every solver run converged (a typed stop reason that is a convergence test);
//! * every number a fit reports (costs, estimates, standard deviations, residual σ̂) is finite.
//!   A non-finite value means the fit or its statistics broke down, whatever the solver said
//!   about its own stopping;
//! * no leg's residuals reject the declared measurement noise (the χ² test of
//!   [`super::statistics`]): wrong units, outliers or a wrong model;
//! * every estimate is one the model itself would accept ([`implausible_estimates`]): the model
//!   loader's plausibility rules ([`Mechanism::refused_value`]), and no farther from its
//!   nominal value than [`PERTURBATION_MULTIPLE`] times the perturbation the model declares
//!   for it.

use super::result::{InstrumentEstimate, LegEstimate, ParameterEstimate, StrategyResult};
use crate::model::params::Unit;
use crate::model::Mechanism;

/// An estimate farther from its nominal value than this many times the model's declared
/// perturbation of the parameter (its standard deviation) is not trusted: a Gaussian draw lies
/// beyond 10 σ with probability 2e-23, so either the measurements do not determine the
/// parameter or the model does not describe the mechanism measured.
pub const PERTURBATION_MULTIPLE: f64 = 10.0;

/// The reasons the results of an identification must not be trusted (empty: nothing found).
/// Each names the strategy, the leg or solver run, and the values.
pub fn trust_issues(results: &[StrategyResult]) -> Vec<String> {
    let mut issues = Vec::new();
    for result in results {
        let strategy = result.strategy.name();
        let mut flagged = Vec::new();
        for leg in &result.legs {
            let values = non_finite(leg);
            if !values.is_empty() {
                issues.push(format!(
                    "{strategy}, leg `{}`: not a finite number: {}",
                    leg.leg,
                    values.join(", ")
                ));
                flagged.push(leg.leg.as_str());
            }
            if let Some(test) = leg.statistics.noise_test.as_ref().filter(|t| t.rejected) {
                issues.push(format!(
                    "{strategy}, leg `{}`: the residuals reject the declared noise (σ̂ {} times \
                     the declared scatter, χ² p = {:.2e}): check the units (degrees vs radians, \
                     millimetres vs metres), the outliers and the model",
                    leg.leg,
                    super::statistics::figure(test.sigma_ratio),
                    test.p_value
                ));
            }
        }
        for run in result.runs.iter().filter(|run| !run.converged) {
            issues.push(format!(
                "{} ({strategy}) did not converge for leg{} {}: {} after {} iterations and {} \
                 residual evaluations; the estimate must not be trusted",
                result.solver.name(),
                if run.legs.len() == 1 { "" } else { "s" },
                run.legs.join(", "),
                run.stop_reason,
                run.iterations,
                run.residual_evaluations
            ));
        }
        for run in &result.runs {
            let covered = run.legs.iter().any(|l| flagged.contains(&l.as_str()));
            if !run.final_cost.is_finite() && !covered {
                issues.push(format!(
                    "{strategy}, {} run on {}: not a finite number: final cost {}",
                    result.solver.name(),
                    run.legs.join(", "),
                    run.final_cost
                ));
            }
        }
        if let Some(instrument) = &result.instrument {
            instrument_issues(&mut issues, strategy, instrument);
        }
    }
    issues
}

/// What speaks against the instrument's part of a result: a non-finite value, residuals that
/// reject the declared noise as a whole, held frame components the measurements disagree with.
fn instrument_issues(issues: &mut Vec<String>, strategy: &str, instrument: &InstrumentEstimate) {
    for p in &instrument.parameters {
        if !(p.estimate.is_finite() && p.std.is_none_or(f64::is_finite)) {
            issues.push(format!("{strategy}: {} is not a finite number", p.name));
        }
    }
    if let Some(test) = instrument.noise_test.as_ref().filter(|t| t.rejected) {
        issues.push(format!(
            "{strategy}: the residuals reject the declared noise (σ̂ {} times the declared \
             scatter, χ² p = {:.2e}): check the instrument frame and targets (are the right \
             ones identified?), the units, the outliers and the model",
            super::statistics::figure(test.sigma_ratio),
            test.p_value
        ));
    }
    if let Some(predicted) = &instrument.predicted_position {
        if let Some(tolerance) = predicted.tolerance.filter(|&t| predicted.max > t) {
            if !instrument.outliers.is_empty() {
                issues.push(format!(
                    "{strategy}: the predicted σ of target `{}`'s position over the workspace \
                     reaches {:.4} mm, above the model's tolerance {:.4} mm, but the residuals \
                     hold {} outlier row(s) (named in the warnings) that inflate it: check \
                     them, or refit without them (--drop-outliers), before judging the design",
                    predicted.target,
                    predicted.max * 1e3,
                    tolerance * 1e3,
                    instrument.outliers.len()
                ));
            } else {
                issues.push(format!(
                    "{strategy}: the predicted σ of target `{}`'s position over the workspace \
                 reaches {:.4} mm (RMS {:.4} mm), above the model's tolerance {:.4} mm: these \
                 observations hardly see the combination {}; a low residual is not a good \
                 calibration here: measure what determines it (distances between rows, \
                 touches at a second height) or hold one of its parameters",
                    predicted.target,
                    predicted.max * 1e3,
                    predicted.rms * 1e3,
                    tolerance * 1e3,
                    instrument.observability.weakest_direction
                ));
            }
        }
    }
    if let Some(test) = instrument.held_frame.as_ref().filter(|t| t.rejected) {
        issues.push(format!(
            "{strategy}: the held instrument frame ({}) disagrees with the measurements: \
             freeing it lowers χ² by {:.1} on {} dof (p = {:.2e}); identify it \
             (`instrument.frame.identify`) or correct the values held",
            test.freed.join(", "),
            test.chi_squared_drop,
            test.degrees_of_freedom,
            test.p_value
        ));
    }
}

/// The estimates of `result` the model would not accept, one line each naming the strategy,
/// the leg (or the instrument), the parameter and why: a value the model loader refuses (the
/// calibrated model would not load), or one farther from its nominal value than
/// [`PERTURBATION_MULTIPLE`] times the model's declared perturbation of it (for a leg's
/// parameter `simulation.perturbation` by its kind, or its distance to `simulation.real` if
/// that is larger; for an instrument's, `instrument.frame.perturbation` or the target's
/// `perturbation`). Held parameters and non-finite values (named by [`trust_issues`]) are
/// skipped.
pub fn implausible_estimates(mechanism: &Mechanism, result: &StrategyResult) -> Vec<String> {
    let strategy = result.strategy.name();
    let mut issues = Vec::new();
    let simulation = mechanism.simulation.as_ref();
    for leg in &result.legs {
        for p in leg.parameters.iter().filter(|p| p.identified) {
            let declared = simulation.and_then(|s| {
                let (length, angle, gain) = s.perturbation?;
                let sigma = match p.unit {
                    Unit::One => gain,
                    Unit::Radian => angle,
                    Unit::Metre => length,
                };
                let real = s.real.get(&p.name).map_or(0.0, |r| (r - p.nominal).abs());
                Some(sigma.max(real))
            });
            let place = format!("{strategy}, leg `{}`", leg.leg);
            issues.extend(implausible(mechanism, &place, p, declared));
        }
    }
    let shared = mechanism.instrument.as_ref().map(|i| &i.parameters);
    if let (Some(estimate), Some(model)) = (&result.instrument, shared) {
        for (p, declared) in estimate.parameters.iter().zip(model) {
            if p.identified {
                let place = format!("{strategy}, instrument");
                issues.extend(implausible(
                    mechanism,
                    &place,
                    p,
                    Some(declared.perturbation),
                ));
            }
        }
    }
    issues
}

/// Why the estimate `p` (of `place`) is implausible, if it is: refused by the loader, or more
/// than [`PERTURBATION_MULTIPLE`] times `declared` (a standard deviation; none when 0) from its
/// nominal value.
fn implausible(
    mechanism: &Mechanism,
    place: &str,
    p: &ParameterEstimate,
    declared: Option<f64>,
) -> Option<String> {
    let value = p.estimate;
    if !value.is_finite() {
        return None;
    }
    // A value with its unit (a gain has none).
    let shown = |v: f64| {
        // Six significant digits, in scientific notation when huge or tiny.
        let v: f64 = format!("{v:.5e}").parse().unwrap_or(v);
        let number = match v.abs() {
            a if a != 0.0 && !(1e-4..1e6).contains(&a) => format!("{v:e}"),
            _ => format!("{v}"),
        };
        match p.unit {
            Unit::One => number,
            unit => format!("{number} {unit}"),
        }
    };
    let name = &p.name;
    let unknown = format!(
        "either the measurements do not determine {name} (a reading that never changes? poses \
         that do not move it?) or the mechanism measured is not the model's (a wrong nominal \
         value, a unit mix-up)"
    );
    if let Some(reason) = mechanism.refused_value(p.unit, p.nominal, value) {
        return Some(format!(
            "{place}: {name} = {}: the model would refuse it ({reason}), and a calibrated model \
             holding it would not load; {unknown}",
            shown(value)
        ));
    }
    let sigma = declared.filter(|&s| s > 0.0)?;
    let distance = (value - p.nominal).abs();
    (distance > PERTURBATION_MULTIPLE * sigma).then(|| {
        format!(
            "{place}: {name} = {} is {} from its nominal value {}, more than \
             {PERTURBATION_MULTIPLE} times the perturbation the model declares for it (σ {}); \
             {unknown}",
            shown(value),
            shown(distance),
            shown(p.nominal),
            shown(sigma)
        )
    })
}

/// The non-finite values of one leg's estimate, as `name value`.
fn non_finite(leg: &LegEstimate) -> Vec<String> {
    let mut values = Vec::new();
    let mut check = |what: String, value: f64| {
        if !value.is_finite() {
            values.push(format!("{what} {value}"));
        }
    };
    check("final cost".into(), leg.final_cost);
    if let Some(sigma) = leg.residual_sigma {
        check("σ̂".into(), sigma);
    }
    for p in leg.parameters.iter().filter(|p| p.identified) {
        check(p.name.clone(), p.estimate);
        if let Some(std) = p.std {
            check(format!("std({})", p.name), std);
        }
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::estimate::{FitOptions, ParameterEstimate, SolverRun, Strategy};
    use crate::identify::observability::Observability;
    use crate::identify::statistics::{LegStatistics, NoiseTest};
    use crate::model::params::Unit;
    use crate::solver::{SolverKind, StopReason};

    fn parameter(
        name: &str,
        estimate: f64,
        std: Option<f64>,
        identified: bool,
    ) -> ParameterEstimate {
        ParameterEstimate {
            name: name.into(),
            unit: Unit::Metre,
            nominal: 1.0,
            estimate,
            std,
            identified,
            degrees_of_freedom: std.map(|_| 10),
            prior: None,
            data_share: None,
        }
    }

    fn result(parameters: Vec<ParameterEstimate>, final_cost: f64) -> StrategyResult {
        let observability = Observability {
            singular_values: vec![1.0],
            scaled_singular_values: vec![1.0],
            rank: 1,
            condition: 1.0,
            indices: [1.0; 5],
            unidentifiable: Vec::new(),
            null_directions: Vec::new(),
            scaled_condition: 1.0,
            weakest_direction: "l1".into(),
            resting_on_prior: Vec::new(),
        };
        StrategyResult {
            strategy: Strategy::DivideAndConquer,
            solver: SolverKind::LevenbergMarquardt,
            legs: vec![LegEstimate {
                leg: "leg1".into(),
                parameters,
                measurements: 10,
                initial_cost: 1.0,
                final_cost,
                residual_sigma: Some(1e-4),
                observability,
                statistics: LegStatistics::default(),
                dropped: Vec::new(),
                warnings: Vec::new(),
                covariance: None,
                residuals: Vec::new(),
            }],
            runs: vec![SolverRun {
                legs: vec!["leg1".into()],
                iterations: 3,
                converged: true,
                stop_reason: StopReason::CostReduction,
                refinement_steps: 0,
                initial_cost: 1.0,
                final_cost,
                residual_evaluations: 4,
                jacobian_evaluations: 3,
                seconds: 0.0,
            }],
            options: FitOptions::default(),
            warnings: Vec::new(),
            instrument: None,
        }
    }

    #[test]
    fn an_estimate_is_implausible_beyond_ten_declared_sigmas_or_the_loader_s_rules() {
        // The 3-RPR declares perturbations of 2 mm, 2 mrad and 0.002 of a gain.
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/3rpr.yaml");
        let mechanism = Mechanism::load(std::path::Path::new(path)).unwrap();
        let judged = |unit: Unit, nominal: f64, estimate: f64, identified: bool| {
            let p = ParameterEstimate {
                unit,
                nominal,
                ..parameter("a1x", estimate, Some(1e-4), identified)
            };
            implausible_estimates(&mechanism, &result(vec![p], 1e-8))
        };
        assert!(judged(Unit::Metre, 0.0, -0.0199, true).is_empty());
        assert_eq!(
            judged(Unit::Metre, 0.0, -0.0201, true),
            [
                "divide and conquer, leg `leg1`: a1x = -0.0201 m is 0.0201 m from its nominal \
                 value 0 m, more than 10 times the perturbation the model declares for it (σ \
                 0.002 m); either the measurements do not determine a1x (a reading that never \
                 changes? poses that do not move it?) or the mechanism measured is not the \
                 model's (a wrong nominal value, a unit mix-up)"
            ]
        );
        assert!(judged(Unit::Metre, 0.0, 0.5, false).is_empty());
        assert!(judged(Unit::One, 1.0, 1.0199, true).is_empty());
        assert_eq!(judged(Unit::One, 1.0, 1.0201, true).len(), 1);
        assert!(judged(Unit::Radian, 0.0, 0.0199, true).is_empty());
        assert_eq!(judged(Unit::Radian, 0.0, 0.0201, true).len(), 1);
        // The loader's rules first, whatever the perturbation.
        let refused = judged(Unit::One, 1.0, 2e6, true);
        assert_eq!(refused.len(), 1);
        assert!(
            refused[0].starts_with(
                "divide and conquer, leg `leg1`: a1x = 2e6: the model would refuse it (2e6 is not \
                 a plausible value;"
            ),
            "{refused:?}"
        );
        // Without a declared perturbation, the loader's rules alone.
        let undeclared = mechanism.edited(|parts| {
            if let Some(simulation) = parts.simulation.as_mut() {
                simulation.perturbation = None;
            }
        });
        let p = ParameterEstimate {
            nominal: 0.0,
            ..parameter("a1x", 0.5, Some(1e-4), true)
        };
        assert!(implausible_estimates(&undeclared, &result(vec![p], 1e-8)).is_empty());
    }

    #[test]
    fn a_finite_result_has_no_issue() {
        let ok = result(vec![parameter("l1", 0.75, Some(1e-4), true)], 1e-8);
        assert!(trust_issues(&[ok]).is_empty());
    }

    #[test]
    fn a_rejected_noise_test_is_named_with_its_figures() {
        let mut bad = result(vec![parameter("l1", 0.75, Some(1e-4), true)], 1e-8);
        let test = NoiseTest {
            chi_squared: 120.0,
            degrees_of_freedom: 12,
            p_value: 1.5e-19,
            sigma_ratio: 120f64.sqrt() / 12f64.sqrt(),
            residual_sigma: 1e-3,
            expected_sigma: 1e-3 / 10f64.sqrt(),
            excluded: 0,
            rejected: true,
        };
        bad.legs[0].statistics.noise_test = Some(test.clone());
        assert_eq!(
            trust_issues(std::slice::from_ref(&bad)),
            [
                "divide and conquer, leg `leg1`: the residuals reject the declared noise (σ̂ 3.162 \
              times the declared scatter, χ² p = 1.50e-19): check the units (degrees vs radians, \
              millimetres vs metres), the outliers and the model"
            ]
        );
        bad.legs[0].statistics.noise_test = Some(NoiseTest {
            rejected: false,
            ..test
        });
        assert!(trust_issues(&[bad]).is_empty());
    }

    #[test]
    fn a_non_finite_cost_is_named_once_for_the_leg() {
        let bad = result(vec![parameter("l1", 0.75, Some(1e-4), true)], f64::NAN);
        assert_eq!(
            trust_issues(&[bad]),
            ["divide and conquer, leg `leg1`: not a finite number: final cost NaN"]
        );
    }

    #[test]
    fn a_run_whose_legs_look_finite_is_named_by_its_cost() {
        let mut bad = result(vec![parameter("l1", 0.75, Some(1e-4), true)], 1e-8);
        bad.runs[0].final_cost = f64::INFINITY;
        assert_eq!(
            trust_issues(&[bad]),
            ["divide and conquer, Levenberg-Marquardt run on leg1: not a finite number: final cost \
              inf"]
        );
    }

    #[test]
    fn non_finite_estimates_and_stds_name_the_parameter_unless_it_is_fixed() {
        let bad = result(
            vec![
                parameter("l1", f64::INFINITY, Some(1e-4), true),
                parameter("L1", 1.1, Some(f64::NAN), true),
                parameter("A1x", f64::NAN, None, false),
            ],
            1e-8,
        );
        assert_eq!(
            trust_issues(&[bad]),
            ["divide and conquer, leg `leg1`: not a finite number: l1 inf, std(L1) NaN"]
        );
    }

    #[test]
    fn a_run_that_did_not_converge_is_named_with_its_reason() {
        let mut bad = result(vec![parameter("l1", 0.75, Some(1e-4), true)], 1e-8);
        bad.runs[0].converged = false;
        bad.runs[0].stop_reason = StopReason::EvaluationBudget;
        let issues = trust_issues(&[bad]);
        assert_eq!(issues.len(), 1);
        assert!(
            issues[0].starts_with(
                "Levenberg-Marquardt (divide and conquer) did not converge for leg leg1: "
            ),
            "{}",
            issues[0]
        );
        assert!(
            issues[0].ends_with(
                "after 3 iterations and 4 residual evaluations; the estimate must not be trusted"
            ),
            "{}",
            issues[0]
        );
    }
}
