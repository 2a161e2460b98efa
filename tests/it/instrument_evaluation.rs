//! The shared problem's kept evaluations and its row variances, recomputed another way: the
//! blocks after other evaluations equal a fresh problem's at the same unknowns, and each row's
//! expected variance equals the declared reading variance plus the target coordinates'
//! variances carried by central differences of the residuals in those coordinates.
use argmin::core::Operator;
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::observe_simulate::simulate_observed;
use legwise::measure::simulate::SimulationOptions;
use legwise::solver::bordered::{to_dense, BorderedLeastSquares};

use crate::instrument_support::target_sigmas;
use crate::support::bundled;

const MODELS: [&str; 2] = ["5r-tracker.yaml", "3rpr-tracker.yaml"];

#[test]
fn blocks_after_other_evaluations_equal_a_fresh_problems_at_the_same_unknowns() {
    for model in MODELS {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
        let problem =
            IdentificationProblem::through_instrument(&mechanism, &experiment.observations)
                .unwrap();
        let x1 = problem.start().map(|v| v * (1.0 + 1e-3));
        let x2 = problem.start().map(|v| v * (1.0 - 2e-3));
        // Residuals at x1 (kept), then at x2 in a clone (a solver's copy), then blocks at x1
        // and at x2 (the clone's evaluation, shared) on the original.
        let r1 = problem.apply(&x1).unwrap();
        let r2 = problem.clone().apply(&x2).unwrap();
        let layout = problem.layout();
        let (b1, j1) = to_dense(&layout, &problem.bordered(&x1).unwrap());
        let (b2, j2) = to_dense(&layout, &problem.bordered(&x2).unwrap());
        assert_eq!(r1, b1, "{model}: residuals at x1");
        assert_eq!(r2, b2, "{model}: residuals at x2");
        assert!((&r1 - &r2).amax() > 1e-6, "{model}: x1 and x2 must differ");
        for (x, r, j) in [(&x1, &b1, &j1), (&x2, &b2, &j2)] {
            let fresh =
                IdentificationProblem::through_instrument(&mechanism, &experiment.observations)
                    .unwrap();
            let (fr, fj) = to_dense(&layout, &fresh.bordered(x).unwrap());
            assert!(
                (r - &fr).amax() <= 1e-12,
                "{model}: residuals {:e}",
                (r - &fr).amax()
            );
            let gap = (j - &fj).amax();
            assert!(
                gap <= 1e-10 * fj.amax(),
                "{model}: Jacobian differs by {gap:e}"
            );
        }
    }
}

#[test]
fn row_variances_carry_the_target_noise_through_the_pose_fit_as_central_differences_do() {
    for model in MODELS {
        let mechanism = bundled(model);
        let noise = mechanism.noise.expect("a declared noise");
        let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
        let observations = &experiment.observations;
        let problem = IdentificationProblem::through_instrument(&mechanism, observations).unwrap();
        let x = problem.start().map(|v| v * (1.0 + 1e-3));
        let variances = problem.row_variances(&x, &noise).unwrap();
        let sigmas = target_sigmas(&mechanism, &noise);
        // Σ_i (∂r/∂m_i σ_i)² per residual: a row's coordinates move only its own residuals.
        let mut carried = vec![0.0; problem.apply(&x).unwrap().len()];
        assert_eq!(variances.len(), carried.len(), "{model}: one per residual");
        let h = 1e-6;
        for row in 0..observations.rows.len() {
            for (i, sigma) in sigmas.iter().enumerate() {
                let residuals = |delta: f64| {
                    let mut moved = observations.clone();
                    moved.rows[row].observed[i] += delta;
                    IdentificationProblem::through_instrument(&mechanism, &moved)
                        .unwrap()
                        .apply(&x)
                        .unwrap()
                };
                let d = (residuals(h) - residuals(-h)) / (2.0 * h);
                for (c, v) in carried.iter_mut().zip(d.iter()) {
                    *c += (v * sigma).powi(2);
                }
            }
        }
        let reading = noise.reading.powi(2);
        let mut moved = 0;
        for (k, (&v, &c)) in variances.iter().zip(&carried).enumerate() {
            assert!(
                (v - (reading + c)).abs() <= 1e-6 * c + 1e-20,
                "{model}, row {k}: variance {v:e}, expected {:e}",
                reading + c
            );
            moved += usize::from(c > 0.1 * reading);
        }
        // The pose fit carries a comparable share of the noise on every row.
        assert_eq!(moved, variances.len(), "{model}");
    }
}

/// Holding the shared parameters at given values: the residuals are the full problem's at the
/// same values (the legs' unknowns alone), and the held problem keeps evaluations of its own
/// (with every frame component held in the model, the two problems' unknowns have the same
/// length, so a shared evaluation state would hand back the other values).
#[test]
fn holding_the_shared_parameters_gives_the_full_problems_residuals_at_their_values() {
    for model in MODELS {
        let mechanism = bundled(model);
        let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
        let observations = &experiment.observations;
        let full = IdentificationProblem::through_instrument(&mechanism, observations).unwrap();
        let x = full.start().map(|v| v * (1.0 + 1e-3));
        let values = full.shared_values(&x);
        let own = x
            .rows(0, x.len() - full.shared_columns().len())
            .into_owned();
        assert!(!full.shared_columns().is_empty(), "{model}");
        let held = full.with_shared_fixed(&values);
        assert!(held.shared_columns().is_empty());
        let gap = (held.apply(&own).unwrap() - full.apply(&x).unwrap()).amax();
        assert!(gap <= 1e-12, "{model}: {gap:e}");
        // Every instrument parameter held by the model: the unknowns are the legs' in both.
        let frozen = mechanism.edited(|frozen| {
            for p in &mut frozen.instrument.as_mut().unwrap().parameters {
                p.identified = false;
            }
        });
        let nominal = IdentificationProblem::through_instrument(&frozen, observations).unwrap();
        assert_eq!(nominal.start().len(), own.len(), "{model}");
        let at_nominal = nominal.apply(&own).unwrap();
        let moved = nominal.with_shared_fixed(&values).apply(&own).unwrap();
        let gap = (&moved - full.apply(&x).unwrap()).amax();
        assert!(gap <= 1e-12, "{model}: {gap:e}");
        assert!(
            (&moved - &at_nominal).amax() > 1e-6,
            "{model}: the values matter"
        );
    }
}

/// What the shared problem's evaluations reuse, counted in solved rows
/// (`IdentificationProblem::row_solves`): the two latest evaluations are kept (the oldest dropped), the
/// derivatives where the residuals were evaluated solve nothing, clones share the count, and a
/// problem of more than 65 536 rows keeps its readings but not its solutions.
#[test]
fn the_shared_problem_keeps_its_two_latest_evaluations() {
    let mechanism = bundled("5r-tracker.yaml");
    let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
    let problem =
        IdentificationProblem::through_instrument(&mechanism, &experiment.observations).unwrap();
    let point = |d: f64| problem.start().map(|v| v * (1.0 + d));
    let (x1, x2, x3) = (point(1e-3), point(2e-3), point(3e-3));
    assert_eq!(problem.row_solves(), 0);
    let m = problem.apply(&x1).unwrap().len() as u64;
    assert_eq!(problem.row_solves(), m);
    problem.apply(&x1).unwrap();
    problem.bordered(&x1).unwrap();
    problem.bordered(&x1).unwrap();
    assert_eq!(
        problem.row_solves(),
        m,
        "kept, derivatives from the kept rows"
    );
    problem.apply(&x2).unwrap();
    problem.apply(&x1).unwrap();
    assert_eq!(problem.row_solves(), 2 * m, "two kept");
    problem.clone().apply(&x3).unwrap();
    assert_eq!(problem.row_solves(), 3 * m, "a clone's solves counted");
    problem.apply(&x1).unwrap();
    assert_eq!(problem.row_solves(), 3 * m, "x1 was the newer");
    problem.apply(&x2).unwrap();
    assert_eq!(problem.row_solves(), 4 * m, "x2 was dropped");
    // A problem of more than 65 536 rows keeps its readings, not its solutions: the derivatives
    // where it last solved need the derivative passes only (from its warm starts), elsewhere a
    // solve again.
    let mut many = experiment.observations.clone();
    let copies = 65_536 / m as usize + 1;
    many.rows = (0..copies)
        .flat_map(|_| experiment.observations.rows.iter().cloned())
        .collect();
    let large = IdentificationProblem::through_instrument(&mechanism, &many).unwrap();
    let rows = large.apply(&x1).unwrap().len() as u64;
    assert!(rows > 65_536);
    large.apply(&x1).unwrap();
    large.bordered(&x1).unwrap();
    assert_eq!(large.row_solves(), rows);
    large.apply(&x2).unwrap();
    large.bordered(&x2).unwrap();
    assert_eq!(
        large.row_solves(),
        2 * rows,
        "the derivatives from the warm starts"
    );
    // x1's readings are kept, its solutions are not: its derivatives need a solve again.
    large.bordered(&x1).unwrap();
    assert_eq!(large.row_solves(), 3 * rows);
}

/// The two-stage registration's rows: `with_rows(k)` keeps the first `k` rows of every leg, in
/// order, and their residuals are the full problem's at those rows.
#[test]
fn with_rows_keeps_the_first_rows_of_every_leg() {
    let mechanism = bundled("3rpr-tracker.yaml");
    let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
    let full =
        IdentificationProblem::through_instrument(&mechanism, &experiment.observations).unwrap();
    let x = full.start().map(|v| v * (1.0 + 1e-3));
    let r_full = full.apply(&x).unwrap();
    for count in [1, 2, 5] {
        let few = full.with_rows(count);
        let mut expected = Vec::new();
        for leg in full.legs() {
            let rows = (0..full.blocks().len()).filter(|&i| full.blocks()[i].leg == leg);
            expected.extend(rows.take(count));
        }
        assert_eq!(few.blocks().len(), expected.len());
        assert_eq!(expected.len(), count * full.legs().len());
        let r_few = few.apply(&x).unwrap();
        for (k, &i) in expected.iter().enumerate() {
            assert_eq!(
                few.blocks()[k].reading.to_bits(),
                full.blocks()[i].reading.to_bits(),
                "{count}: {k}"
            );
            assert!((r_few[k] - r_full[i]).abs() <= 1e-12, "{count}: {k}");
        }
    }
}

/// Row weights scale a row's residual and its whole Jacobian row, the instrument's columns
/// included: weights of 4 double them.
#[test]
fn weights_scale_the_shared_columns_too() {
    let mechanism = bundled("5r-tracker.yaml");
    let experiment = simulate_observed(&mechanism, SimulationOptions::default()).unwrap();
    let problem =
        IdentificationProblem::through_instrument(&mechanism, &experiment.observations).unwrap();
    let x = problem.start().map(|v| v * (1.0 + 1e-3));
    let (r, jacobian) = problem.residuals_and_jacobian(&x).unwrap();
    let weighted = problem.clone().with_weights(&vec![4.0; r.len()]);
    let (rw, jw) = weighted.residuals_and_jacobian(&x).unwrap();
    assert!(!problem.shared_columns().is_empty());
    assert_eq!(rw, &r * 2.0);
    assert_eq!(jw, &jacobian * 2.0);
}
