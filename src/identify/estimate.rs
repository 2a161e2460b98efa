//! Identification of leg parameters: divide and conquer (each leg alone on its own blocks) or
//! traditional (all legs stacked on shared poses). Rank check first, then the solver, then the
//! statistics of the estimate.

use nalgebra::{DMatrix, DVector};

use super::observability::{analyse, Observability};
use super::problem::{BlockError, IdentificationProblem, LegSlot};
use crate::error::{Error, Result};
use crate::measure::MeasurementSet;
use crate::model::params::Unit;
use crate::model::Mechanism;
use crate::solver::{solve, SolverKind};

/// How the legs are grouped into least-squares problems.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Each leg alone, on the poses labelled with it (Durango et al.).
    DivideAndConquer,
    /// All legs in one problem, on the shared poses only.
    Traditional,
}

impl Strategy {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::DivideAndConquer => "divide and conquer",
            Strategy::Traditional => "traditional (all legs)",
        }
    }
}

/// One parameter's estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterEstimate {
    /// Name as in the model file.
    pub name: String,
    /// SI unit.
    pub unit: Unit,
    /// Nominal value.
    pub nominal: f64,
    /// Identified value (the nominal value for a fixed parameter).
    pub estimate: f64,
    /// Standard deviation `σ̂ √diag((CᵀC)⁻¹)`, `None` if fixed or without redundancy.
    pub std: Option<f64>,
    /// Identified (true) or held fixed.
    pub identified: bool,
}

/// One leg's result.
#[derive(Debug, Clone, PartialEq)]
pub struct LegEstimate {
    /// Leg name.
    pub leg: String,
    /// Every parameter of the leg, in model order.
    pub parameters: Vec<ParameterEstimate>,
    /// Number of residual blocks (measured readings) used.
    pub measurements: usize,
    /// ½‖r‖² at the nominal parameters.
    pub initial_cost: f64,
    /// ½‖r‖² at the estimate.
    pub final_cost: f64,
    /// Residual standard deviation σ̂ = √(‖r‖²/(m − n)), if m > n.
    pub residual_sigma: Option<f64>,
    /// Observability of the identification Jacobian at the estimate.
    pub observability: Observability,
}

/// One solver run (one per leg for divide and conquer, one in all for traditional).
#[derive(Debug, Clone, PartialEq)]
pub struct SolverRun {
    /// The legs the run identified.
    pub legs: Vec<String>,
    /// Iterations.
    pub iterations: u64,
    /// Why it stopped.
    pub termination: String,
    /// ½‖r‖² before.
    pub initial_cost: f64,
    /// ½‖r‖² after.
    pub final_cost: f64,
    /// Residual evaluations.
    pub residual_evaluations: u64,
    /// Jacobian evaluations.
    pub jacobian_evaluations: u64,
    /// Wall-clock time of the solver run, seconds.
    pub seconds: f64,
}

/// The result of one strategy.
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyResult {
    /// The strategy.
    pub strategy: Strategy,
    /// The solver.
    pub solver: SolverKind,
    /// Per-leg estimates, in mechanism order.
    pub legs: Vec<LegEstimate>,
    /// Solver runs.
    pub runs: Vec<SolverRun>,
}

/// Identifies the mechanism's parameters from `data` with `strategy` and `solver`.
///
/// # Errors
/// A leg without measurements, a pose a leg cannot reach (naming the file line), a
/// rank-deficient design ([`Error::Unidentifiable`], naming the parameters), or a solver failure.
pub fn identify(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    strategy: Strategy,
    solver: SolverKind,
) -> Result<StrategyResult> {
    let legs = mechanism.legs.len();
    let identified = mechanism.identified_legs();
    if identified.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no parameter is identified (every parameter has `identify: false`)",
            mechanism.model_path.display()
        )));
    }
    let groups: Vec<(Vec<usize>, Vec<_>)> = match strategy {
        Strategy::DivideAndConquer => identified
            .iter()
            .map(|&l| (vec![l], data.leg_blocks(l)))
            .collect(),
        Strategy::Traditional => {
            if data.shared_count() == 0 {
                return Err(Error::Invalid(
                    "the traditional strategy needs shared poses (rows with an empty `leg` column)"
                        .into(),
                ));
            }
            vec![(identified, data.shared_blocks(legs))]
        }
    };
    let mut result = StrategyResult {
        strategy,
        solver,
        legs: Vec::new(),
        runs: Vec::new(),
    };
    for (group, blocks) in groups {
        let problem = IdentificationProblem::new(mechanism, &group, blocks);
        let (estimates, run) = identify_problem(mechanism, data, &problem, solver)?;
        result.legs.extend(estimates);
        result.runs.push(run);
    }
    result.legs.sort_by_key(|e| mechanism.leg_index(&e.leg));
    Ok(result)
}

/// Identifies one problem: rank check, solver, statistics.
///
/// # Errors
/// As [`identify`].
pub fn identify_problem(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    problem: &IdentificationProblem<'_>,
    solver: SolverKind,
) -> Result<(Vec<LegEstimate>, SolverRun)> {
    let names: Vec<String> = problem
        .slots()
        .iter()
        .map(|s| mechanism.legs[s.leg].name.clone())
        .collect();
    for (slot, name) in problem.slots().iter().zip(&names) {
        if problem.rows_of(slot).is_empty() {
            return Err(Error::NoMeasurements {
                file: data.source.clone(),
                leg: name.clone(),
            });
        }
    }
    let x0 = problem.nominal();
    let (r0, c0) = problem
        .residuals_and_jacobian(&x0)
        .map_err(|e| located(mechanism, data, problem, e))?;
    for slot in problem.slots() {
        let observability = leg_observability(mechanism, problem, slot, &c0);
        let n = slot.columns.len();
        if observability.rank < n {
            let rows = problem.rows_of(slot).len();
            let mut params = observability.unidentifiable.join(", ");
            if rows < n {
                params.push_str(&format!(" (only {rows} measurements for {n} parameters)"));
            } else if !observability.null_directions.is_empty() {
                params.push_str(&format!(
                    " (null-space directions, column-scaled: {})",
                    observability.null_directions.join("; ")
                ));
            }
            return Err(Error::Unidentifiable {
                file: data.source.clone(),
                leg: mechanism.legs[slot.leg].name.clone(),
                rank: observability.rank,
                n,
                params,
            });
        }
    }
    let started = std::time::Instant::now();
    let outcome = solve(problem, x0.clone(), solver).map_err(|err| Error::Solver {
        context: format!("legs {}", names.join(", ")),
        message: err.to_string(),
    })?;
    let seconds = started.elapsed().as_secs_f64();
    let (r, c) = problem
        .residuals_and_jacobian(&outcome.x)
        .map_err(|e| located(mechanism, data, problem, e))?;
    if !(r.iter().all(|v| v.is_finite()) && outcome.x.iter().all(|v| v.is_finite())) {
        return Err(Error::Solver {
            context: format!("legs {}", names.join(", ")),
            message: "the estimate is not finite".into(),
        });
    }
    let estimates = problem
        .slots()
        .iter()
        .map(|slot| leg_estimate(mechanism, problem, slot, &outcome.x, &r0, &r, &c))
        .collect();
    let run = SolverRun {
        legs: names,
        iterations: outcome.iterations,
        termination: outcome.termination,
        initial_cost: 0.5 * r0.norm_squared(),
        final_cost: 0.5 * r.norm_squared(),
        residual_evaluations: outcome.residual_evaluations,
        jacobian_evaluations: outcome.jacobian_evaluations,
        seconds,
    };
    Ok((estimates, run))
}

/// The leg's rows and columns of the stacked Jacobian.
fn leg_jacobian(
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    c: &DMatrix<f64>,
) -> DMatrix<f64> {
    let rows = problem.rows_of(slot);
    let n = slot.columns.len();
    DMatrix::from_fn(rows.len(), n, |i, j| c[(rows[i], slot.offset + j)])
}

fn leg_observability(
    mechanism: &Mechanism,
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    c: &DMatrix<f64>,
) -> Observability {
    let names = mechanism.legs[slot.leg].identified_names();
    analyse(&leg_jacobian(problem, slot, c), &names)
}

fn leg_estimate(
    mechanism: &Mechanism,
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    x: &DVector<f64>,
    r0: &DVector<f64>,
    r: &DVector<f64>,
    c: &DMatrix<f64>,
) -> LegEstimate {
    let leg = &mechanism.legs[slot.leg];
    let rows = problem.rows_of(slot);
    let (m, n) = (rows.len(), slot.columns.len());
    let sum_squares: f64 = rows.iter().map(|&i| r[i] * r[i]).sum();
    let residual_sigma = (m > n).then(|| (sum_squares / (m - n) as f64).sqrt());
    let c_leg = leg_jacobian(problem, slot, c);
    let variances =
        residual_sigma.and_then(|sigma| covariance_diagonal(&c_leg).map(|d| (sigma, d)));
    let phi = problem.leg_parameters(slot, x);
    let parameters = leg
        .params
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let column = slot.columns.iter().position(|&c| c == i);
            ParameterEstimate {
                name: p.name.clone(),
                unit: p.unit,
                nominal: p.nominal,
                estimate: phi[i],
                std: column.and_then(|k| variances.as_ref().map(|(s, d)| s * d[k].sqrt())),
                identified: p.identified,
            }
        })
        .collect();
    LegEstimate {
        leg: leg.name.clone(),
        parameters,
        measurements: m,
        initial_cost: 0.5 * rows.iter().map(|&i| r0[i] * r0[i]).sum::<f64>(),
        final_cost: 0.5 * sum_squares,
        residual_sigma,
        observability: leg_observability(mechanism, problem, slot, c),
    }
}

/// diag((CᵀC)⁻¹) from the SVD of C (never an explicit inverse of CᵀC); `None` if rank-deficient.
fn covariance_diagonal(c: &DMatrix<f64>) -> Option<Vec<f64>> {
    let n = c.ncols();
    if c.nrows() < n {
        return None;
    }
    let svd = c.clone().svd(false, true);
    let v_t = svd.v_t?;
    let largest = svd.singular_values.max();
    if svd.singular_values.iter().any(|&s| s <= 1e-14 * largest) {
        return None;
    }
    Some(
        (0..n)
            .map(|i| {
                (0..svd.singular_values.len())
                    .map(|k| (v_t[(k, i)] / svd.singular_values[k]).powi(2))
                    .sum()
            })
            .collect(),
    )
}

/// Turns a failed block into an error naming the measurement file line, or the simulated pose.
fn located(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    problem: &IdentificationProblem<'_>,
    error: BlockError,
) -> Error {
    let block = &problem.blocks()[error.block];
    let pose_text = mechanism.pose_text(&block.pose);
    match (&data.source, block.line) {
        (Some(path), Some(line)) => Error::Measurement {
            path: path.clone(),
            location: format!("line {line}"),
            message: error.source.to_string(),
        },
        _ => Error::Invalid(format!("simulated pose {pose_text}: {}", error.source)),
    }
}

#[cfg(test)]
mod tests {
    use super::covariance_diagonal;
    use nalgebra::DMatrix;

    #[test]
    fn covariance_diagonal_is_the_inverse_of_the_normal_matrix_or_none_when_singular() {
        // CᵀC = [[2, 1], [1, 2]]: (CᵀC)⁻¹ = [[2, −1], [−1, 2]]/3.
        let c = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let d = covariance_diagonal(&c).unwrap();
        assert!((d[0] - 2.0 / 3.0).abs() < 1e-15 && (d[1] - 2.0 / 3.0).abs() < 1e-15);
        let scaled = DMatrix::from_row_slice(3, 2, &[10.0, 0.0, 0.0, 0.5, 0.0, 0.0]);
        let d = covariance_diagonal(&scaled).unwrap();
        assert!((d[0] - 0.01).abs() < 1e-17 && (d[1] - 4.0).abs() < 1e-14);
        // s_min/s_max = 1e-15: singular to working precision, no covariance.
        let singular = DMatrix::from_row_slice(3, 2, &[10.0, 0.0, 0.0, 1e-14, 0.0, 0.0]);
        assert_eq!(covariance_diagonal(&singular), None);
    }
}
