//! The forward kinematics through the prismatic legs' kernels (the 3-RPR's and the hexapod's
//! distance legs, the delta's carriage legs) against the stacked Newton ([`forward`]: every
//! leg's joints and the pose together, continued from home), on random geometries: every
//! identified parameter of the bundled model moved by up to 1 % of its size (or 1e-4 when
//! it is near zero), random poses of the workspace. Started at home (not near the answer), the
//! kernel's pose equals the stacked Newton's to 1e-12 of the mechanism's size, with or without
//! the configuration handed back, in the same assembly mode (both succeed); where the stacked
//! Newton refuses the readings, so does the kernel path. Seeds 1–3.
use legwise::kinematics::inverse::predict_reading;
use legwise::kinematics::kernel::LegKernel;
use legwise::kinematics::platform::{forward, Configuration, ForwardKinematics};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::support::bundled;

#[test]
fn the_prismatic_kernels_forward_kinematics_equals_the_stacked_newton() {
    for model in ["delta.yaml", "hexapod.yaml", "3rpr.yaml"] {
        let mechanism = bundled(model);
        assert!(
            mechanism
                .legs
                .iter()
                .all(|l| LegKernel::recognise(l).is_some()),
            "{model}: every leg a kernel"
        );
        let home = mechanism.home_pose;
        let size = home[..3].iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
        let (mut compared, mut refused) = (0, 0);
        for seed in 1..=3u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            for _ in 0..10 {
                let params: Vec<Vec<f64>> = mechanism
                    .legs
                    .iter()
                    .map(|leg| {
                        leg.params
                            .iter()
                            .map(|p| {
                                let size = p.nominal.abs().max(1e-2);
                                let moved = p.nominal + 1e-2 * size * rng.random_range(-1.0..1.0);
                                if p.identified {
                                    moved
                                } else {
                                    p.nominal
                                }
                            })
                            .collect()
                    })
                    .collect();
                let kinematics = ForwardKinematics::new(&mechanism, &params);
                for _ in 0..10 {
                    let mut pose = home;
                    for &c in &mechanism.measured {
                        let spread = if c < 3 { 0.05 } else { 0.15 };
                        pose[c] += spread * rng.random_range(-1.0..1.0);
                    }
                    if !mechanism.workspace.contains(&pose) {
                        continue;
                    }
                    let readings: Option<Vec<f64>> = mechanism
                        .legs
                        .iter()
                        .zip(&params)
                        .map(|(leg, phi)| predict_reading(leg, phi, &pose, &home).ok())
                        .collect();
                    let Some(readings) = readings else { continue };
                    let reference = forward(&mechanism, &params, &readings);
                    let mut start = Configuration::home(&mechanism);
                    let full = kinematics.solve_near(&readings, &mut start);
                    let lean =
                        kinematics.solve_near_pose(&readings, &Configuration::home(&mechanism));
                    let Ok(reference) = reference else {
                        assert!(full.is_err() && lean.is_err(), "{model}: refused alike");
                        refused += 1;
                        continue;
                    };
                    let (full, lean) = (full.expect("full"), lean.expect("lean"));
                    for c in 0..6 {
                        for (what, value) in [("full", full[c]), ("lean", lean[c])] {
                            assert!(
                                (value - reference[c]).abs() <= 1e-12 * size,
                                "{model}: {what} {value} vs {} (coordinate {c})",
                                reference[c]
                            );
                        }
                    }
                    // The configuration handed back closes every leg at its reading.
                    for (l, leg) in mechanism.legs.iter().enumerate() {
                        let geometry = leg.geometry(&params[l]);
                        let actuated = start.joints[l][leg.actuated];
                        let reading = (actuated - geometry.offset) / geometry.gain;
                        assert!((reading - readings[l]).abs() <= 1e-12, "{model}: leg {l}");
                    }
                    compared += 1;
                }
            }
        }
        assert!(
            compared >= 100,
            "{model}: only {compared} poses compared ({refused} refused)"
        );
    }
}
