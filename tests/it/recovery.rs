//! Zero-noise exact recovery of every real parameter, for every bundled model and both solvers.
use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::solver::SolverKind;

use crate::support::bundled_models;

const NOISE_FREE: SimulationOptions = SimulationOptions {
    seed: None,
    noise_scale: 0.0,
    poses_per_leg: None,
};

#[test]
fn both_solvers_recover_every_real_parameter_at_zero_noise() {
    for mech in bundled_models() {
        let experiment = simulate(&mech, NOISE_FREE).unwrap();
        for solver in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
            for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
                let result = identify(&mech, &experiment.measurements, strategy, solver).unwrap();
                for (leg, estimate) in result.legs.iter().enumerate() {
                    for (p, param) in estimate.parameters.iter().enumerate() {
                        let real = experiment.real[leg][p];
                        assert!(
                            (param.estimate - real).abs() <= 1e-9,
                            "{} {solver:?} {strategy:?}: {} = {} but real {real}",
                            mech.name,
                            param.name,
                            param.estimate
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn recovery_also_holds_through_the_measurement_csv() {
    use legwise::measure::file;
    let directory = tempfile::tempdir().unwrap();
    for mech in bundled_models() {
        let experiment = simulate(&mech, NOISE_FREE).unwrap();
        let path = directory.path().join("measurements.csv");
        file::write(&path, &mech, &experiment.measurements).unwrap();
        let data = file::read(&path, &mech).unwrap();
        assert_eq!(data.poses.len(), experiment.measurements.poses.len());
        for solver in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
            let result = identify(&mech, &data, Strategy::DivideAndConquer, solver).unwrap();
            for (leg, estimate) in result.legs.iter().enumerate() {
                for (p, param) in estimate.parameters.iter().enumerate() {
                    let real = experiment.real[leg][p];
                    assert!(
                        (param.estimate - real).abs() <= 1e-9,
                        "{}: {}",
                        param.name,
                        param.estimate
                    );
                }
            }
        }
    }
}
