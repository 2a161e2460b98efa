//! What an identification through the instrument reports besides its estimate, recomputed
//! another way: the RMS residual and the problem's size from the residuals at the estimate, the
//! declared noise deciding the noise test (zeros are no noise, readings or pose alone are one),
//! and each reason `trust_issues` gives, word for word.
use argmin::core::Operator;
use legwise::identify::shared::SharedProblem;
use legwise::identify::shared_estimate::{
    identify_shared, trust_issues, SharedEstimate, SharedStrategy,
};
use legwise::measure::observe_simulate::{simulate_observed, ObservedExperiment};
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;

use crate::instrument_support::{simulation, unknowns};
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
    for strategy in [SharedStrategy::Joint, SharedStrategy::TwoStage] {
        let estimate = identify_shared(&mechanism, observations, strategy).unwrap();
        let problem = SharedProblem::new(&mechanism, observations).unwrap();
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
        assert_eq!(
            (estimate.rows, r.len()),
            (readings, readings),
            "{strategy:?}"
        );
        let rms = (r.norm_squared() / r.len() as f64).sqrt();
        assert!(
            (estimate.rms - rms).abs() <= 1e-12 * rms,
            "{strategy:?}: {} vs {rms}",
            estimate.rms
        );
        // Scattered at the noise level (1e-4 on targets and readings), not zero.
        assert!((1e-6..1e-2).contains(&rms), "{strategy:?}: {rms}");
        if strategy == SharedStrategy::Joint {
            assert_eq!(estimate.unknowns, identified.len());
        }
    }
}

#[test]
fn a_declared_noise_of_zeros_is_no_noise_and_readings_or_pose_alone_are_one() {
    let (mechanism, experiment) = experiment();
    let with = |noise: Option<MeasurementNoise>| {
        let mut m = mechanism.clone();
        m.noise = noise;
        identify_shared(&m, &experiment.observations, SharedStrategy::Joint).unwrap()
    };
    let sigmas = |e: &SharedEstimate| -> Vec<Option<f64>> {
        let legs = e.legs.iter().flat_map(|(_, p)| p);
        legs.chain(&e.shared).map(|p| p.std).collect()
    };
    let none = with(None);
    assert!(none.noise_test.is_none());
    let zeros = with(Some(MeasurementNoise {
        pose: [0.0; 6],
        reading: 0.0,
    }));
    assert!(zeros.noise_test.is_none());
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
        let test = estimate.noise_test.as_ref();
        assert!(test.is_some(), "{what} alone declare a noise");
        assert_ne!(sigmas(estimate), sigmas(&none), "{what} alone");
    }
}

#[test]
fn each_reason_not_to_trust_a_result_is_one_line_naming_the_strategy() {
    let (mechanism, experiment) = experiment();
    let estimate =
        identify_shared(&mechanism, &experiment.observations, SharedStrategy::Joint).unwrap();
    assert_eq!(
        trust_issues(std::slice::from_ref(&estimate)),
        Vec::<String>::new()
    );
    let joint = "joint (legs and instrument, Schur complement)";

    let mut unconverged = estimate.clone();
    unconverged.outcome.converged = false;
    unconverged.outcome.iterations = 17;
    let reason = unconverged.outcome.stop_reason.to_string();
    assert_eq!(
        trust_issues(&[unconverged]),
        [format!(
            "{joint}: the solver did not converge ({reason}) after 17 iterations; the estimate \
             must not be trusted"
        )]
    );

    // A leg's value, a leg's σ, the instrument's value: each named; a missing σ is not.
    let mut not_finite = estimate.clone();
    let leg_name = not_finite.legs[1].1[0].name.clone();
    not_finite.legs[1].1[0].estimate = f64::NAN;
    let sigma_name = not_finite.legs[0].1[2].name.clone();
    not_finite.legs[0].1[2].std = Some(f64::INFINITY);
    not_finite.legs[0].1[3].std = None;
    let shared_name = not_finite.shared[0].name.clone();
    not_finite.shared[0].estimate = f64::NEG_INFINITY;
    assert_eq!(
        trust_issues(&[not_finite]),
        [
            format!("{joint}: {sigma_name} is not a finite number"),
            format!("{joint}: {leg_name} is not a finite number"),
            format!("{joint}: {shared_name} is not a finite number"),
        ]
    );

    // Two results: the reasons of each, in order.
    let mut two_stage = estimate.clone();
    two_stage.strategy = SharedStrategy::TwoStage;
    two_stage.outcome.converged = false;
    let issues = trust_issues(&[estimate, two_stage]);
    assert_eq!(issues.len(), 1, "{issues:?}");
    assert!(
        issues[0].starts_with("two-stage (instrument registered first, then D&C): the solver"),
        "{issues:?}"
    );
}
