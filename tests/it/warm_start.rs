//! The fast identification path gives what the plain one gives: inverse kinematics warm-started
//! from the previous solution equals the from-home solve (also when the warm start would jump
//! working mode), the one-pass vector-dual gradient equals one single dual pass per parameter
//! and central differences (also beyond one pass's lanes), and a problem's residuals and
//! Jacobian neither depend on its evaluation history nor on the number of threads.
use legwise::identify::jacobian::{PreparedLeg, LANES};
use legwise::identify::problem::IdentificationProblem;
use legwise::kinematics::chain::{attachment_world, tip_position, ChainFrames};
use legwise::kinematics::inverse::{
    joints, newton, predict_reading, reading_at_solution, solve_leg, solve_warm,
};
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::leg::LegModel;
use legwise::model::params::{ParamTarget, Parameter, Unit};
use legwise::solver::{solve, SolverKind};
use nalgebra::DVector;
use num_dual::Dual64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::support::{bundled, bundled_models};

/// Along a path of poses through the usable workspace, each solve warm-started from the
/// previous pose's solution gives the from-home solution, and it closes the leg.
#[test]
fn warm_started_ik_along_a_path_equals_the_from_home_solve() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for mech in bundled_models() {
        let home = mech.home_pose;
        for leg in &mech.legs {
            let geometry = leg.geometry(&leg.nominal());
            let frames = ChainFrames::new(&geometry);
            let mut seed = None;
            for _ in 0..40 {
                let pose = mech.workspace.sample(&home, &mut rng).unwrap();
                let target = attachment_world(&pose, &geometry.attachment);
                let warm = solve_warm(
                    leg,
                    &geometry,
                    &frames,
                    (&pose, &target),
                    &home,
                    seed.as_ref(),
                )
                .unwrap_or_else(|e| panic!("{}: {e}", leg.name));
                let cold = solve_leg(leg, &geometry, &pose, &home).unwrap();
                for (w, c) in warm.q.iter().zip(&cold.q) {
                    assert!(
                        (w - c).abs() < 1e-12,
                        "{}: {:?} vs {:?}",
                        leg.name,
                        warm.q,
                        cold.q
                    );
                }
                let tip = tip_position(leg, &geometry, &warm.q[..leg.moving.len()]);
                assert!((tip - target).norm() < 1e-12);
                assert!(warm.normalised_determinant * leg.branch_sign > 0.0);
                seed = Some(warm.q);
            }
        }
    }
}

/// A seed on the other working mode converges there: the warm start is refused and the solve
/// falls back to the from-home path, which gives the home-branch solution.
#[test]
fn a_warm_start_on_the_other_branch_falls_back_to_the_home_branch() {
    let mech = bundled("5r.yaml");
    let home = mech.home_pose;
    let leg = &mech.legs[0];
    let geometry = leg.geometry(&leg.nominal());
    let frames = ChainFrames::new(&geometry);
    let pose = [0.1, 1.2, 0.0, 0.0, 0.0, 0.0];
    let cold = solve_leg(leg, &geometry, &pose, &home).unwrap();
    // The elbow folded the other way: Newton from there converges on the other working mode.
    let mirrored = [cold.q[0] - 2.0 * 0.9, -cold.q[1]];
    let other = newton(leg, &geometry, &pose, &mirrored).unwrap();
    assert!(other.normalised_determinant * leg.branch_sign < 0.0);
    assert!(
        (other.q[1] + cold.q[1]).abs() < 1e-9,
        "{:?} {:?}",
        other.q,
        cold.q
    );
    let target = attachment_world(&pose, &geometry.attachment);
    let warm = solve_warm(
        leg,
        &geometry,
        &frames,
        (&pose, &target),
        &home,
        Some(&joints(&other.q)),
    )
    .unwrap();
    assert!(warm.normalised_determinant * leg.branch_sign > 0.0);
    assert!((warm.q[0] - cold.q[0]).abs() < 1e-12 && (warm.q[1] - cold.q[1]).abs() < 1e-12);
    // A non-finite seed falls back too.
    let nan = solve_warm(
        leg,
        &geometry,
        &frames,
        (&pose, &target),
        &home,
        Some(&[f64::NAN; 3]),
    )
    .unwrap();
    assert!((nan.q[0] - cold.q[0]).abs() < 1e-12);
}

/// One dual pass per parameter (`Dual64`, the generic reading) for the gradient's reference.
fn per_parameter_gradient(
    leg: &LegModel,
    phi: &[f64],
    pose: &[f64; 6],
    home: &[f64; 6],
) -> Vec<f64> {
    let solution = solve_leg(leg, &leg.geometry(phi), pose, home).unwrap();
    let pose_dual = pose.map(Dual64::from);
    (0..phi.len())
        .map(|j| {
            let mut seeded: Vec<Dual64> = phi.iter().map(|&v| Dual64::from(v)).collect();
            seeded[j].eps = 1.0;
            reading_at_solution(leg, &leg.geometry(&seeded), &pose_dual, &solution).eps
        })
        .collect()
}

/// Every origin component of every joint, the attachment, gain and offset as parameters (23
/// for a three-joint chain: three passes of at most `LANES`).
fn every_quantity(leg: &LegModel) -> LegModel {
    let mut wide = leg.clone();
    wide.params.clear();
    for (joint, j) in leg.joints.iter().enumerate() {
        for component in 0..6 {
            wide.params.push(Parameter {
                name: format!("{}_{component}", j.name),
                target: ParamTarget::JointOrigin { joint, component },
                nominal: j.origin[component],
                identified: true,
                unit: if component < 3 {
                    Unit::Metre
                } else {
                    Unit::Radian
                },
                derived: None,
                prior: None,
            });
        }
    }
    for component in 0..3 {
        wide.params.push(Parameter {
            name: format!("attachment_{component}"),
            target: ParamTarget::Attachment { component },
            nominal: leg.attachment[component],
            identified: true,
            unit: Unit::Metre,
            derived: None,
            prior: None,
        });
    }
    for (name, target, nominal) in [
        ("gain", ParamTarget::Gain, leg.gain),
        ("offset", ParamTarget::Offset, leg.offset),
    ] {
        wide.params.push(Parameter {
            name: name.into(),
            target,
            nominal,
            identified: true,
            unit: Unit::One,
            derived: None,
            prior: None,
        });
    }
    wide
}

#[test]
fn the_one_pass_gradient_equals_per_parameter_duals_and_central_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for mech in bundled_models() {
        let home = mech.home_pose;
        for leg in mech.legs.iter().map(every_quantity) {
            let n = leg.params.len();
            assert!(n > 2 * LANES, "{n} parameters: more than two passes");
            for _ in 0..5 {
                let pose = mech.workspace.sample(&home, &mut rng).unwrap();
                // Perturbed parameters: no special zero or unit values.
                let phi: Vec<f64> = leg
                    .nominal()
                    .iter()
                    .map(|v| v + rng.random_range(-0.01..0.01))
                    .collect();
                // Any order of the columns: reversed.
                let columns: Vec<usize> = (0..n).rev().collect();
                let prepared = PreparedLeg::new(&leg, &phi, &columns);
                let mut gradient = vec![f64::NAN; n];
                let value = prepared
                    .reading_and_gradient(&pose, &home, &mut gradient)
                    .unwrap();
                let base = predict_reading(&leg, &phi, &pose, &home).unwrap();
                assert!((value - base).abs() < 1e-13, "{value} vs {base}");
                let reference = per_parameter_gradient(&leg, &phi, &pose, &home);
                for (k, &j) in columns.iter().enumerate() {
                    let g = gradient[k];
                    assert!(
                        (g - reference[j]).abs() <= 1e-13 * (1.0 + reference[j].abs()),
                        "{} ∂ψ/∂{}: {g} vs {}",
                        leg.name,
                        leg.params[j].name,
                        reference[j]
                    );
                    let h = 1e-6;
                    let (mut plus, mut minus) = (phi.clone(), phi.clone());
                    plus[j] += h;
                    minus[j] -= h;
                    let difference = (predict_reading(&leg, &plus, &pose, &home).unwrap()
                        - predict_reading(&leg, &minus, &pose, &home).unwrap())
                        / (2.0 * h);
                    assert!(
                        (g - difference).abs() <= 1e-6 * g.abs().max(difference.abs()).max(1e-3),
                        "{} ∂ψ/∂{}: {g} vs central difference {difference}",
                        leg.name,
                        leg.params[j].name
                    );
                }
            }
        }
    }
}

/// A problem's residuals and Jacobian after a history of evaluations (warm starts) equal a
/// fresh problem's (from home), and a fit gives bit-identical results on one and two threads.
#[test]
fn residuals_ignore_the_history_and_the_thread_count() {
    let mech = bundled("5r.yaml");
    let options = SimulationOptions {
        poses_per_leg: Some(700),
        ..Default::default()
    };
    let data = simulate(&mech, options).unwrap().measurements;
    let problem = IdentificationProblem::new(&mech, &[0], data.leg_blocks(0));
    assert!(problem.blocks().len() > 512, "several parallel chunks");
    let x0 = problem.start();
    let mut x = x0.clone();
    for step in 0..4 {
        x[0] += 1e-3 * step as f64;
        x[3] -= 5e-4 * step as f64;
        problem.residuals_and_jacobian(&x).unwrap();
    }
    let (r_warm, c_warm) = problem.residuals_and_jacobian(&x0).unwrap();
    let fresh = IdentificationProblem::new(&mech, &[0], data.leg_blocks(0));
    let (r_cold, c_cold) = fresh.residuals_and_jacobian(&x0).unwrap();
    assert!((&r_warm - &r_cold).amax() < 1e-13);
    assert!((&c_warm - &c_cold).amax() < 1e-12);
    assert!((problem.residuals(&x0).unwrap() - &r_cold).amax() < 1e-13);
    let fit = |threads: usize| -> DVector<f64> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let problem = IdentificationProblem::new(&mech, &[0], data.leg_blocks(0));
        pool.install(|| solve(&problem, problem.start(), SolverKind::LevenbergMarquardt))
            .unwrap()
            .x
    };
    let one: Vec<u64> = fit(1).iter().map(|v| v.to_bits()).collect();
    let two: Vec<u64> = fit(2).iter().map(|v| v.to_bits()).collect();
    assert_eq!(one, two);
}

/// A problem too large to keep its full solutions (more than 65 536 rows) takes the Jacobian
/// where it last evaluated the residuals from its kept seeds (dual passes only): bit for bit
/// the Jacobian of an evaluation that took both at once, and, row by row, the Jacobian and the
/// expected variances of a small problem of the same poses (which keeps its solutions).
#[test]
fn a_large_problem_takes_its_jacobian_from_the_kept_seeds() {
    let mech = bundled("5r.yaml");
    let options = SimulationOptions {
        poses_per_leg: Some(40),
        ..Default::default()
    };
    let data = simulate(&mech, options).unwrap().measurements;
    let base = data.leg_blocks(0);
    let copies = 65_536 / base.len() + 1;
    let many: Vec<_> = (0..copies).flat_map(|_| base.iter().cloned()).collect();
    let small = IdentificationProblem::new(&mech, &[0], base.clone());
    let large = IdentificationProblem::new(&mech, &[0], many.clone());
    let mut x = large.start();
    x[0] += 2e-3;
    x[3] -= 1e-3;
    // Residuals first, then the Jacobian at the same unknowns: from the seeds.
    let r = large.residuals(&x).unwrap();
    let (r_seeds, c_seeds) = large.residuals_and_jacobian(&x).unwrap();
    // Both at once on a fresh problem.
    let fresh = IdentificationProblem::new(&mech, &[0], many);
    let (r_once, c_once) = fresh.residuals_and_jacobian(&x).unwrap();
    // The residuals are the kept evaluation's (a Jacobian's pass reads the prediction off the
    // dual pass, the residuals' off the closure error: the same to round-off).
    assert!(r == r_seeds, "the Jacobian's residuals are the kept ones");
    assert!((&r_once - &r_seeds).amax() < 1e-14);
    let same_bits = c_once
        .iter()
        .zip(c_seeds.iter())
        .all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(
        same_bits,
        "the seeds' Jacobian is the one-pass Jacobian, bit for bit"
    );
    let (r_small, c_small) = small.residuals_and_jacobian(&x).unwrap();
    let noise = mech.noise.expect("the 5R declares its noise");
    let v_large = legwise::identify::statistics::row_variances(&large, &x, &noise).unwrap();
    let v_small = legwise::identify::statistics::row_variances(&small, &x, &noise).unwrap();
    for i in 0..r_seeds.len() {
        let k = i % base.len();
        assert!((r_seeds[i] - r_small[k]).abs() < 1e-13);
        for j in 0..c_small.ncols() {
            assert!((c_seeds[(i, j)] - c_small[(k, j)]).abs() < 1e-12);
        }
        assert!((v_large[i] - v_small[k]).abs() <= 1e-12 * v_small[k]);
    }
}

/// Every number of prepared columns, 1 to all of them (every size of a last, partial pass):
/// the one-pass gradient equals the per-parameter duals, column for column.
#[test]
fn every_column_count_gives_the_per_parameter_gradient() {
    let mech = bundled("3rpr.yaml");
    let home = mech.home_pose;
    let leg = every_quantity(&mech.legs[0]);
    let n = leg.params.len();
    let pose = [
        home[0] + 0.01,
        home[1] - 0.02,
        0.0,
        0.0,
        0.0,
        home[5] + 0.05,
    ];
    let phi: Vec<f64> = leg
        .nominal()
        .iter()
        .enumerate()
        .map(|(k, v)| v + 1e-3 * (k as f64).sin())
        .collect();
    let reference = per_parameter_gradient(&leg, &phi, &pose, &home);
    for count in 1..=n {
        // The last `count` parameters, in reverse order.
        let columns: Vec<usize> = (n - count..n).rev().collect();
        let prepared = PreparedLeg::new(&leg, &phi, &columns);
        assert_eq!(prepared.columns(), count);
        let mut gradient = vec![f64::NAN; count];
        prepared
            .reading_and_gradient(&pose, &home, &mut gradient)
            .unwrap();
        for (k, &j) in columns.iter().enumerate() {
            assert!(
                (gradient[k] - reference[j]).abs() <= 1e-13 * (1.0 + reference[j].abs()),
                "{count} columns, ∂ψ/∂{}: {} vs {}",
                leg.params[j].name,
                gradient[k],
                reference[j]
            );
        }
    }
}
