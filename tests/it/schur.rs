//! The Schur-complement Levenberg–Marquardt solver of bordered problems
//! (`legwise::solver::schur`): its damped step against an independent dense solve of the same
//! normal equations, and whole solves of exactly fitting nonlinear problems (several decays
//! sharing an offset and a drift) against the known parameters and the dense
//! Levenberg–Marquardt solver.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use argmin::core::{Error, Jacobian, Operator};
use legwise::solver::bordered::{to_dense, BorderedBlock, BorderedLayout, BorderedLeastSquares};
use legwise::solver::schur::arrowhead::ArrowheadSystem;
use legwise::solver::{solve, solve_bordered, solve_bordered_within, SolverKind, StopReason};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random blocks: group `k` has `rows[k]` rows, `own[k]` own and `shared` shared columns.
fn random_blocks(
    rng: &mut ChaCha8Rng,
    rows: &[usize],
    layout: &BorderedLayout,
) -> Vec<BorderedBlock> {
    let mut entry = || rng.random_range(-1.0..1.0);
    rows.iter()
        .zip(&layout.own)
        .map(|(&m, &n)| BorderedBlock {
            residuals: DVector::from_fn(m, |_, _| entry()),
            own: DMatrix::from_fn(m, n, |_, _| entry()),
            shared: DMatrix::from_fn(m, layout.shared, |_, _| entry()),
        })
        .collect()
}

/// `(JᵀJ + λD²) p = Jᵀr` on the dense assembly, by LU.
fn dense_step(
    layout: &BorderedLayout,
    blocks: &[BorderedBlock],
    lambda: f64,
    scale: &DVector<f64>,
) -> DVector<f64> {
    let (r, j) = to_dense(layout, blocks);
    let mut normal = j.transpose() * &j;
    for (i, d) in scale.iter().enumerate() {
        normal[(i, i)] += lambda * d * d;
    }
    normal.lu().solve(&(j.transpose() * r)).expect("regular")
}

fn relative_difference(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

/// 1–8 groups, 0–3 shared and 1–8 own unknowns per group, square to tall blocks, several
/// damping factors and scales: the Schur step is the dense solve to 1e-10.
#[test]
fn the_schur_step_is_the_dense_solve_of_the_damped_normal_equations() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut shapes = 0;
    for groups in 1..=8 {
        for shared in 0..=3 {
            let own: Vec<usize> = (0..groups).map(|_| rng.random_range(1..=8)).collect();
            // Each group's block is at least as tall as its own unknowns plus the shared ones,
            // up to four times taller.
            let rows: Vec<usize> = own
                .iter()
                .map(|&n| rng.random_range(n + shared..=4 * (n + shared)))
                .collect();
            let layout = BorderedLayout { own, shared };
            let blocks = random_blocks(&mut rng, &rows, &layout);
            let scale = DVector::from_fn(layout.unknowns(), |_, _| rng.random_range(0.1..10.0));
            let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
            for lambda in [1e-6, 1e-2, 1.0, 1e3] {
                let schur = system.damped_step(lambda, &scale).unwrap();
                let dense = dense_step(&layout, &blocks, lambda, &scale);
                let difference = relative_difference(&schur, &dense);
                assert!(
                    difference <= 1e-10,
                    "{layout:?} rows {rows:?} λ {lambda}: {difference:e}"
                );
            }
            shapes += 1;
        }
    }
    assert_eq!(shapes, 32);
    // Groups without own unknowns only add to the shared system.
    let layout = BorderedLayout {
        own: vec![0, 3, 0, 2],
        shared: 2,
    };
    let blocks = random_blocks(&mut rng, &[2, 6, 3, 4], &layout);
    let scale = DVector::from_element(layout.unknowns(), 1.5);
    let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
    let schur = system.damped_step(1e-4, &scale).unwrap();
    let dense = dense_step(&layout, &blocks, 1e-4, &scale);
    assert!(relative_difference(&schur, &dense) <= 1e-10);
}

/// Three groups of very different sizes, each strongly coupled to the two shared unknowns:
/// leaving out any one group's contribution to the reduced shared system changes the step by
/// far more than the tolerance (checked on the dense solve with that group's border zeroed),
/// and the Schur step still matches the dense solve to 1e-10.
#[test]
fn every_group_contributes_to_the_reduced_system() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let layout = BorderedLayout {
        own: vec![1, 6, 3],
        shared: 2,
    };
    let rows = [2, 20, 7];
    let blocks = random_blocks(&mut rng, &rows, &layout);
    let scale = DVector::from_element(layout.unknowns(), 1.0);
    let lambda = 1e-3;
    let dense = dense_step(&layout, &blocks, lambda, &scale);
    for k in 0..3 {
        let mut without = blocks.clone();
        without[k].shared.fill(0.0);
        let changed = dense_step(&layout, &without, lambda, &scale);
        assert!(relative_difference(&changed, &dense) > 1e-3, "group {k}");
    }
    let system = ArrowheadSystem::assemble(&layout, &blocks).unwrap();
    let schur = system.damped_step(lambda, &scale).unwrap();
    assert!(relative_difference(&schur, &dense) <= 1e-10);
}

/// One group of decay data `y(t) = a·exp(−b t) + e + c + d·t`: own unknowns `(a, b)`, `(a, b,
/// e)` (an own offset `e`, otherwise 0) or none (then `y = c + d·t`), shared unknowns the first
/// `shared` of `(c, d)`.
#[derive(Clone, Debug)]
struct Group {
    own: usize,
    times: Vec<f64>,
    data: Vec<f64>,
}

/// Several decays sharing an offset and a drift: an exact fit of `truth`.
#[derive(Clone, Debug)]
struct Decays {
    groups: Vec<Group>,
    shared: usize,
    truth: DVector<f64>,
}

impl Decays {
    /// Groups with `own[k]` (0, 2 or 3) own unknowns and `rows[k]` data points, `shared` (0–2)
    /// shared unknowns; true values a_k = 1 + k/2, b_k = 0.3 + 0.2 k, e_k = 0.2, c = 0.7,
    /// d = −0.1.
    fn new(own: &[usize], rows: &[usize], shared: usize) -> Self {
        let mut truth = Vec::new();
        for (k, &n) in own.iter().enumerate() {
            if n >= 2 {
                truth.extend([1.0 + 0.5 * k as f64, 0.3 + 0.2 * k as f64]);
            }
            if n == 3 {
                truth.push(0.2);
            }
        }
        truth.extend(&[0.7, -0.1][..shared]);
        let mut problem = Decays {
            groups: own
                .iter()
                .zip(rows)
                .map(|(&own, &m)| Group {
                    own,
                    times: (0..m).map(|i| 0.25 + 0.5 * i as f64).collect(),
                    data: vec![0.0; m],
                })
                .collect(),
            shared,
            truth: DVector::from_vec(truth),
        };
        let data = problem.model(&problem.truth.clone());
        for (group, values) in problem.groups.iter_mut().zip(data) {
            group.data = values;
        }
        problem
    }

    /// Each group's model values at `x`.
    fn model(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        let layout = self.layout();
        let s = layout.shared_offset();
        let c = if self.shared > 0 { x[s] } else { 0.0 };
        let d = if self.shared > 1 { x[s + 1] } else { 0.0 };
        self.groups
            .iter()
            .enumerate()
            .map(|(k, group)| {
                let o = layout.offset(k);
                group
                    .times
                    .iter()
                    .map(|&t| {
                        let decay = if group.own >= 2 {
                            x[o] * (-x[o + 1] * t).exp()
                        } else {
                            0.0
                        };
                        let offset = if group.own == 3 { x[o + 2] } else { 0.0 };
                        decay + offset + c + d * t
                    })
                    .collect()
            })
            .collect()
    }
}

impl BorderedLeastSquares for Decays {
    fn layout(&self) -> BorderedLayout {
        BorderedLayout {
            own: self.groups.iter().map(|g| g.own).collect(),
            shared: self.shared,
        }
    }

    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        let layout = self.layout();
        let model = self.model(x);
        let blocks = self.groups.iter().enumerate().map(|(k, group)| {
            let m = group.times.len();
            let o = layout.offset(k);
            let residuals = DVector::from_fn(m, |i, _| model[k][i] - group.data[i]);
            let own = DMatrix::from_fn(m, group.own, |i, j| {
                let t = group.times[i];
                let e = (-x[o + 1] * t).exp();
                match j {
                    0 => e,
                    1 => -x[o] * t * e,
                    _ => 1.0,
                }
            });
            let shared =
                DMatrix::from_fn(
                    m,
                    self.shared,
                    |i, j| {
                        if j == 0 {
                            1.0
                        } else {
                            group.times[i]
                        }
                    },
                );
            BorderedBlock {
                residuals,
                own,
                shared,
            }
        });
        Ok(blocks.collect())
    }
}

impl Operator for Decays {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let model = self.model(x);
        let residuals = model
            .iter()
            .zip(&self.groups)
            .flat_map(|(values, g)| values.iter().zip(&g.data).map(|(v, y)| v - y));
        Ok(DVector::from_iterator(
            self.groups.iter().map(|g| g.data.len()).sum(),
            residuals,
        ))
    }
}

/// The same problem as an ordinary dense one, for the dense Levenberg–Marquardt solver.
#[derive(Clone)]
struct Dense(Decays);

impl Operator for Dense {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        self.0.apply(x)
    }
}

impl Jacobian for Dense {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> Result<DMatrix<f64>, Error> {
        Ok(to_dense(&self.0.layout(), &self.0.bordered(x)?).1)
    }
}

/// A start 10–30 % off every true value (alternating signs).
fn perturbed(truth: &DVector<f64>) -> DVector<f64> {
    DVector::from_fn(truth.len(), |i, _| {
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        truth[i] * (1.0 + sign * (0.1 + 0.2 * (i % 3) as f64 / 2.0))
    })
}

fn max_error(x: &DVector<f64>, truth: &DVector<f64>) -> f64 {
    (x - truth).amax()
}

/// Four decays of different lengths and a group with no own unknowns, sharing an offset and a
/// drift: recovered to 1e-10 from a perturbed start, as the dense solver finds to 1e-9.
#[test]
fn shared_decays_are_recovered_and_agree_with_the_dense_solver() {
    let problem = Decays::new(&[2, 2, 0, 2, 2], &[6, 9, 4, 12, 7], 2);
    let x0 = perturbed(&problem.truth);
    let out = solve_bordered(&problem, x0.clone()).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(out.jacobian_evaluations >= 1 && out.residual_evaluations > out.iterations);
    assert!(max_error(&out.x, &problem.truth) <= 1e-10, "{out:?}");
    let dense = solve(&Dense(problem.clone()), x0, SolverKind::LevenbergMarquardt).unwrap();
    assert!(dense.converged, "{dense:?}");
    assert!(max_error(&out.x, &dense.x) <= 1e-9);
}

/// The same decays with data off the model by up to 1e-2 (a non-zero residual at the
/// minimum): both solvers, each followed by the refinement, find the same minimiser to 1e-9,
/// from a start 10–30 % off.
#[test]
fn with_a_misfit_both_solvers_find_the_same_minimiser() {
    let mut problem = Decays::new(&[2, 2, 0, 2], &[7, 9, 5, 11], 2);
    for (k, group) in problem.groups.iter_mut().enumerate() {
        for (i, y) in group.data.iter_mut().enumerate() {
            *y += 1e-2 * ((3 * i + 7 * k) as f64).sin();
        }
    }
    let x0 = perturbed(&problem.truth);
    let out = solve_bordered(&problem, x0.clone()).unwrap();
    let dense = solve(&Dense(problem.clone()), x0, SolverKind::LevenbergMarquardt).unwrap();
    assert!(out.converged && dense.converged, "{out:?} {dense:?}");
    assert!(problem.apply(&out.x).unwrap().norm() > 1e-3);
    assert!(max_error(&out.x, &dense.x) <= 1e-9, "{out:?} {dense:?}");
}

/// No shared unknowns: plain block-diagonal Levenberg–Marquardt, every group recovered.
#[test]
fn without_shared_unknowns_every_group_is_fitted_on_its_own() {
    let problem = Decays::new(&[2, 2, 2], &[5, 8, 6], 0);
    let out = solve_bordered(&problem, perturbed(&problem.truth)).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(max_error(&out.x, &problem.truth) <= 1e-10, "{out:?}");
}

/// A group with one data point for its two own unknowns (rank 1): the solver still reaches an
/// exact fit, with finite parameters, and the well-determined groups and shared unknowns
/// are recovered.
#[test]
fn a_rank_deficient_group_gives_finite_steps_and_an_exact_fit() {
    let problem = Decays::new(&[2, 2, 2], &[8, 1, 9], 2);
    let out = solve_bordered(&problem, perturbed(&problem.truth)).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(out.x.iter().all(|v| v.is_finite()));
    assert!(problem.apply(&out.x).unwrap().norm() <= 1e-12, "{out:?}");
    let determined = [0, 1, 4, 5, 6, 7];
    for i in determined {
        assert!((out.x[i] - problem.truth[i]).abs() <= 1e-9, "{i}: {out:?}");
    }
}

/// Every group has its own offset besides the shared one: only their sums are determined (as
/// an instrument frame and the legs' base joints are not separately observable), so the
/// reduced shared system is singular without damping. The solver still reaches an exact fit
/// with finite parameters, and recovers what is determined: each decay, the drift and every
/// sum of offsets.
#[test]
fn shared_unknowns_not_separable_from_own_ones_give_finite_steps() {
    let problem = Decays::new(&[3, 3, 3], &[8, 9, 10], 2);
    let out = solve_bordered(&problem, perturbed(&problem.truth)).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(out.x.iter().all(|v| v.is_finite()));
    assert!(problem.apply(&out.x).unwrap().norm() <= 1e-12, "{out:?}");
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9;
    for k in 0..3 {
        let o = 3 * k;
        assert!(close(out.x[o], problem.truth[o]), "{out:?}");
        assert!(close(out.x[o + 1], problem.truth[o + 1]), "{out:?}");
        assert!(close(out.x[o + 2] + out.x[9], 0.2 + 0.7), "{out:?}");
    }
    assert!(close(out.x[10], -0.1), "{out:?}");
}

#[test]
fn a_spent_budget_is_not_convergence() {
    let problem = Decays::new(&[2, 2], &[6, 6], 1);
    let out = solve_bordered_within(&problem, perturbed(&problem.truth), 2).unwrap();
    assert_eq!(out.stop_reason, StopReason::EvaluationBudget);
    assert!(!out.converged);
    assert_eq!(out.residual_evaluations, 2);
    assert_eq!(out.refinement_steps, 0);
}

/// [`Decays`] whose residuals fail at the `fail_from`-th evaluation and after (the 1st is
/// the start), until `fail_until`.
#[derive(Clone)]
struct Failing {
    inner: Decays,
    calls: Arc<AtomicU64>,
    fail_from: u64,
    fail_until: u64,
}

impl Operator for Failing {
    type Param = DVector<f64>;
    type Output = DVector<f64>;
    fn apply(&self, x: &DVector<f64>) -> Result<DVector<f64>, Error> {
        let call = self.calls.fetch_add(1, Ordering::SeqCst) + 1;
        if (self.fail_from..self.fail_until).contains(&call) {
            return Err(Error::msg("out of reach"));
        }
        self.inner.apply(x)
    }
}

impl BorderedLeastSquares for Failing {
    fn layout(&self) -> BorderedLayout {
        self.inner.layout()
    }
    fn bordered(&self, x: &DVector<f64>) -> Result<Vec<BorderedBlock>, Error> {
        self.inner.bordered(x)
    }
}

/// Residuals that fail at the first two trial points are rejected steps: the solve goes on,
/// spends two more evaluations than without the failures, and still recovers the truth.
/// Residuals that fail at every trial point end the run unconverged, without an error.
#[test]
fn failing_residuals_at_a_trial_point_are_rejected_steps() {
    let inner = Decays::new(&[2, 2, 2], &[6, 7, 8], 2);
    let x0 = perturbed(&inner.truth);
    let plain = solve_bordered(&inner, x0.clone()).unwrap();
    let failing = Failing {
        inner: inner.clone(),
        calls: Arc::default(),
        fail_from: 2,
        fail_until: 4,
    };
    let out = solve_bordered(&failing, x0.clone()).unwrap();
    assert!(out.converged, "{out:?}");
    assert!(max_error(&out.x, &inner.truth) <= 1e-10);
    assert!(out.residual_evaluations >= plain.residual_evaluations + 2);
    let always = Failing {
        fail_until: u64::MAX,
        ..failing
    };
    always.calls.store(0, Ordering::SeqCst);
    let out = solve_bordered_within(&always, x0.clone(), 500).unwrap();
    assert!(!out.converged, "{out:?}");
    assert_eq!(out.x, x0);
}
