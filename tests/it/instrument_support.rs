//! Helpers shared by the instrument tests: the simulation options, the parameter names of an
//! instrument block, zero-noise recovery of a joint estimate, the targets' poses against the
//! simulated truth, an estimate's identified unknowns, and the identification through the
//! instrument by one strategy as the pipeline runs it (with the held-frame test for the joint
//! strategy).
use legwise::error::Result;
use legwise::identify::result::{
    FitOptions, InstrumentEstimate, ParameterEstimate, Strategy, StrategyResult,
};
use legwise::measure::observations::Observations;
use legwise::measure::observe_simulate::ObservedExperiment;
use legwise::measure::simulate::SimulationOptions;
use legwise::measure::targets::platform_pose;
use legwise::measure::Measurements;
use legwise::model::instrument::Instrument;
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;
use legwise::pipeline::identify_one;
use legwise::solver::SolverKind;
use nalgebra::DVector;

/// Identifies the legs and the instrument from `observations` by `strategy` (joint or
/// two-stage) as the pipeline does: Levenberg–Marquardt, the default fit options, and for the
/// joint strategy the held-frame test.
pub(crate) fn identify_shared(
    mechanism: &Mechanism,
    observations: &Observations,
    strategy: Strategy,
) -> Result<StrategyResult> {
    identify_one(
        mechanism,
        &Measurements::Targets(observations.clone()),
        strategy,
        SolverKind::LevenbergMarquardt,
        FitOptions::default(),
    )
}

/// The default simulation with its noise scaled by `noise_scale` (0: noise-free).
pub(crate) fn simulation(noise_scale: f64) -> SimulationOptions {
    SimulationOptions {
        noise_scale,
        ..Default::default()
    }
}

/// The names of the instrument's parameters, in their order.
pub(crate) fn parameter_names(instrument: &Instrument) -> Vec<&str> {
    instrument
        .parameters
        .iter()
        .map(|p| p.name.as_str())
        .collect()
}

/// Every parameter of `estimate` (legs and instrument) within `tolerance` of the simulation's
/// real value; returns how many of them were identified.
pub(crate) fn assert_recovered(
    mechanism: &Mechanism,
    estimate: &StrategyResult,
    experiment: &ObservedExperiment,
    tolerance: f64,
) -> usize {
    let legs = estimate.legs.iter().flat_map(|leg| {
        let index = mechanism
            .leg_index(&leg.leg)
            .expect("a leg of the mechanism");
        leg.parameters
            .iter()
            .enumerate()
            .map(move |(p, parameter)| (parameter, experiment.real[index][p]))
    });
    let shared = shared(estimate).iter().zip(&experiment.real_shared);
    let mut identified = 0;
    for (parameter, real) in legs.chain(shared.map(|(parameter, &real)| (parameter, real))) {
        assert!(
            (parameter.estimate - real).abs() <= tolerance,
            "{}: {} but real {real}",
            parameter.name,
            parameter.estimate
        );
        identified += usize::from(parameter.identified);
    }
    identified
}

/// The pose fitted to each simulated row's targets at the real instrument is the row's true
/// pose to 1e-12.
pub(crate) fn assert_targets_give_the_true_poses(
    mechanism: &Mechanism,
    experiment: &ObservedExperiment,
) {
    let instrument = mechanism.instrument.as_ref().expect("an instrument");
    for (row, truth) in experiment
        .observations
        .rows
        .iter()
        .zip(experiment.poses.poses())
    {
        let pose = platform_pose::<f64>(
            instrument,
            &experiment.real_shared,
            &row.observed,
            &mechanism.home_pose,
        );
        for c in 0..6 {
            assert!(
                (pose[c] - truth.pose[c]).abs() < 1e-12,
                "{}: {pose:?} vs {:?}",
                mechanism.name,
                truth.pose
            );
        }
    }
}

/// The declared standard deviation of each target coordinate of the instrument, in the
/// measurement file's column order: the noise of the pose coordinate of the same name.
pub(crate) fn target_sigmas(mechanism: &Mechanism, noise: &MeasurementNoise) -> Vec<f64> {
    const POSE: [&str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];
    let instrument = mechanism.instrument.as_ref().expect("an instrument");
    instrument
        .targets
        .iter()
        .flat_map(|t| t.coordinates().iter())
        .map(|c| {
            let index = POSE.iter().position(|p| p == c).expect("a pose coordinate");
            noise.pose[index]
        })
        .collect()
}

/// The estimate's unknowns, in the problem's order.
pub(crate) fn unknowns(estimate: &StrategyResult) -> DVector<f64> {
    let legs = estimate.legs.iter().flat_map(|leg| &leg.parameters);
    let values: Vec<f64> = legs
        .chain(shared(estimate))
        .filter(|p| p.identified)
        .map(|p| p.estimate)
        .collect();
    DVector::from_vec(values)
}

/// The instrument's parameter estimates of a result through the instrument.
pub(crate) fn shared(estimate: &StrategyResult) -> &[ParameterEstimate] {
    &instrument(estimate).parameters
}

/// The instrument's part of a result through the instrument.
pub(crate) fn instrument(estimate: &StrategyResult) -> &InstrumentEstimate {
    estimate
        .instrument
        .as_ref()
        .expect("a result through the instrument")
}
