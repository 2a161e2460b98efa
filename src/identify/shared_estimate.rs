//! Identification through the instrument: the rank check on the shared problem's Jacobian,
//! the Schur-complement solve, and the estimates of the legs' and the instrument's parameters.
//!
//! Two strategies: *joint* (every leg's parameters and the instrument's identified ones
//! together, [`SharedProblem`] solved by [`solve_bordered`]) and *two-stage* (first the
//! instrument alone, the legs at their nominal parameters, from the first rows of every leg;
//! then every leg on its own with the instrument held at that registration).

use nalgebra::{DMatrix, DVector};

use super::estimate::ParameterEstimate;
use super::held_test::{held_frame_test, HeldFrameTest};
use super::observability::{analyse, Observability};
use super::shared::SharedProblem;
use super::shared_covariance::standard_deviations;
use super::statistics::{self, figure, NoiseTest};
use crate::error::{Error, Result};
use crate::measure::observations::Observations;
use crate::model::Mechanism;
use crate::solver::bordered::{to_dense, BorderedLeastSquares, DenseView};
use crate::solver::{solve, solve_bordered, SolverKind, SolverOutcome};

/// Rows per leg the two-stage strategy registers the instrument from.
pub const REGISTRATION_ROWS: usize = 6;

/// How the instrument's parameters are identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SharedStrategy {
    /// With the legs, in one problem (Schur complement on the shared parameters).
    Joint,
    /// First the instrument from a few rows with the nominal legs, then the legs on their own.
    TwoStage,
}

impl SharedStrategy {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            SharedStrategy::Joint => "joint (legs and instrument, Schur complement)",
            SharedStrategy::TwoStage => "two-stage (instrument registered first, then D&C)",
        }
    }
}

/// The result of an identification through the instrument.
#[derive(Debug, Clone)]
pub struct SharedEstimate {
    /// The strategy.
    pub strategy: SharedStrategy,
    /// Per identified leg: its index and every parameter's estimate (model order).
    pub legs: Vec<(usize, Vec<ParameterEstimate>)>,
    /// Every instrument parameter's estimate (the instrument's order).
    pub shared: Vec<ParameterEstimate>,
    /// The solver's outcome (of the last stage for the two-stage strategy).
    pub outcome: SolverOutcome,
    /// Rows (residuals) of the problem.
    pub rows: usize,
    /// Unknowns of the problem (all stages' last).
    pub unknowns: usize,
    /// RMS residual at the estimate (reading units).
    pub rms: f64,
    /// Observability of the joint problem's Jacobian at the start.
    pub observability: Observability,
    /// Wall-clock seconds of the solve.
    pub seconds: f64,
    /// The χ² test of the residuals against the declared noise (propagated from the target
    /// coordinates through the pose fit), if the model declares one.
    pub noise_test: Option<NoiseTest>,
    /// The likelihood-ratio test of the frame components the model holds (joint strategy,
    /// when they can be freed and a noise is declared).
    pub held_frame: Option<HeldFrameTest>,
}

/// The reasons the results must not be trusted (empty: nothing found), one line each: a solve
/// that did not converge, a non-finite value, residuals that reject the declared noise.
pub fn trust_issues(results: &[SharedEstimate]) -> Vec<String> {
    let mut issues = Vec::new();
    for result in results {
        let strategy = result.strategy.name();
        if !result.outcome.converged {
            issues.push(format!(
                "{strategy}: the solver did not converge ({}) after {} iterations; the estimate \
                 must not be trusted",
                result.outcome.stop_reason, result.outcome.iterations
            ));
        }
        let values = result
            .legs
            .iter()
            .flat_map(|(_, p)| p)
            .chain(&result.shared);
        for p in values {
            if !(p.estimate.is_finite() && p.std.is_none_or(f64::is_finite)) {
                issues.push(format!("{strategy}: {} is not a finite number", p.name));
            }
        }
        if let Some(test) = result.noise_test.as_ref().filter(|t| t.rejected) {
            issues.push(format!(
                "{strategy}: the residuals reject the declared noise (σ̂ {} times the declared \
                 scatter, χ² p = {:.2e}): check the instrument frame and targets (are the right \
                 ones identified?), the units, the outliers and the model",
                figure(test.sigma_ratio),
                test.p_value
            ));
        }
        if let Some(test) = result.held_frame.as_ref().filter(|t| t.rejected) {
            issues.push(format!(
                "{strategy}: the held instrument frame ({}) disagrees with the measurements: \
                 freeing it lowers χ² by {:.1} on {} dof (p = {:.2e}); identify it \
                 (`instrument.frame.identify`) or correct the values held",
                test.freed.join(", "),
                test.chi_squared_drop,
                test.degrees_of_freedom,
                test.p_value
            ));
        }
    }
    issues
}

/// The dense Jacobian of `problem` at `x`.
fn dense(problem: &SharedProblem<'_>, x: &DVector<f64>) -> Result<(DVector<f64>, DMatrix<f64>)> {
    let blocks = problem
        .bordered(x)
        .map_err(|e| Error::Invalid(format!("the legs and the instrument: {e}")))?;
    Ok(to_dense(&problem.layout(), &blocks))
}

/// The rank check of `problem` at its start: an error naming the parameters and the null
/// directions (column-scaled) when its Jacobian is rank-deficient.
///
/// # Errors
/// [`Error::Invalid`] naming the parameters and directions when rank-deficient; the problem's
/// evaluation error.
pub fn check_rank(problem: &SharedProblem<'_>, source: &Observations) -> Result<Observability> {
    let x0 = problem.start();
    let (_, jacobian) = dense(problem, &x0)?;
    let names = problem.names();
    let observability = analyse(&jacobian, &names);
    if observability.rank < names.len() {
        let file = source
            .source
            .as_ref()
            .map_or(String::new(), |p| format!("{}: ", p.display()));
        return Err(Error::Invalid(format!(
            "{file}legs and instrument: rank-deficient identification: rank {} of {} \
             parameters; cannot be identified: {} (null-space directions, column-scaled: {}); \
             hold at their nominal values the base joints that define the base frame, the \
             attachments or target offsets that define the platform frame (docs/models.md, \
             \"What to hold\")",
            observability.rank,
            names.len(),
            observability.unidentifiable.join(", "),
            observability.null_directions.join("; ")
        )));
    }
    Ok(observability)
}

/// Identifies the legs and the instrument from `observations` with `strategy`.
///
/// # Errors
/// No instrument, a leg without rows, a rank-deficient problem, a pose a leg cannot reach at
/// the start, or a solver failure.
pub fn identify_shared(
    mechanism: &Mechanism,
    observations: &Observations,
    strategy: SharedStrategy,
) -> Result<SharedEstimate> {
    let problem = SharedProblem::new(mechanism, observations)?;
    let observability = check_rank(&problem, observations)?;
    let started = std::time::Instant::now();
    let (problem, outcome) = match strategy {
        SharedStrategy::Joint => {
            let outcome = solve_bordered(&problem, problem.start()).map_err(solver_error)?;
            (problem, outcome)
        }
        SharedStrategy::TwoStage => {
            let registration = problem.with_legs_fixed().with_rows(REGISTRATION_ROWS);
            let first = solve(
                &DenseView(&registration),
                registration.start(),
                SolverKind::LevenbergMarquardt,
            )
            .map_err(solver_error)?;
            let frame = registration.shared_values(&first.x);
            let legs = problem.with_shared_fixed(&frame);
            let outcome = solve_bordered(&legs, legs.start()).map_err(solver_error)?;
            (legs, outcome)
        }
    };
    let seconds = started.elapsed().as_secs_f64();
    let (r, jacobian) = dense(&problem, &outcome.x)?;
    if !r.iter().chain(outcome.x.iter()).all(|v| v.is_finite()) {
        return Err(solver_error("the estimate is not finite"));
    }
    let (m, n) = jacobian.shape();
    let noise = mechanism
        .noise
        .filter(|n| n.reading > 0.0 || n.pose.iter().any(|&s| s > 0.0));
    let loadings = match noise {
        Some(noise) => Some(
            problem
                .noise_loadings(&outcome.x, &noise)
                .map_err(solver_error)?,
        ),
        None => None,
    };
    let sigmas = standard_deviations(&r, &jacobian, loadings.as_ref());
    let noise_test = loadings
        .as_ref()
        .and_then(|l| statistics::noise_test(r.as_slice(), &l.variances(), n, 0));
    let mut column = 0;
    let mut next = |identified: bool| {
        identified.then(|| {
            column += 1;
            sigmas.as_ref().map(|s| s[column - 1])
        })
    };
    let phis = problem.leg_parameters(&outcome.x);
    let legs = problem
        .legs()
        .into_iter()
        .zip(&phis)
        .map(|(l, phi)| {
            let leg = &mechanism.legs[l];
            let estimates = leg
                .params
                .iter()
                .zip(phi)
                .map(|(p, &value)| {
                    let identified = p.identified;
                    ParameterEstimate {
                        name: p.name.clone(),
                        unit: p.unit,
                        nominal: p.nominal,
                        estimate: value,
                        std: next(identified).flatten(),
                        identified,
                    }
                })
                .collect();
            (l, estimates)
        })
        .collect();
    let values = problem.shared_values(&outcome.x);
    let identified_shared = problem.shared_columns().to_vec();
    let instrument = problem.instrument();
    let shared = instrument
        .parameters
        .iter()
        .enumerate()
        .map(|(k, p)| {
            // Estimated here, or registered by the first stage (no σ of its own then).
            let std = if identified_shared.contains(&k) {
                next(true).flatten()
            } else {
                None
            };
            ParameterEstimate {
                name: p.name.clone(),
                unit: p.unit,
                nominal: p.nominal,
                estimate: values[k],
                std,
                identified: p.identified,
            }
        })
        .collect();
    let mut estimate = SharedEstimate {
        strategy,
        legs,
        shared,
        outcome,
        rows: m,
        unknowns: n,
        rms: (r.norm_squared() / m.max(1) as f64).sqrt(),
        observability,
        seconds,
        noise_test,
        held_frame: None,
    };
    if strategy == SharedStrategy::Joint {
        estimate.held_frame = held_frame_test(mechanism, observations, &estimate);
    }
    Ok(estimate)
}

fn solver_error(error: impl std::fmt::Display) -> Error {
    Error::Solver {
        context: "legs and instrument".into(),
        message: error.to_string(),
    }
}
