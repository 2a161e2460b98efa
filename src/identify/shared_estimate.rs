//! Identification through the instrument: the rank check on the whole problem's Jacobian (the
//! legs' and the instrument's parameter blocks), the Schur-complement solve, and the estimates of the legs' and the instrument's parameters,
//! as the one [`StrategyResult`] of every strategy.
//!
//! Two strategies: [`Strategy::Joint`] (every leg's parameters and the instrument's identified
//! ones together, [`IdentificationProblem::through_instrument`] solved by [`solve_bordered`]) and
//! [`Strategy::TwoStage`] (first the instrument alone, the legs at their nominal parameters, from the first rows of
//! every leg; then every leg on its own with the instrument held at that registration).
//!
//! Each leg's part of the result is its block of the problem: its rows' residuals and costs,
//! the observability of its own columns of the Jacobian at the estimate, and its block of the
//! covariance. The fit's statistics as a whole (rows, RMS, the noise test) are the result's
//! [`InstrumentEstimate`].

use nalgebra::{DMatrix, DVector};

use super::estimate::{leg_estimate, Fit};
use super::gauges::{unseen_motions, STILL};
use super::observability::{analyse, Observability};
use super::problem::IdentificationProblem;
use super::result::{
    FitOptions, InstrumentEstimate, LegEstimate, ParameterEstimate, SolverRun, Strategy,
    StrategyResult, Weighting,
};
use super::robust::{self, RobustError, RobustFit, RobustLoss};
use super::sandwich::{self, reported_and_declared_covariance, reported_covariance};
use super::shared_outliers;
use super::shared_priors::{refuse_priors_without_weights, set_data_shares};
use super::shared_weights::weighted_joint_fit;
use super::statistics::{self, FitKind};
use super::two_stage::TwoStage;
use crate::error::{Error, Result};
use crate::measure::observations::Observations;
use crate::measure::simulate::perturbation_sigma;
use crate::model::Mechanism;
use crate::solver::{solve, solve_bordered, SolverKind, SolverOutcome};

/// Rows per leg the two-stage strategy registers the instrument from.
pub const REGISTRATION_ROWS: usize = 6;

/// The dense Jacobian of `problem` at `x`.
fn dense(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
) -> Result<(DVector<f64>, DMatrix<f64>)> {
    problem.residuals_and_jacobian(x).map_err(located)
}

/// A block's failure at the start or the estimate, located.
fn located(e: super::problem::BlockError) -> Error {
    Error::Invalid(format!(
        "the legs and the instrument: {}: {}",
        e.location, e.source
    ))
}

/// The rank check of `problem` at its start: an error naming the parameters and the null
/// directions (column-scaled) when its Jacobian is rank-deficient.
///
/// # Errors
/// [`Error::Invalid`] naming the parameters and directions when rank-deficient; the problem's
/// evaluation error.
pub fn check_rank(
    problem: &IdentificationProblem<'_>,
    source: &Observations,
) -> Result<Observability> {
    let x0 = problem.start();
    let (_, jacobian) = dense(problem, &x0)?;
    let names = problem.names();
    let mut observability = analyse(&jacobian, &names);
    // Through the forward kinematics: what the observations cannot see, as motions.
    let motions = unseen_motions(problem, &x0, &jacobian);
    if observability.rank < names.len() {
        let file = source
            .source
            .as_ref()
            .map_or(String::new(), |p| format!("{}: ", p.display()));
        let (seen, hint) = match &motions {
            Some(m) => (
                format!(
                    "; the observations cannot see these motions of the reached points: {}; \
                     the least seen after them: {} (column-scaled singular value {:.1e} of \
                     the largest)",
                    m.unseen.join(", "),
                    m.weakest,
                    m.weakest_ratio
                ),
                if m.unseen.iter().any(|u| u.ends_with(STILL)) {
                    "hold one parameter for each unseen motion, one that moves the points that \
                     way (a base joint's coordinate, an actuator offset, the instrument frame's \
                     position), or measure what sees it; a direction moving no reached point \
                     changes parameters that no observation depends on apart (a frame of their \
                     own, such as the platform's: hold one parameter of each such direction, \
                     e.g. the attachments or target offsets that define the platform frame, \
                     among those its null-space direction names) (docs/models.md, \"Forward \
                     observations\")"
                } else {
                    "hold one parameter for each unseen motion, one that moves the points that \
                     way (a base joint's coordinate, an actuator offset, the instrument frame's \
                     position), or measure what sees it (docs/models.md, \"Forward \
                     observations\")"
                },
            ),
            None => (
                String::new(),
                "hold at their nominal values the base joints that define the base frame, the \
                 attachments or target offsets that define the platform frame (docs/models.md, \
                 \"What to hold\")",
            ),
        };
        return Err(Error::Invalid(format!(
            "{file}legs and instrument: rank-deficient identification: rank {} of {} \
             parameters; cannot be identified: {} (null-space directions, column-scaled: {}){seen}; \
             {hint}",
            observability.rank,
            names.len(),
            observability.unidentifiable.join(", "),
            observability.null_directions.join("; ")
        )));
    }
    if let Some(m) = motions.filter(|m| !m.weakest.is_empty()) {
        observability.weakest_direction = format!(
            "{} (moving the reached points by {})",
            observability.weakest_direction, m.weakest
        );
    }
    if !problem.prior_rows().is_empty() {
        // What the data alone cannot see rests on the priors.
        let (_, data) = dense(&problem.without_priors(), &x0)?;
        observability.resting_on_prior = analyse(&data, &names).null_directions;
    }
    Ok(observability)
}

/// Identifies the legs and the instrument from `observations` with `strategy` (joint or
/// two-stage), by Levenberg–Marquardt; `options` give the noise the statistics expect (the
/// fit itself is unweighted). The held-frame test is not run here
/// ([`super::held_test::held_frame_test`]).
///
/// # Errors
/// No instrument, a strategy that does not identify through an instrument, a leg without
/// rows, a rank-deficient problem, a pose a leg cannot reach at the start, or a solver failure.
pub fn identify_shared(
    mechanism: &Mechanism,
    observations: &Observations,
    strategy: Strategy,
    options: FitOptions,
) -> Result<StrategyResult> {
    if !strategy.through_instrument() {
        return Err(Error::Invalid(format!(
            "{}: the model has an instrument block: its legs are identified through it (joint \
             or two-stage), not by {}",
            mechanism.model_path.display(),
            strategy.name()
        )));
    }
    if strategy == Strategy::TwoStage && mechanism.forward_instrument().is_some() {
        return Err(Error::Invalid(format!(
            "{}: the instrument is seen through the forward kinematics, whose rows couple \
             every leg and the instrument: they are identified together (joint), not in two \
             stages",
            mechanism.model_path.display()
        )));
    }
    let problem = IdentificationProblem::through_instrument(mechanism, observations)?
        .with_priors()
        .map_err(Error::Invalid)?;
    refuse_priors_without_weights(mechanism, &problem, strategy, options)?;
    let observability = check_rank(&problem, observations)?;
    let started = std::time::Instant::now();
    let noise = options.expected_noise(mechanism);
    // The joint fit is weighted by the declared noise unless asked not to be; the two-stage
    // one (a comparison) stays unweighted.
    let weigh = strategy == Strategy::Joint && options.weights != Weighting::Unweighted;
    if let Some(loss) = options.robust.filter(|_| strategy == Strategy::Joint) {
        if options.drop_outliers {
            return Err(Error::Invalid(format!(
                "{}: --robust {} and --drop-outliers are two answers to the same rows: a \
                 robust loss weighs outliers down inside the fit, --drop-outliers refits \
                 without them; choose one",
                mechanism.model_path.display(),
                loss.name()
            )));
        }
        if noise.is_none() {
            return Err(Error::Model {
                path: mechanism.model_path.clone(),
                field: "noise".into(),
                message: format!(
                    "--robust {} scales its loss by the measurement noise: add a `noise:` \
                     block with non-zero standard deviations",
                    loss.name()
                ),
            });
        }
    }
    if weigh && options.weights == Weighting::Noise && noise.is_none() {
        return Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "noise".into(),
            message: "--weights noise needs the measurement noise: add a `noise:` block with \
                      non-zero standard deviations"
                .into(),
        });
    }
    // `√w` of every residual when the fit is weighted (by the noise, or 0 for a dropped row),
    // and whether by the declared noise.
    let mut scales: Option<Vec<f64>> = None;
    let mut noise_weighted = false;
    let mut dropped = Vec::new();
    // The loss of a robust joint fit (the two-stage comparison stays least squares).
    let robust = options.robust.filter(|_| strategy == Strategy::Joint);
    let (problem, outcome, registered) = if strategy == Strategy::Joint {
        let fit = |mask: Option<&[f64]>| -> Result<(SolverOutcome, Option<Vec<f64>>, bool)> {
            if let (Some(noise), true) = (&noise, weigh) {
                let start = problem.start();
                if let Some(fit) =
                    weighted_joint_fit(&problem, &start, noise, mask).map_err(solver_error)?
                {
                    return Ok((fit.outcome, Some(fit.scales), true));
                }
            }
            match mask {
                None => Ok((
                    solve_bordered(&problem, problem.start()).map_err(solver_error)?,
                    None,
                    false,
                )),
                Some(mask) => {
                    let masked = problem.clone().with_weights(mask);
                    let outcome = solve_bordered(&masked, problem.start()).map_err(solver_error)?;
                    Ok((
                        outcome,
                        Some(mask.iter().map(|w| w.sqrt()).collect()),
                        false,
                    ))
                }
            }
        };
        let (mut outcome, mut fitted_scales, mut by_noise) = fit(None)?;
        if let (Some(loss), Some(noise)) = (robust, &noise) {
            // From the least-squares estimate, the loss scaled by each residual's declared σ
            // there.
            let fit = robust_fit(&problem, &outcome.x, loss, noise)?;
            outcome = fit.outcome;
            outcome.x = fit.x;
            // The covariance is the declared-noise weighted one at the robust estimate, times
            // the loss's variance factor (below).
            let variances = problem
                .row_variances(&outcome.x, noise)
                .map_err(solver_error)?;
            fitted_scales = Some(variances.iter().map(|v| 1.0 / v.sqrt()).collect());
            by_noise = true;
        }
        if options.drop_outliers {
            // The first fit's outlier rows, then a refit without every residual of them.
            let (r, jacobian) = dense(&problem, &outcome.x)?;
            let variances = match &noise {
                Some(noise) => problem
                    .row_variances(&outcome.x, noise)
                    .map_err(solver_error)?,
                None => vec![1.0; r.len()],
            };
            let all: Vec<usize> = (0..r.len()).collect();
            let (flagged, _) = shared_outliers::outliers(
                &problem,
                (&r, &jacobian),
                &variances,
                &all,
                FitKind::LeastSquares,
            );
            if !flagged.is_empty() {
                let kept = shared_outliers::kept_residuals(&problem, &flagged);
                let mask: Vec<f64> = (0..r.len())
                    .map(|i| if kept.contains(&i) { 1.0 } else { 0.0 })
                    .collect();
                (outcome, fitted_scales, by_noise) = fit(Some(&mask))?;
                dropped = flagged;
            }
        }
        scales = fitted_scales;
        noise_weighted = by_noise;
        if !noise_weighted && !problem.prior_rows().is_empty() {
            return Err(Error::Model {
                path: mechanism.model_path.clone(),
                field: "noise".into(),
                message: "a prior is weighed against the data by the declared noise, and some \
                          row's declared variance is zero: declare a non-zero noise for every \
                          measured coordinate"
                    .into(),
            });
        }
        (problem, outcome, None)
    } else {
        let registration = problem.with_legs_fixed().with_rows(REGISTRATION_ROWS);
        let first = solve(
            &registration,
            registration.start(),
            SolverKind::LevenbergMarquardt,
        )
        .map_err(solver_error)?;
        let frame = registration.shared_values(&first.x);
        let legs = problem.with_shared_fixed(&frame);
        let outcome = solve_bordered(&legs, legs.start()).map_err(solver_error)?;
        let rows = problem.first_rows(REGISTRATION_ROWS);
        let departure = departure_sigmas(mechanism, &legs);
        let covariance = TwoStage {
            full: &problem,
            registration: &registration,
            rows: &rows,
            frame: &first.x,
            legs: &outcome.x,
            departure: &departure,
        }
        .covariance(noise.as_ref())
        .map_err(|e| solver_error(format!("{}: {}", e.location, e.source)))?;
        (legs, outcome, Some(covariance))
    };
    let seconds = started.elapsed().as_secs_f64();
    let (r, jacobian) = dense(&problem, &outcome.x)?;
    if !r.iter().chain(outcome.x.iter()).all(|v| v.is_finite()) {
        return Err(solver_error("the estimate is not finite"));
    }
    let n = jacobian.ncols();
    let all_loadings = match &noise {
        Some(noise) => Some(
            problem
                .noise_loadings(&outcome.x, noise)
                .map_err(solver_error)?,
        ),
        None => None,
    };
    // The outlier test over the residuals left after a drop; the statistics are of the kept
    // residuals: every one but those of dropped rows and, after a robust fit, of its outliers
    // (as a robust leg fit's σ̂ leaves them out).
    let tested = shared_outliers::kept_residuals(&problem, &dropped);
    let kind = match robust {
        Some(_) => FitKind::Robust,
        None => FitKind::LeastSquares,
    };
    let (outliers, outlier_threshold) = {
        let variances = match &all_loadings {
            Some(l) => l.variances(),
            None => vec![1.0; r.len()],
        };
        shared_outliers::outliers(&problem, (&r, &jacobian), &variances, &tested, kind)
    };
    let kept = match robust {
        Some(_) => {
            let excluded: Vec<_> = dropped.iter().chain(&outliers).cloned().collect();
            shared_outliers::kept_residuals(&problem, &excluded)
        }
        None => tested,
    };
    let m = kept.len();
    let kept_r = DVector::from_iterator(m, kept.iter().map(|&i| r[i]));
    let kept_jacobian = DMatrix::from_fn(m, n, |k, j| jacobian[(kept[k], j)]);
    let loadings = all_loadings.as_ref().map(|l| l.restricted(&kept));
    let scales: Option<Vec<f64>> = scales.map(|s| kept.iter().map(|&i| s[i]).collect());
    // The degrees of freedom of the residuals' scale behind every σ; none when the σ are the
    // declared noise's (too few to scale by, `sandwich::SCALE_DOF`).
    let dof = m
        .checked_sub(n)
        .filter(|&d| d > 0)
        .filter(|&d| loadings.is_none() || sandwich::scaled_by_residuals(d));
    // The joint fit's sandwich (on the weighted rows when weighted); the two-stage one's
    // propagates the registration's error. The declared noise's covariance (not scaled by ŝ): what the data determine, the prior a
    // next calibration takes (`identify --prior`); with priors it says how much of each
    // parameter's information comes from the data.
    let mut declared = None;
    let (covariance, registration) = match registered {
        None => match (&scales, &loadings) {
            (Some(s), Some(l)) if noise_weighted => {
                let weighted_r = DVector::from_fn(m, |i, _| s[i] * kept_r[i]);
                let weighted_jacobian = DMatrix::from_fn(m, n, |i, j| s[i] * kept_jacobian[(i, j)]);
                let weighted_loadings = l.scaled(s);
                // One sandwich for both.
                let both = reported_and_declared_covariance(
                    &weighted_r,
                    &weighted_jacobian,
                    &weighted_loadings,
                );
                let (reported, from_noise) = both.unzip();
                declared = from_noise;
                (reported, None)
            }
            _ => (
                reported_covariance(&kept_r, &kept_jacobian, loadings.as_ref()),
                None,
            ),
        },
        Some(two_stage) => match two_stage {
            Some(c) => (Some(c.legs), Some((c.registration, c.registration_dof))),
            None => (None, None),
        },
    };
    // A robust fit's scatter is its loss's variance factor times the weighted fit's.
    let covariance = match robust {
        Some(loss) => covariance.map(|c| c * loss.variance_factor()),
        None => covariance,
    };
    let sigmas: Option<Vec<f64>> = covariance
        .as_ref()
        .map(|v| v.diagonal().iter().map(|v| v.max(0.0).sqrt()).collect());
    let registration_sigmas: Option<(Vec<f64>, usize)> = registration.map(|(c, dof)| {
        (
            c.diagonal().iter().map(|v| v.max(0.0).sqrt()).collect(),
            dof,
        )
    });
    let noise_test = loadings
        .as_ref()
        .and_then(|l| statistics::noise_test(kept_r.as_slice(), &l.variances(), n, r.len() - m));
    // The residuals at the start, for each leg's cost before (evaluated last: the warm starts
    // of the estimate's evaluations are untouched).
    let r0 = problem.residuals(&problem.start()).map_err(located)?;
    let fit = Fit {
        x: &outcome.x,
        r0: &r0,
        r: &r,
        unweighted_r: &r,
        unweighted_c: &jacobian,
    };
    // Each leg's part: its block of the problem's covariance (no σ̂ of its own).
    let legs: Vec<LegEstimate> = problem
        .slots()
        .iter()
        .map(|slot| {
            let columns = slot.offset..slot.offset + slot.columns.len();
            let block = covariance.as_ref().map(|v| {
                v.view(
                    (columns.start, columns.start),
                    (columns.len(), columns.len()),
                )
                .into_owned()
            });
            leg_estimate(mechanism, &problem, slot, &fit, None, (block, dof))
        })
        .collect();
    let mut legs = legs;
    if let Some(declared) = declared
        .as_ref()
        .filter(|_| !problem.prior_rows().is_empty())
    {
        set_data_shares(&problem, declared, &mut legs);
    }
    let names: Vec<String> = legs.iter().map(|l| l.leg.clone()).collect();
    // The priors' rows come last and are always kept: the data's are the others.
    let data_rows = m - problem.prior_rows().len();
    let instrument = InstrumentEstimate {
        parameters: match &registration_sigmas {
            Some((sigmas, dof)) => registered_parameters(&problem, sigmas, *dof),
            None => instrument_parameters(&problem, &outcome.x, sigmas.as_deref(), dof),
        },
        rows: data_rows,
        unknowns: n,
        rms: (kept_r.rows(0, data_rows).norm_squared() / data_rows.max(1) as f64).sqrt(),
        observability,
        noise_test,
        outliers,
        outlier_threshold,
        dropped,
        held_frame: None,
        // The two-stage covariance is the legs' alone.
        covariance: covariance.clone().filter(|_| strategy == Strategy::Joint),
        declared_covariance: declared.filter(|_| strategy == Strategy::Joint && robust.is_none()),
        predicted_position: None,
    };
    let run = SolverRun::new(names, &outcome, (&r0, &r), seconds);
    let warnings = outlier_warnings(&instrument, strategy, robust);
    Ok(StrategyResult {
        strategy,
        solver: SolverKind::LevenbergMarquardt,
        legs,
        runs: vec![run],
        // Weighted by the declared noise or not, as fitted (unweighted, the covariance is the
        // sandwich of `sandwich` on the plain rows).
        options: FitOptions {
            weights: if noise_weighted {
                Weighting::Noise
            } else {
                Weighting::Unweighted
            },
            robust,
            ..options
        },
        warnings,
        instrument: Some(instrument),
    })
}

/// The warnings naming the outlier rows of a fit through the instrument (weighed down by
/// `robust`'s loss, if any), and the rows dropped.
fn outlier_warnings(
    instrument: &InstrumentEstimate,
    strategy: Strategy,
    robust: Option<RobustLoss>,
) -> Vec<String> {
    let figure = statistics::figure;
    let dropped = instrument.dropped.iter().map(|o| {
        format!(
            "{}: dropped {} (residual {}, studentized residual t = {} in the first fit) and \
             refitted",
            strategy.name(),
            o.place,
            figure(o.residual),
            figure(o.t)
        )
    });
    let remedy = match robust {
        Some(loss) => format!(
            "the {} loss weighs it down and the statistics leave it out",
            loss.name()
        ),
        None => "--drop-outliers refits without it".to_string(),
    };
    let flagged = instrument.outliers.iter().map(|o| {
        format!(
            "{}: outlier {} (residual {}, studentized residual t = {} beyond {}): check that \
             row (a mistyped value, a probe that misfired); {remedy}",
            strategy.name(),
            o.place,
            figure(o.residual),
            figure(o.t),
            instrument.outlier_threshold.map_or("-".into(), figure)
        )
    });
    dropped.chain(flagged).collect()
}

/// The instrument's parameters of `problem` at `x`: estimated (σ from `sigmas`, the
/// problem's, on `dof` degrees of freedom or the declared noise's without), or held (no σ; the
/// two-stage strategy's registration takes its σ from [`registered_parameters`]).
fn instrument_parameters(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    sigmas: Option<&[f64]>,
    dof: Option<usize>,
) -> Vec<ParameterEstimate> {
    let values = problem.shared_values(x);
    let identified = problem.shared_columns();
    let first = x.len() - identified.len();
    let Some(instrument) = problem.instrument() else {
        return Vec::new();
    };
    instrument
        .parameters
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let column = identified.iter().position(|&c| c == k);
            let std = column.and_then(|i| sigmas.map(|s| s[first + i]));
            ParameterEstimate {
                name: p.name.clone(),
                unit: p.unit,
                nominal: p.nominal,
                estimate: values[k],
                std,
                identified: p.identified,
                degrees_of_freedom: std.and(dof),
                prior: None,
                data_share: None,
            }
        })
        .collect()
}

/// The instrument's parameters registered by the two-stage strategy's first stage (held in
/// `problem`, its second stage), each identified one with its σ from `sigmas` (the
/// registration's unknowns, in the instrument's order of identified parameters).
fn registered_parameters(
    problem: &IdentificationProblem<'_>,
    sigmas: &[f64],
    dof: usize,
) -> Vec<ParameterEstimate> {
    let mut identified = sigmas.iter();
    let x = DVector::zeros(problem.parameter_count());
    instrument_parameters(problem, &x, None, None)
        .into_iter()
        .map(|mut p| {
            if p.identified {
                p.std = identified.next().copied();
                p.degrees_of_freedom = p.std.map(|_| dof);
            }
            p
        })
        .collect()
}

/// Per unknown of `problem` (the legs' identified parameters), the standard deviation of its
/// departure from nominal the model's simulation block draws (0 where it draws none).
fn departure_sigmas(mechanism: &Mechanism, problem: &IdentificationProblem<'_>) -> Vec<f64> {
    let mut sigmas = vec![0.0; problem.parameter_count()];
    let Some(simulation) = &mechanism.simulation else {
        return sigmas;
    };
    for slot in problem.slots() {
        let params = &mechanism.legs[slot.leg].params;
        for (k, &c) in slot.columns.iter().enumerate() {
            sigmas[slot.offset + k] = perturbation_sigma(&params[c], simulation).unwrap_or(0.0);
        }
    }
    sigmas
}

/// The robust joint fit of `problem` (unweighted, as built) from the least-squares estimate
/// `x0` with `loss`, scaled by each residual's declared σ at `x0` under `noise`; each
/// reweighting round solved by the Schur complement.
///
/// # Errors
/// A residual whose expected variance is zero (nothing to scale the loss by), a block out of
/// reach, or the solver's failure.
fn robust_fit(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    loss: RobustLoss,
    noise: &crate::model::mechanism::MeasurementNoise,
) -> Result<RobustFit> {
    let variances = problem.row_variances(x0, noise).map_err(solver_error)?;
    let sigma: Vec<f64> = variances.iter().map(|v| v.sqrt()).collect();
    if let Some(i) = sigma.iter().position(|s| !(*s > 0.0 && s.is_finite())) {
        return Err(solver_error(format!(
            "--robust {}: residual {} ({}) has no declared scatter to scale the loss by \
             (expected variance {:e})",
            loss.name(),
            i + 1,
            problem.residual_places()[i].text(),
            variances[i]
        )));
    }
    robust::fit_with(problem, x0, loss, &sigma, |weighted, x| {
        solve_bordered(weighted, x.clone()).map_err(|e| RobustError::Solver(e.to_string()))
    })
    .map_err(|e| match e {
        RobustError::Block(e) => located(e),
        RobustError::Solver(message) => solver_error(message),
    })
}

fn solver_error(error: impl std::fmt::Display) -> Error {
    Error::Solver {
        context: "legs and instrument".into(),
        message: error.to_string(),
    }
}
