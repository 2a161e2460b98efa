//! What an identification through the instrument reports besides its estimate, recomputed
//! another way: the RMS residual and the problem's size from the residuals at the estimate, the
//! declared noise deciding the noise test (zeros are no noise, readings or pose alone are one),
//! and each reason `trust_issues` gives, word for word.
use argmin::core::Operator;
use legwise::identify::problem::IdentificationProblem;
use legwise::identify::result::{Strategy, StrategyResult};
use legwise::identify::trust::trust_issues;
use legwise::measure::observe_simulate::{simulate_observed, ObservedExperiment};
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;

use crate::instrument_support::{identify_shared, instrument, shared, simulation, unknowns};
use crate::support::bundled;

/// The tracker model and a noisy experiment simulated with its declared noise.
fn experiment() -> (Mechanism, ObservedExperiment) {
    let mechanism = bundled("3rpr-tracker.yaml");
    let experiment = simulate_observed(&mechanism, simulation(1.0)).unwrap();
    (mechanism, experiment)
}

#[test]
fn the_rms_and_the_size_are_those_of_the_residuals_at_the_estimate() {
    let (mechanism, experiment) = experiment();
    let observations = &experiment.observations;
    for strategy in [Strategy::Joint, Strategy::TwoStage] {
        let estimate = identify_shared(&mechanism, observations, strategy).unwrap();
        let problem = IdentificationProblem::through_instrument(&mechanism, observations).unwrap();
        let identified = unknowns(&estimate);
        let r = problem.apply(&identified).unwrap();
        // One residual per reading of a leg's rows (its labelled ones, or the shared ones
        // for a leg without labelled rows: the shared rows here are for the legs that have none).
        let readings: usize = mechanism
            .identified_legs()
            .into_iter()
            .map(|leg| observations.indexed_leg_rows(leg).len())
            .sum();
        assert_eq!(readings, 54);
        let whole = instrument(&estimate);
        assert_eq!((whole.rows, r.len()), (readings, readings), "{strategy:?}");
        let rms = (r.norm_squared() / r.len() as f64).sqrt();
        assert!(
            (whole.rms - rms).abs() <= 1e-12 * rms,
            "{strategy:?}: {} vs {rms}",
            whole.rms
        );
        // Scattered at the noise level (1e-4 on targets and readings), not zero.
        assert!((1e-6..1e-2).contains(&rms), "{strategy:?}: {rms}");
        if strategy == Strategy::Joint {
            assert_eq!(whole.unknowns, identified.len());
        }
    }
}

#[test]
fn a_declared_noise_of_zeros_is_no_noise_and_readings_or_pose_alone_are_one() {
    let (mechanism, experiment) = experiment();
    let with = |noise: Option<MeasurementNoise>| {
        let m = mechanism.edited(|m| m.noise = noise);
        identify_shared(&m, &experiment.observations, Strategy::Joint).unwrap()
    };
    let sigmas = |e: &StrategyResult| -> Vec<Option<f64>> {
        let legs = e.legs.iter().flat_map(|leg| &leg.parameters);
        legs.chain(shared(e)).map(|p| p.std).collect()
    };
    let none = with(None);
    assert!(instrument(&none).noise_test.is_none());
    let zeros = with(Some(MeasurementNoise {
        pose: [0.0; 6],
        reading: 0.0,
        scale: 1.0,
    }));
    assert!(instrument(&zeros).noise_test.is_none());
    assert_eq!(sigmas(&zeros), sigmas(&none), "zeros are no noise");
    let declared = mechanism.noise.expect("the tracker declares a noise");
    let readings_only = with(Some(MeasurementNoise {
        pose: [0.0; 6],
        ..declared
    }));
    let pose_only = with(Some(MeasurementNoise {
        reading: 0.0,
        ..declared
    }));
    for (what, estimate) in [("readings", &readings_only), ("pose", &pose_only)] {
        let test = instrument(estimate).noise_test.as_ref();
        assert!(test.is_some(), "{what} alone declare a noise");
        assert_ne!(sigmas(estimate), sigmas(&none), "{what} alone");
    }
}

#[test]
fn each_reason_not_to_trust_a_result_is_one_line_naming_the_strategy() {
    let (mechanism, experiment) = experiment();
    let estimate = identify_shared(&mechanism, &experiment.observations, Strategy::Joint).unwrap();
    assert_eq!(
        trust_issues(std::slice::from_ref(&estimate)),
        Vec::<String>::new()
    );
    let joint = "joint (legs and instrument, Schur complement)";

    // One solver run for every identified leg.
    assert_eq!(estimate.runs.len(), 1);
    assert_eq!(estimate.runs[0].legs, ["leg1", "leg2", "leg3"]);

    let mut unconverged = estimate.clone();
    unconverged.runs[0].converged = false;
    unconverged.runs[0].iterations = 17;
    unconverged.runs[0].residual_evaluations = 23;
    let reason = unconverged.runs[0].stop_reason.to_string();
    assert_eq!(
        trust_issues(&[unconverged]),
        [format!(
            "Levenberg-Marquardt ({joint}) did not converge for legs leg1, leg2, leg3: {reason} \
             after 17 iterations and 23 residual evaluations; the estimate must not be trusted"
        )]
    );

    // A leg's value, a leg's σ, the instrument's value: each named (a leg's with its leg and
    // its value); a missing σ is not, nor a fixed leg parameter (the plain pipeline's rule).
    let mut not_finite = estimate.clone();
    let value = &mut not_finite.legs[1].parameters[1];
    assert!(value.identified, "{value:?}");
    let leg_name = value.name.clone();
    value.estimate = f64::NAN;
    let sigma = &mut not_finite.legs[0].parameters[4];
    assert!(sigma.identified, "{sigma:?}");
    let sigma_name = sigma.name.clone();
    sigma.std = Some(f64::INFINITY);
    not_finite.legs[0].parameters[5].std = None;
    let fixed = &mut not_finite.legs[0].parameters[2];
    assert!(!fixed.identified, "{fixed:?}");
    fixed.estimate = f64::NAN;
    fixed.std = Some(f64::INFINITY);
    let shared_name = shared(&not_finite)[0].name.clone();
    not_finite.instrument.as_mut().unwrap().parameters[0].estimate = f64::NEG_INFINITY;
    assert_eq!(
        trust_issues(&[not_finite]),
        [
            format!("{joint}, leg `leg1`: not a finite number: std({sigma_name}) inf"),
            format!("{joint}, leg `leg2`: not a finite number: {leg_name} NaN"),
            format!("{joint}: {shared_name} is not a finite number"),
        ]
    );

    // Two results: the reasons of each, in order.
    let mut two_stage = estimate.clone();
    two_stage.strategy = Strategy::TwoStage;
    two_stage.runs[0].converged = false;
    let run = two_stage.runs[0].clone();
    let issues = trust_issues(&[estimate, two_stage]);
    assert_eq!(
        issues,
        [format!(
            "Levenberg-Marquardt (two-stage (instrument registered first, then D&C)) did not \
             converge for legs leg1, leg2, leg3: {} after {} iterations and {} residual \
             evaluations; the estimate must not be trusted",
            run.stop_reason, run.iterations, run.residual_evaluations
        )]
    );
}
