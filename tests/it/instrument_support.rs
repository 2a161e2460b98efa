//! Helpers shared by the instrument tests: the simulation options, the parameter names of an
//! instrument block, zero-noise recovery of a joint estimate, the targets' poses against the
//! simulated truth, and an estimate's identified unknowns.
use legwise::identify::shared_estimate::SharedEstimate;
use legwise::measure::observe_simulate::ObservedExperiment;
use legwise::measure::simulate::SimulationOptions;
use legwise::measure::targets::platform_pose;
use legwise::model::instrument::Instrument;
use legwise::model::mechanism::MeasurementNoise;
use legwise::model::Mechanism;
use nalgebra::DVector;

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
    estimate: &SharedEstimate,
    experiment: &ObservedExperiment,
    tolerance: f64,
) -> usize {
    let legs = estimate.legs.iter().flat_map(|(leg, parameters)| {
        parameters
            .iter()
            .enumerate()
            .map(|(p, parameter)| (parameter, experiment.real[*leg][p]))
    });
    let shared = estimate.shared.iter().zip(&experiment.real_shared);
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
pub(crate) fn unknowns(estimate: &SharedEstimate) -> DVector<f64> {
    let legs = estimate.legs.iter().flat_map(|(_, p)| p);
    let values: Vec<f64> = legs
        .chain(&estimate.shared)
        .filter(|p| p.identified)
        .map(|p| p.estimate)
        .collect();
    DVector::from_vec(values)
}
