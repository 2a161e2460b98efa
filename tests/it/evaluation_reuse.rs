//! What an identification problem's evaluations reuse, counted in solved rows
//! (`IdentificationProblem::row_solves`): the two latest evaluations are kept (newest first, the
//! oldest dropped), a Jacobian where the residuals were evaluated needs no inverse kinematics
//! (from the kept solutions, or from the seeds for a problem too large to keep them), the
//! clones share the count, and `map_solved` reuses a kept evaluation and solves otherwise.
//! Also what stays in memory (`kept_evaluations`) and that every row is warm-started from its
//! previous solution, seen in the last bits of the solutions; and what the problem assembles from
//! an evaluation (a leg's part of the Jacobian, the turn term of readings on another turn).
use legwise::identify::problem::IdentificationProblem;
use legwise::measure::simulate::{simulate, SimulationOptions};
use legwise::model::Mechanism;
use nalgebra::{DMatrix, DVector};

use crate::support::{assert_central_differences, bundled};

/// Leg 0 of the bundled 5R on `poses` simulated poses.
fn leg_problem(mech: &Mechanism, poses: usize, copies: usize) -> IdentificationProblem<'_> {
    let options = SimulationOptions {
        poses_per_leg: Some(poses),
        ..Default::default()
    };
    let base = simulate(mech, options).unwrap().measurements.leg_blocks(0);
    let blocks = (0..copies).flat_map(|_| base.iter().cloned()).collect();
    IdentificationProblem::new(mech, &[0], blocks)
}

/// Three distinct parameter vectors near the nominal one.
fn three_points(problem: &IdentificationProblem<'_>) -> [DVector<f64>; 3] {
    let x0 = problem.start();
    let shifted = |d: f64| {
        let mut x = x0.clone();
        x[0] += d;
        x[3] -= 0.5 * d;
        x
    };
    [shifted(1e-3), shifted(2e-3), shifted(3e-3)]
}

#[test]
fn the_two_latest_evaluations_are_kept_and_the_oldest_is_dropped() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 30, 1);
    let m = problem.blocks().len() as u64;
    let [x1, x2, x3] = three_points(&problem);
    assert_eq!(problem.row_solves(), 0, "a new problem has solved nothing");
    let r1 = problem.residuals(&x1).unwrap();
    assert_eq!(problem.row_solves(), m);
    assert_eq!(problem.residuals(&x1).unwrap(), r1, "kept: the same values");
    assert_eq!(problem.row_solves(), m, "kept: no row solved again");
    let (r, _) = problem.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(r, r1);
    assert_eq!(
        problem.row_solves(),
        m,
        "the Jacobian from the kept solutions"
    );
    problem.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(problem.row_solves(), m, "and its gradients kept");
    problem.residuals(&x2).unwrap();
    assert_eq!(problem.row_solves(), 2 * m);
    problem.residuals(&x1).unwrap();
    assert_eq!(problem.row_solves(), 2 * m, "two evaluations kept");
    // Kept: x1 (newest), x2. A third point drops x2, the oldest.
    problem.residuals(&x3).unwrap();
    assert_eq!(problem.row_solves(), 3 * m);
    problem.residuals(&x1).unwrap();
    assert_eq!(problem.row_solves(), 3 * m, "x1 was the newer of the two");
    problem.residuals(&x2).unwrap();
    assert_eq!(problem.row_solves(), 4 * m, "x2 was dropped");
    // Kept: x2, x1. A clone shares the evaluations and the count.
    let clone = problem.clone();
    clone.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(problem.row_solves(), 4 * m, "the clone reuses x1");
    clone.residuals(&x3).unwrap();
    assert_eq!(
        problem.row_solves(),
        5 * m,
        "the clone's solves are counted"
    );
    // Kept: x3, x1. Without weights, the same evaluations.
    problem.unweighted().residuals(&x1).unwrap();
    assert_eq!(problem.row_solves(), 5 * m);
}

#[test]
fn map_solved_reuses_a_kept_evaluation_and_solves_otherwise() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 30, 1);
    let m = problem.blocks().len() as u64;
    let [x1, x2, _] = three_points(&problem);
    let kept_q = |x: &DVector<f64>| {
        problem
            .map_solved(x, |index, _, _, solution| (index, solution.q))
            .unwrap()
    };
    problem.residuals(&x1).unwrap();
    let at_x1 = kept_q(&x1);
    assert_eq!(problem.row_solves(), m, "x1's solutions are kept");
    assert!(at_x1.iter().enumerate().all(|(i, &(index, _))| i == index));
    let at_x2 = kept_q(&x2);
    assert_eq!(problem.row_solves(), 2 * m, "x2 is solved");
    kept_q(&x2);
    assert_eq!(problem.row_solves(), 3 * m, "and not kept by map_solved");
    // The solutions are those of an evaluation at each point.
    let fresh = leg_problem(&mech, 30, 1);
    fresh.residuals(&x2).unwrap();
    let fresh_x2 = fresh
        .map_solved(&x2, |_, _, _, solution| solution.q)
        .unwrap();
    let gap = |a: &[f64; 3], b: &[f64; 3]| {
        a.iter()
            .zip(b)
            .map(|(u, v)| (u - v).abs())
            .fold(0.0, f64::max)
    };
    for ((_, q), p) in at_x2.iter().zip(&fresh_x2) {
        assert!(gap(q, p) < 1e-12);
    }
    assert!(at_x1
        .iter()
        .zip(&at_x2)
        .any(|((_, a), (_, b))| gap(a, b) > 1e-6));
}

/// Small problems run the rows of `map_solved` on the calling thread (no hand-off to the
/// thread pool for a few rows); more than 512 rows run on the pool's threads.
#[test]
fn only_problems_of_several_chunks_go_to_the_thread_pool() {
    let mech = bundled("5r.yaml");
    let threads = |problem: &IdentificationProblem<'_>| {
        let x = problem.start();
        problem
            .map_solved(&x, |_, _, _, _| rayon::current_thread_index())
            .unwrap()
    };
    let small = leg_problem(&mech, 30, 1);
    assert!(threads(&small).iter().all(Option::is_none));
    let at_the_limit = leg_problem(&mech, 32, 16);
    assert_eq!(at_the_limit.blocks().len(), 512);
    assert!(threads(&at_the_limit).iter().all(Option::is_none));
    let large = leg_problem(&mech, 40, 16);
    assert!(large.blocks().len() > 512);
    assert!(threads(&large).iter().all(Option::is_some));
}

/// A problem too large to keep its solutions (more than 65 536 rows) takes a Jacobian where
/// it last solved from its seeds, and solves again for one at an older kept evaluation.
#[test]
fn a_large_problem_solves_again_only_for_an_older_evaluations_jacobian() {
    let mech = bundled("5r.yaml");
    let large = leg_problem(&mech, 40, 65_536 / 40 + 1);
    let m = large.blocks().len() as u64;
    assert!(m > 65_536);
    let [x1, x2, _] = three_points(&large);
    large.residuals(&x1).unwrap();
    large.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(large.row_solves(), m, "the Jacobian from the seeds");
    large.residuals(&x2).unwrap();
    assert_eq!(large.row_solves(), 2 * m);
    large.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(large.row_solves(), 2 * m, "x1's gradients are kept");
    let (_, c2) = large.residuals_and_jacobian(&x2).unwrap();
    assert_eq!(large.row_solves(), 2 * m, "x2's seeds are the last solved");
    large.residuals(&x1).unwrap();
    large.residuals_and_jacobian(&x2).unwrap();
    assert_eq!(large.row_solves(), 2 * m, "x2's gradients are kept");
    let map = large.map_solved(&x1, |_, _, _, _| ()).unwrap();
    assert_eq!(map.len() as u64, m);
    assert_eq!(large.row_solves(), 3 * m, "no solutions kept: solved again");
    // A fresh problem at x2 after residuals at x1: the seeds are x1's, so x2's Jacobian is
    // solved again, and equals the one from the seeds.
    let other = leg_problem(&mech, 40, 65_536 / 40 + 1);
    other.residuals(&x2).unwrap();
    other.residuals(&x1).unwrap();
    let (_, c2_again) = other.residuals_and_jacobian(&x2).unwrap();
    assert_eq!(other.row_solves(), 3 * m, "x2's Jacobian solved again");
    assert!((&c2 - &c2_again).amax() < 1e-12);
}

/// The rows' expected variances of a problem too large to keep its solutions, at the unknowns
/// it last solved: each row's pose gradient from its seed (the joints and the closure
/// inverse's actuated row), no row solved again, and the same variances to 1e-12 as those
/// of a fresh problem, which solves every row (`map_solved`).
#[test]
fn a_large_problems_row_variances_where_it_last_solved_solve_no_row() {
    use legwise::identify::statistics::row_variances;
    let mech = bundled("5r.yaml");
    let noise = mech.noise.expect("the 5R declares its noise");
    let large = leg_problem(&mech, 40, 65_536 / 40 + 1);
    let m = large.blocks().len() as u64;
    let [x1, x2, _] = three_points(&large);
    large.residuals(&x2).unwrap();
    large.residuals(&x1).unwrap();
    assert_eq!(large.row_solves(), 2 * m);
    let seeded = row_variances(&large, &x1, &noise).unwrap();
    assert_eq!(large.row_solves(), 2 * m, "from the seeds: no row solved");
    let other = leg_problem(&mech, 40, 65_536 / 40 + 1);
    let solved = row_variances(&other, &x1, &noise).unwrap();
    assert_eq!(
        other.row_solves(),
        m,
        "nothing solved at x1 yet: every row solved"
    );
    assert_eq!(seeded.len(), solved.len());
    for (i, (a, b)) in seeded.iter().zip(&solved).enumerate() {
        assert!((a - b).abs() <= 1e-12 * b.abs(), "row {i}: {a} against {b}");
    }
    // At x2 the seeds are x1's: solved again, warm-started.
    row_variances(&large, &x2, &noise).unwrap();
    assert_eq!(large.row_solves(), 3 * m);
}

/// What stays in memory: two evaluations at most, the gradients of one at most (an older
/// evaluation's freed before another's are computed), nothing but the newest evaluation's
/// values after `release_gradients`.
#[test]
fn at_most_one_kept_evaluation_holds_its_gradients() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 30, 1);
    let [x1, x2, x3] = three_points(&problem);
    assert_eq!(problem.kept_evaluations(), (0, 0));
    problem.residuals(&x1).unwrap();
    assert_eq!(problem.kept_evaluations(), (1, 0));
    problem.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(problem.kept_evaluations(), (1, 1));
    problem.residuals_and_jacobian(&x2).unwrap();
    assert_eq!(problem.kept_evaluations(), (2, 1), "x1's gradients freed");
    problem.residuals_and_jacobian(&x1).unwrap();
    assert_eq!(problem.kept_evaluations(), (2, 1), "x2's freed, x1's again");
    problem.residuals(&x3).unwrap();
    assert_eq!(
        problem.kept_evaluations(),
        (2, 1),
        "x2 dropped; residuals alone free no gradients"
    );
    problem.release_gradients();
    assert_eq!(problem.kept_evaluations(), (1, 0));
    let solves = problem.row_solves();
    problem.residuals(&x3).unwrap();
    assert_eq!(
        problem.row_solves(),
        solves,
        "the newest evaluation's values kept"
    );
}

#[test]
fn a_problem_is_weighted_only_with_weights() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 10, 1);
    assert!(!problem.is_weighted());
    let weighted = problem.clone().with_weights(&[1.0; 10]);
    assert!(weighted.is_weighted());
    assert!(!weighted.unweighted().is_weighted());
}

/// Each row's solve is warm-started from its solution at the previous evaluation: the problem's
/// solutions at x₂ after x₁ are, bit for bit, Newton's from the x₁ solutions; from home they
/// differ in the last bits on some rows (the start leaves its trace at round-off). On a leg of
/// the generic chain: every bundled leg is solved in closed form, where the start picks only
/// the joints' turn (`tests/it/kernels.rs`), so the 3-RPR's prismatic lines are moved 1 mm
/// beside their base revolutes (no kernel's pattern).
#[test]
fn each_row_is_warm_started_from_its_previous_solution() {
    use legwise::identify::jacobian::PreparedLeg;
    use legwise::kinematics::kernel::LegKernel;
    let mech = bundled("3rpr.yaml").edited(|parts| {
        for leg in &mut parts.legs {
            let prismatic = leg.moving[1];
            leg.joints[prismatic].origin[1] = 1e-3;
        }
    });
    assert!(mech.legs.iter().all(|l| LegKernel::recognise(l).is_none()));
    let problem = leg_problem(&mech, 30, 1);
    let [x1, x2, _] = three_points(&problem);
    problem.residuals(&x1).unwrap();
    problem.residuals(&x2).unwrap();
    let solved = problem.map_solved(&x2, |_, _, _, s| s.q).unwrap();
    let slot = &problem.slots()[0];
    let leg = &mech.legs[slot.leg];
    let at = |x| PreparedLeg::new(leg, &problem.leg_parameters(slot, x), &[]);
    let (first, second) = (at(&x1), at(&x2));
    let home = &mech.home_pose;
    let mut from_home_differs = 0;
    for (block, q) in problem.blocks().iter().zip(&solved) {
        let previous = first.solve_warm(&block.pose, home, None).unwrap();
        let warm = second
            .solve_warm(&block.pose, home, Some(&previous.q))
            .unwrap();
        let cold = second.solve_warm(&block.pose, home, None).unwrap();
        assert_eq!(q.map(f64::to_bits), warm.q.map(f64::to_bits));
        from_home_differs += usize::from(cold.q.map(f64::to_bits) != warm.q.map(f64::to_bits));
    }
    // Measured: 8 of the 30 rows' residuals differ (at most 9e-16).
    assert!(from_home_differs > 0, "no row tells a warm start from home");
}

/// The oldest kept evaluation is dropped before a new one is solved (so that a large problem
/// never holds three): also when that solve fails.
#[test]
fn the_oldest_evaluation_goes_before_the_next_is_solved() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 30, 1);
    let [x1, x2, _] = three_points(&problem);
    problem.residuals(&x1).unwrap();
    problem.residuals(&x2).unwrap();
    assert_eq!(problem.kept_evaluations(), (2, 0));
    let unreachable = &x1 * 0.1; // every length a tenth
    assert!(problem.residuals(&unreachable).is_err());
    assert_eq!(problem.kept_evaluations(), (1, 0));
    let solves = problem.row_solves();
    problem.residuals(&x2).unwrap();
    assert_eq!(problem.row_solves(), solves, "the newer one kept");
}

/// A leg's part of the Jacobian is the Jacobian itself, borrowed, for a problem of one leg; a
/// copy of the leg's rows and columns otherwise, even when the leg has every column (the other
/// leg holding all its parameters).
#[test]
fn a_legs_jacobian_is_borrowed_only_when_it_is_the_whole_jacobian() {
    use std::borrow::Cow;
    let mech = bundled("5r.yaml");
    let single = leg_problem(&mech, 12, 1);
    let (_, c) = single
        .residuals_and_jacobian(&three_points(&single)[0])
        .unwrap();
    let whole = single.slot_jacobian(&single.slots()[0], &c);
    assert!(matches!(whole, Cow::Borrowed(_)));
    assert_eq!(*whole, c);
    let options = SimulationOptions {
        poses_per_leg: Some(12),
        ..Default::default()
    };
    let measurements = simulate(&mech, options).unwrap().measurements;
    let blocks = || {
        let mut blocks = measurements.leg_blocks(0);
        blocks.extend(measurements.leg_blocks(1));
        blocks
    };
    let held = mech.edited(|parts| {
        for p in &mut parts.legs[1].params {
            p.identified = false;
        }
    });
    for mechanism in [&mech, &held] {
        let problem = IdentificationProblem::new(mechanism, &[0, 1], blocks());
        let (_, c) = problem
            .residuals_and_jacobian(&problem.start().map(|v| v * 1.001))
            .unwrap();
        for slot in problem.slots() {
            let part = problem.slot_jacobian(slot, &c);
            assert!(matches!(part, Cow::Owned(_)));
            let rows = problem.rows_of(slot);
            assert_eq!(rows.len(), 12);
            assert!(rows.iter().all(|&i| problem.blocks()[i].leg == slot.leg));
            let expected =
                DMatrix::from_fn(12, slot.columns.len(), |i, j| c[(rows[i], slot.offset + j)]);
            assert_eq!(*part, expected);
        }
    }
}

/// Readings moved by whole turns on every other row, at unknowns whose gain is 1.3 (not ±1,
/// where 2π/k and 2π·k agree): the residuals are the unmoved ones, and the Jacobian, whose gain
/// column carries the turn term n·2π/k², matches central differences.
#[test]
fn the_gain_column_carries_the_turn_term_of_readings_on_another_turn() {
    let mech = bundled("5r.yaml");
    let plain = leg_problem(&mech, 12, 1);
    let slot = &plain.slots()[0];
    let gain = slot
        .columns
        .iter()
        .position(|&c| mech.legs[0].params[c].name == "k1")
        .expect("k1 identified");
    let mut x = plain.start().map(|v| v * (1.0 + 1e-3));
    x[gain] = 1.3;
    let turn = std::f64::consts::TAU / 1.3;
    let blocks: Vec<_> = plain
        .blocks()
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut b = b.clone();
            b.reading += if i % 2 == 0 { turn } else { -2.0 * turn };
            b
        })
        .collect();
    let moved = IdentificationProblem::new(&mech, &[0], blocks);
    let gap = (moved.residuals(&x).unwrap() - plain.residuals(&x).unwrap()).amax();
    assert!(gap < 1e-12, "residuals differ by {gap:e}");
    let (_, jacobian) = moved.residuals_and_jacobian(&x).unwrap();
    assert_central_differences(&moved, &x, &jacobian, "gain 1.3");
}

/// A Jacobian where only the residuals were evaluated adds the derivative passes to the legs
/// prepared for them (kept with the evaluation): the same Jacobian, bit for bit, as a new
/// problem's evaluated with its derivatives at once, on either path (the kept solutions, or a
/// large problem's seeds), and again after the gradients were released.
#[test]
fn a_jacobian_from_the_legs_prepared_for_the_residuals_is_a_fresh_ones() {
    let mech = bundled("5r.yaml");
    for copies in [1, 2200] {
        let problem = leg_problem(&mech, 30, copies);
        let fresh = leg_problem(&mech, 30, copies);
        let [x1, x2, _] = three_points(&problem);
        for x in [&x1, &x2] {
            problem.residuals(x).unwrap();
            let (_, derived) = problem.residuals_and_jacobian(x).unwrap();
            let (_, direct) = fresh.residuals_and_jacobian(x).unwrap();
            let bits = |j: &DMatrix<f64>| j.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&derived), bits(&direct), "{copies} copies");
            problem.release_gradients();
            let (_, again) = problem.residuals_and_jacobian(x).unwrap();
            assert_eq!(bits(&again), bits(&direct), "{copies} copies, released");
        }
    }
}

/// A new evaluation that replaces a kept one (the oldest of the two kept) has a fresh
/// problem's residuals and Jacobian, bit for bit, whether the replaced one held gradients or
/// not, and whether the new one is asked for them at once or later.
#[test]
fn an_evaluation_replacing_a_kept_one_has_a_fresh_ones_values() {
    let mech = bundled("5r.yaml");
    let problem = leg_problem(&mech, 30, 1);
    let [x1, x2, x3] = three_points(&problem);
    let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    problem.residuals_and_jacobian(&x1).unwrap();
    problem.residuals(&x2).unwrap();
    // x3 replaces x1 (its gradients), then x1 replaces x2, then x2 replaces x3.
    for (x, jacobian_at_once) in [(&x3, true), (&x1, false), (&x2, true)] {
        let fresh = leg_problem(&mech, 30, 1);
        let (r, j) = if jacobian_at_once {
            problem.residuals_and_jacobian(x).unwrap()
        } else {
            let r = problem.residuals(x).unwrap();
            (r, problem.residuals_and_jacobian(x).unwrap().1)
        };
        let (r_fresh, j_fresh) = if jacobian_at_once {
            fresh.residuals_and_jacobian(x).unwrap()
        } else {
            let r = fresh.residuals(x).unwrap();
            (r, fresh.residuals_and_jacobian(x).unwrap().1)
        };
        assert_eq!(bits(r.as_slice()), bits(r_fresh.as_slice()));
        assert_eq!(bits(j.as_slice()), bits(j_fresh.as_slice()));
        assert_eq!(problem.kept_evaluations().0, 2);
    }
}
