//! The forward kinematics through the legs' closed-form kernels against the stacked Newton:
//! for every bundled model whose legs all have a kernel (recognised from their chains), with
//! randomly perturbed parameters, the pose reached for the readings of random poses of the
//! workspace equals the generic continuation's ([`forward`]) to 1e-12 of the mechanism's size,
//! whether the configuration is handed back ([`ForwardKinematics::solve_near`]) or not
//! ([`ForwardKinematics::solve_near_pose`]), and the configuration handed back closes every
//! leg at its reading. The first evaluation computed beforehand at the start
//! ([`ForwardKinematics::kernel_rows_at`], shared by a Monte Carlo trial's maps) changes no bit;
//! a planar two-leg mechanism and a translating three-carriage one start from their closed
//! forms instead (no rows to share).
use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::kernel::LegKernel;
use legwise::kinematics::platform::{forward, Configuration, ForwardKinematics};
use legwise::model::Mechanism;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::support::bundled_models;

/// The bundled models the kernel forward kinematics applies to: every leg a kernel, as many
/// measured coordinates as legs.
fn kernel_models() -> Vec<Mechanism> {
    bundled_models()
        .into_iter()
        .filter(|m| m.measured.len() == m.legs.len())
        .filter(|m| m.legs.iter().all(|l| LegKernel::recognise(l).is_some()))
        .collect()
}

/// The nominal parameters, every identified one moved by up to ±`scale` of its size (or of
/// 1e-2 when it is near zero).
fn perturbed(mechanism: &Mechanism, rng: &mut ChaCha8Rng, scale: f64) -> Vec<Vec<f64>> {
    mechanism
        .legs
        .iter()
        .map(|leg| {
            leg.params
                .iter()
                .map(|p| {
                    let size = p.nominal.abs().max(1e-2);
                    let moved = p.nominal + scale * size * rng.random_range(-1.0..1.0);
                    if p.identified {
                        moved
                    } else {
                        p.nominal
                    }
                })
                .collect()
        })
        .collect()
}

#[test]
fn the_kernel_forward_kinematics_equals_the_stacked_newton() {
    let models = kernel_models();
    assert!(!models.is_empty(), "a bundled model with kernel legs");
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let mut compared = 0;
    for mechanism in &models {
        let home = mechanism.home_pose;
        for _ in 0..20 {
            let real = perturbed(mechanism, &mut rng, 2e-3);
            let kinematics = ForwardKinematics::new(mechanism, &real);
            let size = home[..3].iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
            for _ in 0..25 {
                // A pose of the region about home, and a start near it (an accuracy map's).
                let mut pose = home;
                for &c in &mechanism.measured {
                    pose[c] += 0.3 * rng.random_range(-1.0..1.0);
                }
                if !mechanism.workspace.contains(&pose) {
                    continue;
                }
                let readings: Option<Vec<f64>> = mechanism
                    .legs
                    .iter()
                    .zip(&real)
                    .map(|(leg, phi)| predict_reading(leg, phi, &pose, &home).ok())
                    .collect();
                let Some(readings) = readings else { continue };
                let Ok(reference) = forward(mechanism, &real, &readings) else {
                    continue;
                };
                let mut start = Configuration::home(mechanism);
                start.pose = pose;
                for &c in &mechanism.measured {
                    start.pose[c] += 1e-3 * rng.random_range(-1.0..1.0);
                }
                let lean = kinematics.solve_near_pose(&readings, &start).expect("lean");
                // With the first evaluation computed beforehand at the start: the same pose,
                // bit for bit; computed at another pose, it is not taken for this start's.
                // (None where the solve starts from a closed form: two legs on circles, the
                // planar position measured; three carriage legs on spheres, the position
                // measured.)
                let carriages = mechanism
                    .legs
                    .iter()
                    .all(|leg| matches!(LegKernel::recognise(leg), Some(LegKernel::Carriage(_))));
                let closed_form = (mechanism.legs.len() == 2 && mechanism.measured == [0, 1])
                    || (mechanism.legs.len() == 3 && mechanism.measured == [0, 1, 2] && carriages);
                match kinematics.kernel_rows_at(&start.pose) {
                    Some(first) => {
                        assert!(
                            !closed_form,
                            "{}: rows for a closed-form start",
                            mechanism.name
                        );
                        let shared =
                            kinematics.solve_near_pose_from(&readings, &start, Some(&first));
                        assert_eq!(
                            shared.map(|p| p.map(f64::to_bits)),
                            Ok(lean.map(f64::to_bits))
                        );
                        let elsewhere = kinematics.kernel_rows_at(&home).expect("kernel legs");
                        let ignored =
                            kinematics.solve_near_pose_from(&readings, &start, Some(&elsewhere));
                        assert_eq!(
                            ignored.map(|p| p.map(f64::to_bits)),
                            Ok(lean.map(f64::to_bits))
                        );
                    }
                    None => assert!(closed_form, "{}: no kernel rows", mechanism.name),
                }
                let mut configuration = start.clone();
                let full = kinematics
                    .solve_near(&readings, &mut configuration)
                    .expect("full");
                for c in 0..6 {
                    for (what, value) in [("lean", lean[c]), ("full", full[c])] {
                        assert!(
                            (value - reference[c]).abs() <= 1e-12 * size,
                            "{}: {what} {value} vs {} (coordinate {c})",
                            mechanism.name,
                            reference[c]
                        );
                    }
                    assert!(
                        (pose[c] - reference[c]).abs() <= 1e-9 * size,
                        "the real pose"
                    );
                }
                // The configuration handed back closes every leg at the readings.
                for (l, leg) in mechanism.legs.iter().enumerate() {
                    let geometry = leg.geometry(&real[l]);
                    let actuated = configuration.joints[l][leg.actuated];
                    let reading = (actuated - geometry.offset) / geometry.gain;
                    assert!(
                        (reading - readings[l]).abs() <= 1e-12,
                        "{reading} {readings:?}"
                    );
                }
                compared += 1;
            }
        }
    }
    assert!(compared >= 100, "only {compared} poses compared");
}
