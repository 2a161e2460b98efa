//! Zero-noise exact recovery of every real parameter, for every bundled model and both solvers.
use legwise::identify::estimate::{identify, Strategy};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::solver::SolverKind;

use crate::support::bundled_models;

/// The bundled models whose held parameters are at their real values: every parameter can be
/// recovered exactly. (models/delta-probe.yaml holds its rods and gains at nominal while the
/// real ones differ: a printer's calibration with a misfit, tested in forward_observations.rs.)
fn exact_models() -> Vec<legwise::model::Mechanism> {
    bundled_models()
        .into_iter()
        .filter(|mech| {
            let experiment = simulate(mech, NOISE_FREE).unwrap();
            mech.legs.iter().zip(&experiment.real).all(|(leg, real)| {
                leg.params
                    .iter()
                    .zip(real)
                    .all(|(p, &value)| p.identified || (value - p.nominal).abs() <= 1e-12)
            })
        })
        .collect()
}

const NOISE_FREE: SimulationOptions = SimulationOptions {
    seed: None,
    noise_scale: 0.0,
    poses_per_leg: None,
};

#[test]
fn both_solvers_recover_every_real_parameter_at_zero_noise() {
    for mech in exact_models() {
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
    for mech in exact_models() {
        let experiment = simulate(&mech, NOISE_FREE).unwrap();
        let path = directory.path().join("measurements.csv");
        file::write(&path, &mech, &experiment.measurements).unwrap();
        let data = file::read(&path, &mech).unwrap();
        assert_eq!(data.len(), experiment.measurements.len());
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

/// Calibrating only some legs: a leg whose parameters are all held fixed gets no poses of its
/// own and is left out of both strategies; the others are still recovered exactly.
#[test]
fn a_leg_with_every_parameter_fixed_is_left_out() {
    use legwise::selection::design::ExperimentDesign;
    let mech = crate::support::bundled("5r.yaml").edited(|parts| {
        for p in &mut parts.legs[1].params {
            p.identified = false;
        }
    });
    let design = ExperimentDesign::select(&mech, None, 18, mech.selection.criterion, true).unwrap();
    assert_eq!(design.legs.len(), 1);
    let sets = design.pose_sets();
    assert_eq!(
        (
            sets.per_leg[0].len(),
            sets.per_leg[1].len(),
            sets.shared.len()
        ),
        (18, 0, 18)
    );
    let experiment = legwise::measure::simulate::simulate_at(&mech, &sets, NOISE_FREE).unwrap();
    for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
        let result = identify(
            &mech,
            &experiment.measurements,
            strategy,
            SolverKind::GaussNewton,
        )
        .unwrap();
        assert_eq!(result.legs.len(), 1, "{strategy:?}");
        assert_eq!(result.legs[0].leg, "leg1");
        for (p, param) in result.legs[0].parameters.iter().enumerate() {
            assert!(
                (param.estimate - experiment.real[0][p]).abs() <= 1e-9,
                "{}",
                param.name
            );
        }
    }
}
