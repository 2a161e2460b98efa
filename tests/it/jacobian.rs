//! The dual-number identification Jacobian, and the reading's gradient with respect to the
//! measured pose, agree with central differences on every leg of every bundled model, at
//! seeded poses of the usable workspace.
use legwise::identify::jacobian::{reading_gradient, PreparedLeg};
use legwise::kinematics::inverse::{predict_reading, solve_leg};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::support::bundled_models;

#[test]
fn dual_jacobian_matches_central_differences_on_every_leg() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for mech in bundled_models() {
        let home = mech.home_pose;
        let mut checked = 0;
        while checked < 20 {
            let pose = mech.workspace.sample(&home, &mut rng).unwrap();
            for leg in &mech.legs {
                let phi = leg.nominal();
                let columns: Vec<usize> = (0..phi.len()).collect();
                // Every leg reaches every pose of the usable workspace.
                let (value, gradient) = reading_gradient(leg, &phi, &columns, &pose, &home)
                    .unwrap_or_else(|e| panic!("{} at {pose:?}: {e}", leg.name));
                let base = predict_reading(leg, &phi, &pose, &home).unwrap();
                assert!((value - base).abs() < 1e-12, "value of the dual pass");
                for (j, g) in gradient.iter().enumerate() {
                    let h = 1e-6 * (1.0 + phi[j].abs());
                    let mut plus = phi.clone();
                    let mut minus = phi.clone();
                    plus[j] += h;
                    minus[j] -= h;
                    let difference = (predict_reading(leg, &plus, &pose, &home).unwrap()
                        - predict_reading(leg, &minus, &pose, &home).unwrap())
                        / (2.0 * h);
                    let scale = g.abs().max(difference.abs()).max(1e-3);
                    assert!(
                        (g - difference).abs() <= 1e-6 * scale,
                        "{} {} ∂ψ/∂{}: dual {g} vs central difference {difference} at {pose:?}",
                        mech.name,
                        leg.name,
                        leg.params[j].name
                    );
                }
            }
            checked += 1;
        }
    }
}

/// `∂ψ/∂P` (the pose noise's way into a residual's expected variance): central differences of
/// the predicted reading over each measured pose coordinate, sign included, and zero for the
/// coordinates the instrument does not measure.
#[test]
fn the_pose_gradient_matches_central_differences_on_every_leg() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for mech in bundled_models() {
        let home = mech.home_pose;
        for _ in 0..5 {
            let pose = mech.workspace.sample(&home, &mut rng).unwrap();
            for leg in &mech.legs {
                let phi = leg.nominal();
                let prepared = PreparedLeg::new(leg, &phi, &[]);
                let solution = prepared.solve_warm(&pose, &home, None).unwrap();
                let gradient = prepared.pose_gradient_of(&pose, &solution, &mech.measured);
                for (c, &g) in gradient.iter().enumerate() {
                    if !mech.measured.contains(&c) {
                        assert_eq!(
                            g.to_bits(),
                            0.0_f64.to_bits(),
                            "{}: coordinate {c}",
                            leg.name
                        );
                        continue;
                    }
                    let h = 1e-6;
                    let (mut plus, mut minus) = (pose, pose);
                    plus[c] += h;
                    minus[c] -= h;
                    let difference = (predict_reading(leg, &phi, &plus, &home).unwrap()
                        - predict_reading(leg, &phi, &minus, &home).unwrap())
                        / (2.0 * h);
                    assert!(
                        (g - difference).abs() <= 1e-6 * g.abs().max(difference.abs()).max(1e-3),
                        "{} ∂ψ/∂P[{c}]: {g} vs central difference {difference}",
                        leg.name
                    );
                }
                assert!(gradient.iter().any(|g| g.abs() > 1e-3), "{}", leg.name);
            }
        }
    }
}

/// At a pose solved beforehand (`LegSolution`, as the workspace's candidates are), the reading
/// and gradient are the predicted reading and the dual gradient, with derivative columns or
/// without any (the reading then comes from the closure error alone).
#[test]
fn the_reading_at_a_solved_pose_is_the_predicted_reading() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for mech in bundled_models() {
        let home = mech.home_pose;
        for _ in 0..5 {
            let pose = mech.workspace.sample(&home, &mut rng).unwrap();
            for leg in &mech.legs {
                let phi: Vec<f64> = leg.nominal().iter().map(|v| v * (1.0 + 1e-3)).collect();
                let solved = solve_leg(leg, &leg.geometry(&phi), &pose, &home).unwrap();
                let expected = predict_reading(leg, &phi, &pose, &home).unwrap();
                let columns: Vec<usize> = (0..phi.len()).collect();
                let (_, reference) = reading_gradient(leg, &phi, &columns, &pose, &home).unwrap();
                let mut gradient = vec![f64::NAN; columns.len()];
                let with = PreparedLeg::new(leg, &phi, &columns).reading_and_gradient_at(
                    &pose,
                    &solved,
                    &mut gradient,
                );
                let without = PreparedLeg::new(leg, &phi, &[]).reading_and_gradient_at(
                    &pose,
                    &solved,
                    &mut [],
                );
                for value in [with, without] {
                    assert!(
                        (value - expected).abs() <= 1e-12 * (1.0 + expected.abs()),
                        "{}: {value} vs {expected}",
                        leg.name
                    );
                }
                for (g, r) in gradient.iter().zip(&reference) {
                    assert!(
                        (g - r).abs() <= 1e-12 * (1.0 + r.abs()),
                        "{}: {g} vs {r}",
                        leg.name
                    );
                }
            }
        }
    }
}
