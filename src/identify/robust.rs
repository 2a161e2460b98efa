//! Robust losses (`--robust huber|cauchy`) by iteratively reweighted least squares, around an
//! [`IdentificationProblem`]: the solver stays a plain least-squares solver.
//!
//! A robust fit minimises `Σ ρ(u_i²)` over the standardised residuals `u_i = r_i / σ_i`, with
//! `σ_i² = v_i` the residual variance the declared noise predicts
//! ([`super::statistics::row_variances`]), so the loss's scale comes from the declared noise.
//! Its stationarity condition `Σ ρ'(u_i²) u_i ∇u_i = 0` is the normal equation of a weighted
//! least-squares problem with weights `w_i = ρ'(u_i²) / σ_i²`: each round fixes the weights at
//! the current estimate and solves that weighted problem (Levenberg–Marquardt or Gauss–Newton,
//! from the current estimate) until the estimate stops moving. Cauchy's loss is not convex, so
//! a Cauchy fit starts from the Huber fit, which starts from the least-squares fit.
//!
//! Losses, with `s = u²` and tuning constant `c` (95 % efficiency on normal data):
//! Huber `ρ(s) = s` for `s ≤ c²`, `2c√s − c²` beyond (`c = 1.345`, weight `min(1, c/|u|)`);
//! Cauchy `ρ(s) = c² ln(1 + s/c²)` (`c = 2.3849`, weight `1 / (1 + s/c²)`).

use nalgebra::DVector;
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

use super::problem::{BlockError, IdentificationProblem};
use super::solve_from::{solve_from, FitError};
use crate::solver::{SolverKind, SolverOutcome, StopReason};

/// Largest number of reweighting rounds per loss.
pub const MAX_REWEIGHTINGS: usize = 50;

/// Relative change of the estimate below which the reweighting has converged.
pub const REWEIGHTING_TOLERANCE: f64 = 1e-10;

pub use super::result::RobustLoss;

impl RobustLoss {
    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            RobustLoss::Huber => "huber",
            RobustLoss::Cauchy => "cauchy",
        }
    }

    /// The tuning constant `c`, in units of the residual's standard deviation.
    pub fn tuning(self) -> f64 {
        match self {
            RobustLoss::Huber => 1.345,
            RobustLoss::Cauchy => 2.3849,
        }
    }

    /// The asymptotic variance of the robust estimate over the least-squares one on normal
    /// data: `E[ψ(u)²] / E[ψ'(u)]²` for `u ~ N(0, 1)`, with `ψ(u) = u ρ'(u²)` the loss's
    /// influence function (1.052631 for Huber, 1.052634 for Cauchy: the 95 % efficiency their
    /// constants are tuned for). The weights `ρ'(u²)` the fit ends with treat each residual as if
    /// its weight were fixed, which understates the scatter of an M-estimate (a residual beyond
    /// Huber's corner moves the estimate by `c` whatever its size, not by its weighted share);
    /// the covariance of a robust fit is the declared-noise weighted one times this factor.
    pub fn variance_factor(self) -> f64 {
        let c = self.tuning();
        match self {
            // E[ψ'] = 2Φ(c) − 1, E[ψ²] = 2Φ(c) − 1 − 2cφ(c) + 2c²(1 − Φ(c)).
            RobustLoss::Huber => {
                let normal = Normal::new(0.0, 1.0).expect("the standard normal law");
                let inside = 2.0 * normal.cdf(c) - 1.0;
                let squares =
                    inside - 2.0 * c * normal.pdf(c) + 2.0 * c * c * (1.0 - normal.cdf(c));
                squares / (inside * inside)
            }
            // Smooth integrands, even in u: twice Simpson's rule over [0, 12].
            RobustLoss::Cauchy => {
                let ratio = |u: f64| 1.0 + (u / c).powi(2);
                let squares = 2.0 * simpson(|u| (u / ratio(u)).powi(2), 0.0, 12.0);
                let slopes = 2.0 * simpson(|u| (2.0 - ratio(u)) / ratio(u).powi(2), 0.0, 12.0);
                squares / (slopes * slopes)
            }
        }
    }

    /// `ρ'(u²)`: the weight of a residual `u` standard deviations away.
    pub fn weight(self, u: f64) -> f64 {
        let c = self.tuning();
        match self {
            // 1 inside the corner (also at u = 0, where c/|u| is infinite), c/|u| beyond.
            RobustLoss::Huber => (c / u.abs()).min(1.0),
            RobustLoss::Cauchy => 1.0 / (1.0 + (u / c).powi(2)),
        }
    }
}

/// `∫ f(u) φ(u) du` over `[a, b]` with `φ` the standard normal density, by Simpson's rule on
/// 4000 intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const INTERVALS: usize = 4000;
    let h = (b - a) / INTERVALS as f64;
    let g = |u: f64| f(u) * (-0.5 * u * u).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let inner: f64 = (1..INTERVALS)
        .map(|i| {
            let weight = if i % 2 == 1 { 4.0 } else { 2.0 };
            weight * g(a + i as f64 * h)
        })
        .sum();
    (g(a) + inner + g(b)) * h / 3.0
}

/// Why a robust fit failed.
#[derive(Debug, thiserror::Error)]
pub enum RobustError {
    /// A residual block could not be evaluated at an estimate.
    #[error(transparent)]
    Block(#[from] BlockError),
    /// A solver run failed (its message).
    #[error("{0}")]
    Solver(String),
}

impl From<FitError> for RobustError {
    fn from(error: FitError) -> Self {
        match error {
            FitError::Block(e) => RobustError::Block(e),
            FitError::Solver(message) | FitError::NeedsNoise(message) => {
                RobustError::Solver(message)
            }
        }
    }
}

/// The result of a robust fit.
#[derive(Debug, Clone)]
pub struct RobustFit {
    /// The estimate.
    pub x: DVector<f64>,
    /// The last weighted solve, with the iterations and evaluations of every round added up.
    /// It is not converged when the last solve did not converge, or when the reweighting ran
    /// out of rounds ([`StopReason::EvaluationBudget`]).
    pub outcome: SolverOutcome,
    /// Weighted solves performed (reweighting rounds over all losses).
    pub reweightings: usize,
    /// Final weights `w_i = ρ'(u_i²) / σ_i²`, one per row.
    pub weights: Vec<f64>,
}

/// Whether a reweighting round that moved the estimate by `change` (Euclidean norm) to `x`
/// has settled: `change ≤ tol (‖x‖ + tol)`, [`REWEIGHTING_TOLERANCE`] relative to the estimate
/// and absolute near zero.
fn settled_at(change: f64, x: &DVector<f64>) -> bool {
    change <= REWEIGHTING_TOLERANCE * (x.norm() + REWEIGHTING_TOLERANCE)
}

/// Robust fit of `problem` (its own weights ignored) from `x0` with `loss`; `sigma` holds each
/// row's standard deviation (all positive).
///
/// # Errors
/// A block out of reach at an estimate, or a solver failure.
pub fn fit(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    loss: RobustLoss,
    sigma: &[f64],
    solver: SolverKind,
) -> Result<RobustFit, RobustError> {
    fit_with(problem, x0, loss, sigma, |weighted, x| {
        Ok(solve_from(weighted, x, solver)?)
    })
}

/// [`fit`] with the weighted least-squares solve of each round given by `solve` (the problem
/// weighted by the round's weights, and the start): the joint fit through an instrument
/// solves its rounds by the Schur complement.
///
/// # Errors
/// As [`fit`], and `solve`'s.
pub fn fit_with(
    problem: &IdentificationProblem<'_>,
    x0: &DVector<f64>,
    loss: RobustLoss,
    sigma: &[f64],
    solve: impl Fn(&IdentificationProblem<'_>, &DVector<f64>) -> Result<SolverOutcome, RobustError>,
) -> Result<RobustFit, RobustError> {
    let raw = problem.unweighted();
    let losses: &[RobustLoss] = match loss {
        RobustLoss::Huber => &[RobustLoss::Huber],
        RobustLoss::Cauchy => &[RobustLoss::Huber, RobustLoss::Cauchy],
    };
    let mut x = x0.clone();
    let mut last: Option<SolverOutcome> = None;
    let mut reweightings = 0;
    let mut weights = vec![1.0; sigma.len()];
    let mut settled = true;
    for &loss in losses {
        settled = false;
        for _ in 0..MAX_REWEIGHTINGS {
            let r = raw.residuals(&x)?;
            weights = r
                .iter()
                .zip(sigma)
                .map(|(ri, si)| loss.weight(ri / si) / (si * si))
                .collect();
            let weighted = raw.clone().with_weights(&weights);
            let mut outcome = solve(&weighted, &x)?;
            reweightings += 1;
            let change = (&outcome.x - &x).norm();
            x.clone_from(&outcome.x);
            if let Some(previous) = &last {
                outcome.iterations += previous.iterations;
                outcome.residual_evaluations += previous.residual_evaluations;
                outcome.jacobian_evaluations += previous.jacobian_evaluations;
            }
            last = Some(outcome);
            if settled_at(change, &x) {
                settled = true;
                break;
            }
        }
    }
    let mut outcome = match last {
        Some(outcome) => outcome,
        None => solve(&raw, &x)?,
    };
    if !settled && outcome.converged {
        outcome.converged = false;
        outcome.stop_reason = StopReason::EvaluationBudget;
    }
    Ok(RobustFit {
        x,
        outcome,
        reweightings,
        weights,
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use nalgebra::DVector;

    use super::{fit, settled_at, RobustLoss, REWEIGHTING_TOLERANCE};
    use crate::identify::problem::IdentificationProblem;
    use crate::identify::solve_from::solve_from;
    use crate::identify::statistics::row_variances;
    use crate::measure::simulate::{simulate, SimulationOptions};
    use crate::model::Mechanism;
    use crate::solver::SolverKind;

    /// The factors against independent values: Huber's closed form evaluated in Python
    /// (`statistics.NormalDist`), Cauchy's by a midpoint sum here; both at the 95 % efficiency
    /// their constants are tuned for.
    #[test]
    fn the_variance_factor_is_the_inverse_efficiency_at_the_normal_law() {
        let huber = 1.052_631_291_188_037_8;
        let factor = RobustLoss::Huber.variance_factor();
        assert!((factor - huber).abs() < 1e-9 * huber, "{factor} vs {huber}");
        let c = RobustLoss::Cauchy.tuning();
        let (mut squares, mut slopes) = (0.0, 0.0);
        let h = 1e-4;
        for k in 0..400_000 {
            let u = -20.0 + (k as f64 + 0.5) * h;
            let density = (-0.5 * u * u).exp() / (2.0 * std::f64::consts::PI).sqrt() * h;
            let s = (u / c).powi(2);
            squares += (u / (1.0 + s)).powi(2) * density;
            slopes += (1.0 - s) / (1.0 + s).powi(2) * density;
        }
        let cauchy = squares / (slopes * slopes);
        assert!((RobustLoss::Cauchy.variance_factor() - cauchy).abs() < 1e-8 * cauchy);
        for loss in [RobustLoss::Huber, RobustLoss::Cauchy] {
            let efficiency = 1.0 / loss.variance_factor();
            assert!((efficiency - 0.95).abs() < 1e-3, "{loss:?}: {efficiency}");
        }
    }

    #[test]
    fn a_round_settles_below_the_tolerance_relative_to_the_estimate_and_absolute_near_zero() {
        let tol = REWEIGHTING_TOLERANCE;
        let unit = DVector::from_vec(vec![0.6, 0.8]);
        let limit = tol * (1.0 + tol);
        assert!(settled_at(limit, &unit), "at the limit: settled");
        assert!(!settled_at(limit * (1.0 + 4.0 * f64::EPSILON), &unit));
        let large = DVector::from_vec(vec![3e3, 4e3]);
        assert!(settled_at(4e-7, &large), "relative: 5e3 × 1e-10 = 5e-7");
        assert!(!settled_at(6e-7, &large));
        let zero = DVector::zeros(2);
        assert!(settled_at(tol * tol, &zero), "absolute at zero");
        assert!(!settled_at(2.0 * tol * tol, &zero));
        assert!(!settled_at(f64::NAN, &unit), "a NaN change never settles");
    }

    /// A Cauchy fit (a Huber fit first) of a leg with a gross outlier is its reweighting rounds
    /// replayed one by one: the same estimate and final weights, every round counted, and the
    /// rounds' iterations and evaluations summed.
    #[test]
    fn a_fit_is_its_rounds_replayed() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
        let mechanism = Mechanism::load(&path).unwrap();
        let data = simulate(&mechanism, SimulationOptions::default()).unwrap();
        let mut blocks = data.measurements.leg_blocks(0);
        blocks[3].reading += 0.05;
        let solver = SolverKind::LevenbergMarquardt;
        let noise = mechanism.noise.as_ref().unwrap();
        // The least-squares start and the rows' σ, on a fresh problem: the fit and its replay
        // see the same evaluation history (warm starts), hence the same bits.
        let prepared = || {
            let problem = IdentificationProblem::new(&mechanism, &[0], blocks.clone());
            let start = solve_from(&problem, &problem.start(), solver).unwrap().x;
            let sigma: Vec<f64> = row_variances(&problem, &start, noise)
                .unwrap()
                .iter()
                .map(|v| v.sqrt())
                .collect();
            (problem, start, sigma)
        };
        let (problem, start, sigma) = prepared();
        let robust = fit(&problem, &start, RobustLoss::Cauchy, &sigma, solver).unwrap();
        let (problem, start, sigma) = prepared();
        let problem = problem.unweighted();
        let mut x = start.clone();
        let (mut rounds, mut iterations, mut residuals, mut jacobians) = (0, 0, 0, 0);
        let mut weights = Vec::new();
        for loss in [RobustLoss::Huber, RobustLoss::Cauchy] {
            loop {
                let r = problem.residuals(&x).unwrap();
                weights = r
                    .iter()
                    .zip(&sigma)
                    .map(|(ri, si)| loss.weight(ri / si) / si.powi(2))
                    .collect();
                let weighted = problem.clone().with_weights(&weights);
                let outcome = solve_from(&weighted, &x, solver).unwrap();
                rounds += 1;
                iterations += outcome.iterations;
                residuals += outcome.residual_evaluations;
                jacobians += outcome.jacobian_evaluations;
                let change = (&outcome.x - &x).norm();
                x = outcome.x;
                if settled_at(change, &x) {
                    break;
                }
            }
        }
        assert!(rounds > 3, "{rounds} rounds");
        assert!(robust.outcome.converged);
        assert_eq!(robust.reweightings, rounds);
        assert_eq!(robust.outcome.iterations, iterations);
        assert_eq!(robust.outcome.residual_evaluations, residuals);
        assert_eq!(robust.outcome.jacobian_evaluations, jacobians);
        assert_eq!(robust.x, x);
        assert_eq!(robust.weights, weights);
        // The outlier's weight is far below the others'.
        let outlier = robust.weights[3] * sigma[3].powi(2);
        assert!(outlier < 0.01, "{outlier}");
    }
}
