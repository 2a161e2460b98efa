//! A robust fit minimises Σ ρ(u_i²) with u_i = r_i/σ_i, so at its estimate the weighted normal
//! equations Σ_i w_i r_i ∂r_i/∂θ_j = 0 hold with w_i = ρ'(u_i²)/σ_i² taken at that same
//! estimate. Checked here on the 5R data with one gross outlier, for Huber and Cauchy, with
//! everything rebuilt outside the fit: the residuals by the f64 inverse kinematics, their
//! parameter derivatives and pose gradients by central differences, σ_i² = σ_q² + Σ_c
//! (∂ψ/∂P_c · σ_c)² at the least-squares estimate (where the fit takes its scale), and the
//! weights from the losses' formulas (Huber min(1, c/|u|) with c = 1.345, Cauchy
//! 1/(1 + (u/c)²) with c = 2.3849).
use legwise::identify::estimate::{identify, identify_with, FitOptions, Strategy};
use legwise::identify::robust::RobustLoss;
use legwise::kinematics::inverse::predict_reading;
use legwise::measure::file::read;
use legwise::solver::SolverKind;

use crate::support::{bundled, crate_path};

fn weight(loss: RobustLoss, u: f64) -> f64 {
    match loss {
        RobustLoss::Huber => {
            let c = 1.345;
            if u.abs() <= c {
                1.0
            } else {
                c / u.abs()
            }
        }
        RobustLoss::Cauchy => 1.0 / (1.0 + (u / 2.3849) * (u / 2.3849)),
    }
}

#[test]
fn robust_estimates_solve_their_weighted_normal_equations() {
    let mechanism = bundled("5r.yaml");
    let data = read(&crate_path("tests/data/stats_5r_outlier.csv"), &mechanism).unwrap();
    let noise = mechanism.noise.expect("declared noise");
    let home = mechanism.home_pose;
    let plain = identify(
        &mechanism,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
    )
    .unwrap();
    for loss in [RobustLoss::Huber, RobustLoss::Cauchy] {
        let robust = identify_with(
            &mechanism,
            &data,
            Strategy::DivideAndConquer,
            SolverKind::LevenbergMarquardt,
            FitOptions {
                robust: Some(loss),
                ..Default::default()
            },
        )
        .unwrap();
        for (l, (fitted, least_squares)) in robust.legs.iter().zip(&plain.legs).enumerate() {
            let model = &mechanism.legs[l];
            let phi_ls: Vec<f64> = least_squares
                .parameters
                .iter()
                .map(|p| p.estimate)
                .collect();
            let phi: Vec<f64> = fitted.parameters.iter().map(|p| p.estimate).collect();
            let columns = model.identified();
            let mut gradient = vec![0.0; columns.len()];
            let mut scale = vec![0.0; columns.len()];
            let mut downweighted = 0;
            for block in data.leg_blocks(l) {
                let reading = |phi: &[f64], pose: &[f64; 6]| {
                    predict_reading(model, phi, pose, &home).expect("reachable")
                };
                let mut variance = noise.reading.powi(2);
                for &c in &mechanism.measured {
                    let h = 1e-6;
                    let (mut up, mut down) = (block.pose, block.pose);
                    up[c] += h;
                    down[c] -= h;
                    let derivative = (reading(&phi_ls, &up) - reading(&phi_ls, &down)) / (2.0 * h);
                    variance += (derivative * noise.pose[c]).powi(2);
                }
                let r = reading(&phi, &block.pose) - block.reading;
                let w = weight(loss, r / variance.sqrt()) / variance;
                if w * variance < 0.5 {
                    downweighted += 1;
                }
                for (k, &j) in columns.iter().enumerate() {
                    let h = 1e-7 * (1.0 + phi[j].abs());
                    let (mut up, mut down) = (phi.clone(), phi.clone());
                    up[j] += h;
                    down[j] -= h;
                    let derivative =
                        (reading(&up, &block.pose) - reading(&down, &block.pose)) / (2.0 * h);
                    gradient[k] += w * r * derivative;
                    scale[k] += (w * r * derivative).abs();
                }
            }
            for (k, &j) in columns.iter().enumerate() {
                assert!(
                    gradient[k].abs() <= 1e-5 * scale[k],
                    "{loss:?} {}: Σ w r ∂r/∂{} = {:e} (scale {:e})",
                    model.name,
                    model.params[j].name,
                    gradient[k],
                    scale[k]
                );
            }
            // The outlier (leg1, line 6, 1000σ) is the one row the loss all but ignores.
            let expected = usize::from(l == 0);
            assert_eq!(downweighted, expected, "{loss:?} {}", model.name);
        }
    }
}
