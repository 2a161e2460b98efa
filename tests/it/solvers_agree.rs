//! Solvers and strategies agree: D&C equals traditional on the same poses (block-diagonal
//! stacked Jacobian); LM agrees with the `levenberg-marquardt` crate (MINPACK port).
use legwise::identify::estimate::{identify, Strategy};
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::measure::MeasurementSet;
use legwise::solver::{solve, SolverKind};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

use crate::support::{bundled, bundled_models};

/// Only the shared poses of a simulated experiment: every leg's D&C then uses exactly the
/// traditional strategy's poses.
fn shared_only(data: &MeasurementSet) -> MeasurementSet {
    data.filtered(|p, _| p.leg.is_none())
}

#[test]
fn divide_and_conquer_equals_traditional_on_the_same_poses() {
    for mech in bundled_models() {
        let data = shared_only(
            &simulate(&mech, SimulationOptions::default())
                .unwrap()
                .measurements,
        );
        for solver in [SolverKind::GaussNewton, SolverKind::LevenbergMarquardt] {
            let dc = identify(&mech, &data, Strategy::DivideAndConquer, solver).unwrap();
            let all = identify(&mech, &data, Strategy::Traditional, solver).unwrap();
            for (a, b) in dc.legs.iter().zip(&all.legs) {
                for (p, q) in a.parameters.iter().zip(&b.parameters) {
                    // Both solvers end on the stationary point (see solver::refine), so the
                    // per-leg and the stacked problems must give the same estimate; a coupling
                    // bug shows at the scale of the standard deviation.
                    let tolerance = 1e-10 * (1.0 + p.estimate.abs());
                    assert!(
                        (p.estimate - q.estimate).abs() <= tolerance,
                        "{} {solver:?} {}: D&C {} vs traditional {}",
                        mech.name,
                        p.name,
                        p.estimate,
                        q.estimate
                    );
                    // A parameter held fixed (the delta's effector joints) has no std.
                    match (p.std, q.std) {
                        (Some(sp), Some(sq)) => {
                            assert!((sp - sq).abs() <= 1e-8 * sp, "{}: std {sp} vs {sq}", p.name)
                        }
                        (sp, sq) => assert!(sp.is_none() && sq.is_none() && !p.identified),
                    }
                }
            }
        }
    }
}

#[test]
fn the_stacked_jacobian_is_block_diagonal() {
    let mech = bundled("5r.yaml");
    let data = shared_only(
        &simulate(&mech, SimulationOptions::default())
            .unwrap()
            .measurements,
    );
    let legs: Vec<usize> = (0..mech.legs.len()).collect();
    let problem = IdentificationProblem::new(&mech, &legs, data.shared_blocks(legs.len()));
    let (_, c) = problem.residuals_and_jacobian(&problem.start()).unwrap();
    for (i, block) in problem.blocks().iter().enumerate() {
        for slot in problem.slots() {
            for k in 0..slot.columns.len() {
                let value = c[(i, slot.offset + k)];
                if slot.leg == block.leg {
                    assert!(value != 0.0, "row {i}: own-leg column {k} is zero");
                } else {
                    assert_eq!(
                        value.to_bits(),
                        0.0f64.to_bits(),
                        "row {i} touches leg {}",
                        slot.leg
                    );
                }
            }
        }
    }
}

/// The 5R leg-1 problem for the MINPACK port.
struct MinpackLeg<'a> {
    problem: &'a IdentificationProblem<'a>,
    x: DVector<f64>,
}

impl levenberg_marquardt::LeastSquaresProblem<f64, Dyn, Dyn> for MinpackLeg<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }
    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        self.problem.residuals(&self.x).ok()
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.problem
            .residuals_and_jacobian(&self.x)
            .ok()
            .map(|(_, j)| j)
    }
}

/// Agreement with MINPACK on the model's seeded noisy experiment, both legs.
///
/// Both solvers stop by cost-ratio tests whose decisions, near this flat minimum, rest on a
/// cost known only to ~1e-11 relative: MINPACK's own stopping point can lie up to about
/// √(ε·cost)/s_min ≈ 1e-9 from the stationary point Jᵀr = 0 (ours is refined onto it, see
/// `solver::refine`), and where in that band depends on the data's round-off: since the
/// simulation's readings come from the closed-form kernel (1e-15 away from the generic
/// chain's) MINPACK stops 4.8e-10 and 1.0e-9 from ours on leg 0 (on it before): the two agree
/// to 2e-9.
/// Where exactly MINPACK stops depends on the round-off of each of its evaluations, and so on
/// the evaluations made before (warm starts, kept values): it runs on a problem of its own,
/// the same blocks with no history.
#[test]
fn levenberg_marquardt_agrees_with_the_minpack_port_on_the_noisy_5r_leg() {
    let mech = bundled("5r.yaml");
    let data = simulate(&mech, SimulationOptions::default())
        .unwrap()
        .measurements;
    for leg in 0..mech.legs.len() {
        let problem = IdentificationProblem::new(&mech, &[leg], data.leg_blocks(leg));
        let ours = solve(&problem, problem.start(), SolverKind::LevenbergMarquardt).unwrap();
        let fresh = IdentificationProblem::new(&mech, &[leg], data.leg_blocks(leg));
        let (minpack, report) = levenberg_marquardt::LevenbergMarquardt::new()
            .with_ftol(legwise::solver::LM_TOLERANCE)
            .with_xtol(legwise::solver::LM_TOLERANCE)
            .with_gtol(0.0)
            .minimize(MinpackLeg {
                problem: &fresh,
                x: fresh.start(),
            });
        assert!(
            report.termination.was_successful(),
            "{:?}",
            report.termination
        );
        for (a, b) in ours.x.iter().zip(minpack.x.iter()) {
            assert!(
                (a - b).abs() <= 2e-9 * (1.0 + b.abs()),
                "leg {leg}: LM {a} vs MINPACK {b}"
            );
        }
    }
}

/// Over many seeds, both solvers end on the stationary point: the Gauss–Newton step from the
/// estimate is at round-off, and LM and GN agree to 1e-12.
#[test]
fn both_solvers_end_on_the_stationary_point_over_many_seeds() {
    let mech = bundled("5r.yaml");
    for seed in 1..=12 {
        let options = SimulationOptions {
            seed: Some(seed),
            ..Default::default()
        };
        let data = simulate(&mech, options).unwrap().measurements;
        for leg in 0..mech.legs.len() {
            let problem = IdentificationProblem::new(&mech, &[leg], data.leg_blocks(leg));
            let lm = solve(&problem, problem.start(), SolverKind::LevenbergMarquardt).unwrap();
            let gn = solve(&problem, problem.start(), SolverKind::GaussNewton).unwrap();
            let (r, c) = problem.residuals_and_jacobian(&lm.x).unwrap();
            let step = c.svd(true, true).solve(&r, f64::EPSILON).unwrap();
            assert!(
                step.amax() < 1e-12,
                "seed {seed} leg {leg}: GN step {:.2e} from the LM estimate",
                step.amax()
            );
            let difference = (&lm.x - &gn.x).amax();
            assert!(
                difference < 1e-12,
                "seed {seed} leg {leg}: LM and GN differ by {difference:.2e}"
            );
        }
    }
}

/// Every identification run reports convergence and its typed stop reason, in the terminal
/// report (`converged (…)` on the solver line) and in the JSON (`converged`, `stop_reason`);
/// a run marked as not converged puts a warning at the top of the terminal report and is
/// listed by `trust_issues`.
#[test]
fn runs_report_convergence_in_the_terminal_and_the_json() {
    use legwise::identify::trust::trust_issues;
    use legwise::measure::Measurements;
    use legwise::report::Report;
    use legwise::solver::StopReason;

    let mech = bundled("5r.yaml");
    let data = simulate(&mech, SimulationOptions::default())
        .unwrap()
        .measurements;
    let result = identify(
        &mech,
        &data,
        Strategy::DivideAndConquer,
        SolverKind::LevenbergMarquardt,
    )
    .unwrap();
    assert!(result.runs.iter().all(|r| r.converged));
    assert!(trust_issues(std::slice::from_ref(&result)).is_empty());
    let mut report = Report {
        mechanism: &mech,
        source: "simulation".into(),
        measurements: Measurements::Readings(data.clone()),
        real: None,
        results: vec![result],
        maps: None,
    };
    let json = serde_json::to_value(report.to_json()).unwrap();
    let keys: Vec<&str> = StopReason::ALL.iter().map(|r| r.key()).collect();
    for leg in json["results"][0]["legs"].as_array().unwrap() {
        assert_eq!(leg["solver"]["converged"], serde_json::Value::Bool(true));
        let key = leg["solver"]["stop_reason"].as_str().unwrap();
        assert!(keys.contains(&key), "{key}");
    }
    let text = report.terminal_text();
    assert!(
        !text.contains("WARNING") && text.contains(": converged ("),
        "{text}"
    );

    let run = &mut report.results[0].runs[1];
    (run.converged, run.stop_reason) = (false, StopReason::EvaluationBudget);
    let leg = run.legs[0].clone();
    let issues = trust_issues(&report.results);
    assert_eq!(issues.len(), 1);
    assert!(
        issues[0].contains(&leg) && issues[0].contains("budget"),
        "{}",
        issues[0]
    );
    let text = report.terminal_text();
    let first_leg_table = text.find("\nleg ").unwrap();
    let warning = text.find("WARNING: ").expect("a warning");
    assert!(
        warning < first_leg_table,
        "the warning is not at the top:\n{text}"
    );
    assert!(text.contains("NOT CONVERGED (budget of residual evaluations exhausted)"));
    let json = serde_json::to_value(report.to_json()).unwrap();
    let legs = json["results"][0]["legs"].as_array().unwrap();
    let flagged = legs.iter().find(|l| l["name"] == leg.as_str()).unwrap();
    assert_eq!(
        flagged["solver"]["converged"],
        serde_json::Value::Bool(false)
    );
    assert_eq!(flagged["solver"]["stop_reason"], "evaluation_budget");
}

/// Readings exact at the nominal parameters: the fit starts at the minimum, where the residual
/// is round-off (its direction, and so the gradient cosine, is noise). The Gauss–Newton step
/// there is negligible, so the run converges: an exact start is not a stall.
#[test]
fn an_exact_start_converges() {
    let mech = bundled("5r.yaml");
    let path = crate::support::crate_path("tests/data/valid.csv");
    let set = legwise::measure::file::read(&path, &mech).unwrap();
    for solver in [SolverKind::LevenbergMarquardt, SolverKind::GaussNewton] {
        for strategy in [Strategy::DivideAndConquer, Strategy::Traditional] {
            let result =
                crate::support::identify_unweighted(&mech, &set, strategy, solver).unwrap();
            for run in &result.runs {
                assert!(run.final_cost < 1e-28, "{}", run.final_cost);
                assert!(
                    run.converged,
                    "{solver:?} {strategy:?}: {}",
                    run.stop_reason
                );
            }
        }
    }
}
