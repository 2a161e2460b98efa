//! The dual-number identification Jacobian agrees with central differences on every leg of every
//! bundled model, at seeded poses of the usable workspace.
use legwise::identify::jacobian::reading_gradient;
use legwise::kinematics::inverse::predict_reading;
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
