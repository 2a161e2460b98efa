//! Identification of leg parameters: divide and conquer (each leg alone on its own blocks) or
//! traditional (all legs stacked on shared poses). Rank check first, then the solver, then the
//! statistics of the estimate.
//!
//! [`FitOptions`] add weighted least squares by the declared noise, a robust loss
//! ([`super::robust`]) and a refit without the outlier rows; after every fit, each leg's
//! residuals go through [`super::statistics`] (noise test, outliers, turns) and the data
//! through [`crate::measure::checks`]: their findings are the results' `warnings`.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::fit;
use super::observability::{analyse, scaled_rank, Observability};
use super::problem::{BlockError, IdentificationProblem, LegSlot};
use super::sandwich::{self, NoiseLoadings};
use super::solve_from::FitError;
use super::statistics::{self, FitKind, LegStatistics, Outlier};
use crate::error::{Error, Result};
use crate::measure::MeasurementSet;
use crate::model::Mechanism;
use crate::solver::SolverKind;

pub use super::result::{
    FitOptions, LegEstimate, ParameterEstimate, RowResidual, SolverRun, Strategy, StrategyResult,
    Weighting,
};

/// Identifies the mechanism's parameters from `data` with `strategy` and `solver`, by plain
/// least squares ([`FitOptions::default`]).
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
    identify_with(mechanism, data, strategy, solver, FitOptions::default())
}

/// As [`identify`], with weights, a robust loss or outlier dropping.
///
/// # Errors
/// As [`identify`]; also a position far outside the mechanism
/// ([`crate::measure::checks::check`]), and `--weights noise` or `--robust` without a declared
/// non-zero noise.
pub fn identify_with(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    strategy: Strategy,
    solver: SolverKind,
    options: FitOptions,
) -> Result<StrategyResult> {
    let options = options.resolved(mechanism);
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
        Strategy::Joint | Strategy::TwoStage => {
            return Err(Error::Invalid(format!(
                "{}: the {} strategy identifies through an instrument: the model needs an \
                 `instrument` block and target coordinates in the measurements",
                mechanism.model_path.display(),
                strategy.name()
            )))
        }
    };
    let prior = mechanism
        .identified_legs()
        .iter()
        .flat_map(|&l| &mechanism.legs[l].params)
        .find(|p| p.identified && p.prior.is_some());
    if let Some(calibration) = &mechanism.prior_covariance {
        return Err(Error::Invalid(format!(
            "--prior {}: the {} strategy fits each leg's readings at measured poses without \
             priors; a previous calibration is taken by the joint fit through an instrument",
            calibration.source.display(),
            strategy.name()
        )));
    }
    if let Some(p) = prior {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: format!("prior of `{}`", p.name),
            message: format!(
                "the {} strategy fits each leg's readings at measured poses without priors; \
                 priors are taken by the joint fit through an instrument and by `legwise sets`: \
                 remove the prior, or hold the parameter (`identify: false`)",
                strategy.name()
            ),
        });
    }
    let mut result = StrategyResult {
        strategy,
        solver,
        legs: Vec::new(),
        runs: Vec::new(),
        options,
        warnings: crate::measure::checks::check(mechanism, data)?,
        instrument: None,
    };
    // The groups in parallel (rayon); results in group order, the first error in group order.
    let fits: Vec<Result<_>> = groups
        .into_par_iter()
        .map(|(group, blocks)| {
            let problem = IdentificationProblem::new(mechanism, &group, blocks);
            identify_problem(mechanism, data, &problem, solver, options)
        })
        .collect();
    for fit in fits {
        let (estimates, run) = fit?;
        result.legs.extend(estimates);
        result.runs.push(run);
    }
    result.legs.sort_by_key(|e| mechanism.leg_index(&e.leg));
    Ok(result)
}

/// Identifies one problem: rank check, solver, statistics. A least-squares fit's outliers are
/// those that stay outliers once the worse ones are gone (each refitted without the worst, as
/// docs/statistics.md describes); with
/// [`FitOptions::drop_outliers`] the result is the fit without them.
///
/// # Errors
/// As [`identify_with`].
pub fn identify_problem(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    problem: &IdentificationProblem<'_>,
    solver: SolverKind,
    options: FitOptions,
) -> Result<(Vec<LegEstimate>, SolverRun)> {
    let options = options.resolved(mechanism);
    let (mut estimates, run) = estimate_problem(mechanism, data, problem, solver, options)?;
    if options.robust.is_some() {
        return Ok((estimates, run));
    }
    let Some((confirmed, refit)) =
        confirmed_outliers(mechanism, data, problem, solver, options, &estimates)?
    else {
        return Ok((estimates, run));
    };
    // The first fit's outliers, but the rows a worse one only dragged along.
    for (estimate, slot) in estimates.iter_mut().zip(problem.slots()) {
        let stats = &mut estimate.statistics;
        let keep: Vec<bool> = stats
            .outlier_rows
            .iter()
            .map(|r| confirmed.contains(r))
            .collect();
        let mut kept = keep.iter();
        stats.outliers.retain(|_| *kept.next().unwrap_or(&false));
        stats.outlier_rows.retain(|r| confirmed.contains(r));
        estimate.warnings = leg_warnings(mechanism, slot, stats);
    }
    if options.drop_outliers && !confirmed.is_empty() {
        return Ok(dropped(refit, estimates));
    }
    Ok((estimates, run))
}

/// The rows the fit `first` of `problem` flags as outliers that stay outliers once the worse
/// ones are gone: the worst flagged row (largest |t|) is set aside and the problem refitted,
/// then the worst of the first fit's flagged rows that the refit still flags, and so on. A gross
/// error on a high-leverage row drags its neighbours' residuals beyond the threshold too
/// (swamping); the refit without it does not flag them. The confirmed rows (worst first) and the
/// last refit (without them); `None` when the first fit flags no row, or when a refit fails
/// without [`FitOptions::drop_outliers`] (the first fit's flags then stand).
///
/// # Errors
/// As [`identify_with`], for a refit with [`FitOptions::drop_outliers`].
fn confirmed_outliers(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    problem: &IdentificationProblem<'_>,
    solver: SolverKind,
    options: FitOptions,
    first: &[LegEstimate],
) -> Result<Option<(Vec<usize>, Fitted)>> {
    // A fit's flagged rows (indices of the rows it was given) with their |t|.
    let flagged = |estimates: &[LegEstimate]| -> Vec<(usize, f64)> {
        let legs = estimates.iter().map(|e| &e.statistics);
        let pairs = legs.flat_map(|s| s.outlier_rows.iter().copied().zip(&s.outliers));
        // A reading out of range is set aside first, whatever its |t| in a fit it distorts.
        let weight = |o: &Outlier| {
            if o.out_of_range {
                f64::INFINITY
            } else {
                o.t.abs()
            }
        };
        pairs.map(|(row, o)| (row, weight(o))).collect()
    };
    let candidates: Vec<usize> = flagged(first).into_iter().map(|(row, _)| row).collect();
    let all: Vec<usize> = (0..problem.blocks().len()).collect();
    let (mut current, mut alive) = (flagged(first), all.clone());
    let mut confirmed = Vec::new();
    let mut refit = None;
    loop {
        let worst = current
            .iter()
            .map(|&(row, t)| (alive[row], t))
            .filter(|(row, _)| candidates.contains(row))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((row, _)) = worst else { break };
        confirmed.push(row);
        let reduced = problem.without_rows(&confirmed);
        alive = all
            .iter()
            .copied()
            .filter(|i| !confirmed.contains(i))
            .collect();
        let fit = match estimate_problem(mechanism, data, &reduced, solver, options) {
            Ok(fit) => fit,
            // Without the row the problem cannot be fitted (too few rows left, say): the
            // first fit's flags stand, and only dropping them is an error.
            Err(_) if !options.drop_outliers => return Ok(None),
            Err(e) => return Err(e),
        };
        current = flagged(&fit.0);
        refit = Some(fit);
    }
    Ok(refit.map(|fit| (confirmed, fit)))
}

/// A problem's leg estimates and its solver run.
type Fitted = (Vec<LegEstimate>, SolverRun);

/// Fits one problem and estimates its legs: rank check, solver, statistics.
///
/// # Errors
/// As [`identify_with`].
fn estimate_problem(
    mechanism: &Mechanism,
    data: &MeasurementSet,
    problem: &IdentificationProblem<'_>,
    solver: SolverKind,
    options: FitOptions,
) -> Result<Fitted> {
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
    let x0 = problem.start();
    let (r0_start, c0) = problem
        .residuals_and_jacobian(&x0)
        .map_err(|e| located(mechanism, data, problem, e))?;
    // The residuals at the start, unweighted (all a problem given here has), for the
    // fitted problem's initial cost without solving every row at the start again.
    let r0_unweighted = (!problem.is_weighted()).then_some(r0_start);
    for slot in problem.slots() {
        let n = slot.columns.len();
        let jacobian = problem.slot_jacobian(slot, &c0);
        // The rank alone first: the full analysis only names what a deficient leg misses.
        if scaled_rank(&jacobian).is_some_and(|rank| rank >= n) {
            continue;
        }
        let observability = analyse(&jacobian, &mechanism.legs[slot.leg].identified_names());
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
    drop(c0);
    let noise = options.expected_noise(mechanism);
    let started = std::time::Instant::now();
    let fitted = fit::fit(problem, &x0, solver, options, noise.as_ref()).map_err(|e| match e {
        FitError::Block(e) => located(mechanism, data, problem, e),
        FitError::Solver(message) => Error::Solver {
            context: format!("legs {}", names.join(", ")),
            message,
        },
        FitError::NeedsNoise(option) => Error::Model {
            path: mechanism.model_path.clone(),
            field: "noise".into(),
            message: format!(
                "{option} needs the measurement noise: add a `noise:` block with non-zero \
                 standard deviations (e.g. `noise: {{x: 1.0e-4, y: 1.0e-4, readings: 1.0e-4}}`)"
            ),
        },
    })?;
    let (outcome, kind) = (fitted.outcome, fitted.kind);
    let problem = &fitted.problem;
    let r0 = match r0_unweighted {
        // The same numbers as `problem.residuals(&x0)`: each row scaled by its `√w`.
        Some(raw) => DVector::from_fn(raw.len(), |i, _| problem.row_scale(i) * raw[i]),
        None => problem
            .residuals(&x0)
            .map_err(|e| located(mechanism, data, problem, e))?,
    };
    let seconds = started.elapsed().as_secs_f64();
    let (r, c) = problem
        .residuals_and_jacobian(&outcome.x)
        .map_err(|e| located(mechanism, data, problem, e))?;
    // A non-finite estimate cannot get here (the inverse kinematics refuses non-finite
    // parameters); a residual that is not finite would be a silent NaN in every figure below.
    if !r.iter().all(|v| v.is_finite()) {
        return Err(Error::Solver {
            context: format!("legs {}", names.join(", ")),
            message: "the estimate is not finite".into(),
        });
    }
    // Observability is a property of the design: always of the unweighted Jacobian.
    let unweighted = if problem.is_weighted() {
        Some(
            problem
                .unweighted()
                .residuals_and_jacobian(&outcome.x)
                .map_err(|e| located(mechanism, data, problem, e))?,
        )
    } else {
        None
    };
    let (unweighted_r, unweighted_c) = unweighted.as_ref().map_or((&r, &c), |(r, c)| (r, c));
    // Unweighted with a declared noise: the rows' variances differ, and the covariance is the
    // sandwich that allows it.
    let loadings = match (problem.is_weighted(), kind, noise.as_ref()) {
        (false, FitKind::LeastSquares, Some(noise)) => Some(
            statistics::row_loadings(problem, &outcome.x, noise)
                .map_err(|e| located(mechanism, data, problem, e))?,
        ),
        _ => None,
    };
    // A robust fit's covariance: the declared-noise weighted one at its estimate (each row's
    // residual and Jacobian over its σ), times the loss's variance factor.
    let mut robust = match (kind, options.robust, noise.as_ref()) {
        (FitKind::Robust, Some(loss), Some(noise)) => {
            let v = statistics::row_variances(&problem.unweighted(), &outcome.x, noise)
                .map_err(|e| located(mechanism, data, problem, e))?;
            let r = DVector::from_fn(v.len(), |i, _| unweighted_r[i] / v[i].sqrt());
            let c = DMatrix::from_fn(v.len(), unweighted_c.ncols(), |i, j| {
                unweighted_c[(i, j)] / v[i].sqrt()
            });
            Some((loss.variance_factor(), r, c))
        }
        _ => None,
    };
    problem.release_gradients();
    let mut estimates = Vec::new();
    for slot in problem.slots() {
        let evaluated = ((&r, &c), (unweighted_r, unweighted_c));
        let stats =
            statistics::leg_statistics(problem, slot, &outcome.x, evaluated, noise.as_ref(), kind)
                .map_err(|e| located(mechanism, data, problem, e))?;
        // A robust fit's σ̂ (and so its standard deviations) leaves its outliers out.
        let excluded: &[usize] = match kind {
            FitKind::Robust => &stats.outlier_rows,
            FitKind::LeastSquares => &[],
        };
        let declared = problem.is_weighted() && kind == FitKind::LeastSquares;
        let (residual_sigma, covariance, dof) = match &mut robust {
            Some((factor, gls_r, gls_c)) => {
                let residual_sigma =
                    leg_covariance(problem, slot, (&r, &c), excluded, (None, false)).0;
                // The outliers, at full weight here, leave the leg's Jacobian (each row is one
                // leg's: no other leg reads it).
                for &i in excluded {
                    gls_c.row_mut(i).fill(0.0);
                }
                let (_, covariance, dof) =
                    leg_covariance(problem, slot, (gls_r, gls_c), excluded, (None, true));
                let factor = *factor;
                (residual_sigma, covariance.map(|v| v * factor), dof)
            }
            None => leg_covariance(
                problem,
                slot,
                (&r, &c),
                excluded,
                (loadings.as_ref(), declared),
            ),
        };
        let fit = Fit {
            x: &outcome.x,
            r0: &r0,
            r: &r,
            unweighted_r,
            unweighted_c,
        };
        let covariance = (covariance, dof);
        let mut estimate = leg_estimate(mechanism, problem, slot, &fit, residual_sigma, covariance);
        estimate.statistics = stats;
        estimate.warnings = leg_warnings(mechanism, slot, &estimate.statistics);
        estimates.push(estimate);
    }
    let run = SolverRun::new(names, &outcome, (&r0, &r), seconds);
    Ok((estimates, run))
}

fn leg_observability(
    mechanism: &Mechanism,
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    c: &DMatrix<f64>,
) -> Observability {
    let names = mechanism.legs[slot.leg].identified_names();
    analyse(&problem.slot_jacobian(slot, c), &names)
}

/// A fitted problem's estimate, its residuals at the start and at the estimate (as fitted),
/// and its unweighted residuals and Jacobian at the estimate.
pub(super) struct Fit<'f> {
    pub(super) x: &'f DVector<f64>,
    pub(super) r0: &'f DVector<f64>,
    pub(super) r: &'f DVector<f64>,
    pub(super) unweighted_r: &'f DVector<f64>,
    pub(super) unweighted_c: &'f DMatrix<f64>,
}

/// The σ̂ of the leg in `slot` (its rows of `r` but the `excluded` ones), its covariance from
/// its block of the Jacobian `c` and the degrees of freedom `m − n` of σ̂; `None` without
/// redundancy. The covariance is `σ̂² (CᵀC)⁻¹`, or with the `loadings` of a declared noise on
/// an unweighted fit the sandwich of [`super::sandwich`]. With a declared noise (`loadings`, or
/// `weighted` by it: `C` then the weighted Jacobian, and `σ̂ = 1` when the noise holds) and
/// fewer than [`sandwich::SCALE_DOF`] degrees of freedom the σ are the declared noise's,
/// unscaled by σ̂, and no degrees of freedom are returned.
fn leg_covariance(
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    (r, c): (&DVector<f64>, &DMatrix<f64>),
    excluded: &[usize],
    (loadings, weighted): (Option<&NoiseLoadings>, bool),
) -> (Option<f64>, Option<DMatrix<f64>>, Option<usize>) {
    let n = slot.columns.len();
    let kept: Vec<usize> = problem
        .rows_of(slot)
        .into_iter()
        .filter(|i| !excluded.contains(i))
        .collect();
    let kept_squares: f64 = kept.iter().map(|&i| r[i] * r[i]).sum();
    let residual_sigma = (kept.len() > n).then(|| (kept_squares / (kept.len() - n) as f64).sqrt());
    let covariance = match loadings {
        // The leg's rows (a least-squares fit excludes none), each its own measurement.
        Some(loadings) => residual_sigma.and_then(|_| {
            let leg_r = DVector::from_iterator(kept.len(), kept.iter().map(|&i| r[i]));
            let rows = kept.iter().enumerate();
            let leg_loadings = NoiseLoadings {
                reading: loadings.reading,
                rows: rows
                    .map(|(k, &i)| (k, loadings.rows[i].1.clone()))
                    .collect(),
                also: Vec::new(),
            };
            sandwich::reported_covariance(
                &leg_r,
                &problem.slot_jacobian(slot, c),
                Some(&leg_loadings),
            )
        }),
        None => residual_sigma.and_then(|sigma| {
            let scale = match weighted && !sandwich::scaled_by_residuals(kept.len() - n) {
                true => 1.0,
                false => sigma * sigma,
            };
            unscaled_covariance(&problem.slot_jacobian(slot, c)).map(|inverse| inverse * scale)
        }),
    };
    let declared = loadings.is_some() || weighted;
    let dof = kept
        .len()
        .checked_sub(n)
        .filter(|&d| d > 0)
        .filter(|&d| !declared || sandwich::scaled_by_residuals(d));
    (residual_sigma, covariance, dof)
}

/// The leg in `slot`'s part of a fitted problem: its parameters (σ from the diagonal of
/// `covariance`, the leg's block of the estimate's covariance, on `dof` degrees of freedom), its rows' costs at the start
/// and at the estimate, their residuals (measured minus predicted reading, unweighted) and the
/// observability of its own columns of the unweighted Jacobian.
pub(super) fn leg_estimate(
    mechanism: &Mechanism,
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    fit: &Fit<'_>,
    residual_sigma: Option<f64>,
    (covariance, dof): (Option<DMatrix<f64>>, Option<usize>),
) -> LegEstimate {
    let leg = &mechanism.legs[slot.leg];
    let rows = problem.rows_of(slot);
    let cost = |r: &DVector<f64>| 0.5 * rows.iter().map(|&i| r[i] * r[i]).sum::<f64>();
    let phi = problem.leg_parameters(slot, fit.x);
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
                std: column.and_then(|k| covariance.as_ref().map(|v| v[(k, k)].max(0.0).sqrt())),
                identified: p.identified,
                degrees_of_freedom: column.and(covariance.as_ref()).and(dof),
                prior: column.and_then(|k| problem.prior_sigma(slot.offset + k)),
                // Set by the fit that took the prior (`shared_estimate`).
                data_share: None,
            }
        })
        .collect();
    LegEstimate {
        leg: leg.name.clone(),
        parameters,
        measurements: rows.len(),
        initial_cost: cost(fit.r0),
        final_cost: cost(fit.r),
        residual_sigma,
        observability: leg_observability(mechanism, problem, slot, fit.unweighted_c),
        statistics: LegStatistics::default(),
        dropped: Vec::new(),
        warnings: Vec::new(),
        covariance,
        residuals: rows
            .iter()
            .map(|&i| RowResidual {
                line: problem.blocks()[i].line,
                // Unweighted: a robust fit may give a row zero weight.
                residual: -fit.unweighted_r[i],
            })
            .collect(),
    }
}

/// The statistics' warnings for the leg in `slot`.
fn leg_warnings(mechanism: &Mechanism, slot: &LegSlot, stats: &LegStatistics) -> Vec<String> {
    let leg = &mechanism.legs[slot.leg];
    let unit = if leg.actuated_is_revolute() {
        "rad"
    } else {
        "m"
    };
    let joint = &leg.joints[leg.moving[leg.actuated]].name;
    statistics::warnings(stats, &leg.name, unit, joint, leg.home_joints[leg.actuated])
}

/// `--drop-outliers`: the refit without the confirmed outliers, which the first fit's
/// `first` estimates list, recorded per leg as dropped.
fn dropped((mut estimates, run): Fitted, first: Vec<LegEstimate>) -> Fitted {
    for (estimate, before) in estimates.iter_mut().zip(first) {
        let mut warnings: Vec<String> = before
            .statistics
            .outliers
            .iter()
            .map(|o| {
                format!(
                    "leg {}: dropped {} (reading {}, studentized residual t = {} in the first \
                     fit) and refitted",
                    estimate.leg,
                    o.place(),
                    o.reading,
                    crate::identify::statistics::figure(o.t)
                )
            })
            .collect();
        warnings.append(&mut estimate.warnings);
        estimate.warnings = warnings;
        estimate.dropped = before.statistics.outliers;
    }
    (estimates, run)
}

/// (CᵀC)⁻¹ = V Σ⁻² Vᵀ from the SVD of C (never an explicit inverse of CᵀC); `None` if
/// rank-deficient.
fn unscaled_covariance(c: &DMatrix<f64>) -> Option<DMatrix<f64>> {
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
    let scaled = DMatrix::from_fn(svd.singular_values.len(), n, |k, i| {
        v_t[(k, i)] / svd.singular_values[k]
    });
    Some(scaled.transpose() * scaled)
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
    use super::unscaled_covariance;
    use nalgebra::DMatrix;

    #[test]
    fn unscaled_covariance_is_the_inverse_of_the_normal_matrix_or_none_when_singular() {
        // CᵀC = [[2, 1], [1, 2]]: (CᵀC)⁻¹ = [[2, −1], [−1, 2]]/3.
        let c = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let expected = DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 2.0]) / 3.0;
        assert!((unscaled_covariance(&c).unwrap() - expected).amax() < 1e-15);
        let scaled = DMatrix::from_row_slice(3, 2, &[10.0, 0.0, 0.0, 0.5, 0.0, 0.0]);
        let expected = DMatrix::from_row_slice(2, 2, &[0.01, 0.0, 0.0, 4.0]);
        assert!((unscaled_covariance(&scaled).unwrap() - expected).amax() < 1e-14);
        // s_min/s_max = 1e-15: singular to working precision, no covariance.
        let singular = DMatrix::from_row_slice(3, 2, &[10.0, 0.0, 0.0, 1e-14, 0.0, 0.0]);
        assert_eq!(unscaled_covariance(&singular), None);
        // As many rows as columns: (CᵀC)⁻¹ = C⁻¹C⁻ᵀ, with C = [[2, 0], [2, 1]] and
        // C⁻¹ = [[1/2, 0], [−1, 1]].
        let square = DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 2.0, 1.0]);
        let inverse = DMatrix::from_row_slice(2, 2, &[0.5, 0.0, -1.0, 1.0]);
        let expected = &inverse * inverse.transpose();
        assert!((unscaled_covariance(&square).unwrap() - expected).amax() < 1e-14);
        // Fewer rows than columns: no covariance, whatever the row says.
        let wide = DMatrix::from_row_slice(1, 2, &[1.0, 2.0]);
        assert_eq!(unscaled_covariance(&wide), None);
    }
}
