//! Statistics that catch bad data, after every fit: the residuals tested against the declared
//! measurement noise (χ²), externally studentized residuals that name outlier rows, and the
//! readings that sit on another turn than the leg's home value.
//!
//! **Expected residual variance.** In the inverse method a residual is the predicted reading at
//! the *measured* pose minus the measured reading, so both noises enter it: the reading's
//! `σ_q²` and the pose noise mapped through the leg's inverse kinematics,
//! `v_i = σ_q² + ∇_P ψ · Σ_P · ∇_P ψᵀ` (`Σ_P` diagonal, the declared tracker noise). The gradient
//! `∇_P ψ` comes from dual numbers seeded on the pose coordinates, one Newton step from the f64
//! solution (implicit function theorem), like the identification Jacobian.
//!
//! **Noise test.** `χ² = Σ r_i² / v_i` over the leg's rows, with `m − n` degrees of freedom
//! (exact for the `--weights noise` fit, a close approximation for the unweighted one). The
//! declared noise is rejected when the upper-tail probability is below [`NOISE_TEST_P`].
//!
//! **Outliers.** For a least-squares fit, the externally studentized (leave-one-out) residual
//! `t_i = e_i / (s_(i) √(1 − h_ii))`, with `h_ii` the leverage (hat-matrix diagonal of the
//! fitted Jacobian, from its SVD) and `s_(i)² = (Σ e² − e_i²/(1 − h_ii)) / (m − n − 1)` the
//! residual variance without row `i`; under the model it follows Student's t with `m − n − 1`
//! degrees of freedom. For a robust fit, whose residuals do not follow least-squares algebra,
//! `t_i = e_i / (σ_i √(1 − h_ii))` with the declared `σ_i = √v_i`, against the normal law. A row
//! is an outlier beyond the Bonferroni-corrected two-sided quantile at family level
//! [`OUTLIER_ALPHA`]: on clean data, one fit in a hundred flags a row.
//!
//! **Exact fits.** Studentized residuals are ratios, so they are as large on a fit whose
//! residuals are round-off (a zero-noise simulation) as on a noisy one. A fit is exact, and no
//! row is flagged, when its RMS residual is at most [`ROUND_OFF`] times the largest reading, or at
//! most [`EXACT_FIT_FRACTION`] of the declared scatter (see [`exact_fit`]).

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};

use super::problem::{BlockError, IdentificationProblem, LegSlot};
use super::sandwich::NoiseLoadings;
use crate::measure::checks::{mechanism_size, reading_out_of_range, SIZE_FACTOR};
use crate::model::mechanism::MeasurementNoise;
use crate::model::Mechanism;

/// The 0.975 quantile of Student's t with `dof` degrees of freedom (NaN for none): the factor
/// of a two-sided 95 % interval built on an estimated σ.
pub fn student_t_975(dof: usize) -> f64 {
    StudentsT::new(0.0, 1.0, dof as f64).map_or(f64::NAN, |t| t.inverse_cdf(0.975))
}

/// Half the width of the two-sided 95 % interval of an estimate whose σ `std` was estimated on
/// `dof` degrees of freedom: `t(0.975, dof) · std`.
pub fn half_width95(std: f64, dof: usize) -> f64 {
    student_t_975(dof) * std
}

/// The 0.975 quantile of the normal law: the factor of a two-sided 95 % interval on a known σ
/// (the declared noise's, [`SCALE_DOF`](super::sandwich::SCALE_DOF)).
pub const NORMAL_975: f64 = 1.959_963_984_540_054;

/// Upper-tail probability of the χ² statistic below which the declared noise is rejected.
pub const NOISE_TEST_P: f64 = 1e-3;

/// Whether a χ² test's upper-tail probability `p_value` rejects its hypothesis: below
/// [`NOISE_TEST_P`], or not a number (a statistic that cannot be trusted rejects).
pub fn rejects(p_value: f64) -> bool {
    p_value.is_nan() || p_value < NOISE_TEST_P
}

/// Family-wise level of the outlier test (Bonferroni over a leg's rows).
pub const OUTLIER_ALPHA: f64 = 0.01;

/// Residuals whose RMS is at most this fraction of the largest `|reading|` are round-off.
pub const ROUND_OFF: f64 = 1e-10;

/// Residuals whose RMS is at most this fraction of the declared scatter are far below noise.
pub const EXACT_FIT_FRACTION: f64 = 1e-3;

/// Whether residuals `e` of a fit to `readings` are too small to name outliers: their RMS is at
/// most [`ROUND_OFF`] × the largest `|reading|` (round-off), or at most [`EXACT_FIT_FRACTION`] ×
/// the declared scatter `√(mean variances)` when positive variances are declared.
pub fn exact_fit(e: &[f64], readings: &[f64], variances: Option<&[f64]>) -> bool {
    if e.is_empty() {
        return false;
    }
    let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt();
    let largest = readings.iter().fold(0.0_f64, |a, r| a.max(r.abs()));
    let declared = variances
        .filter(|v| !v.is_empty())
        .map(|v| (v.iter().sum::<f64>() / v.len() as f64).sqrt())
        // A zero scatter admits only a zero RMS, which the round-off test admits already.
        .filter(|s| s.is_finite());
    rms <= ROUND_OFF * largest || declared.is_some_and(|s| rms <= EXACT_FIT_FRACTION * s)
}

/// The residuals of one leg tested against the declared noise.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct NoiseTest {
    /// `Σ r_i² / v_i` over the tested rows.
    pub chi_squared: f64,
    /// Degrees of freedom: tested rows − identified parameters.
    pub degrees_of_freedom: usize,
    /// Upper-tail probability of `chi_squared`.
    pub p_value: f64,
    /// `√(χ² / dof)`: the residual scatter in units of the declared one (≈ 1 when it holds).
    pub sigma_ratio: f64,
    /// RMS residual `√(Σ r² / dof)` in reading units.
    pub residual_sigma: f64,
    /// The declared scatter the test compares with, `residual_sigma / sigma_ratio` (a mean of
    /// the expected standard deviations `√v_i`), reading units.
    pub expected_sigma: f64,
    /// Rows left out of the test (the outliers of a robust fit).
    #[serde(rename = "excluded_rows")]
    pub excluded: usize,
    /// `p_value < NOISE_TEST_P` ([`rejects`]).
    pub rejected: bool,
}

/// One row flagged as an outlier.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Outlier {
    /// Line of the measurement file, if read from one.
    pub line: Option<usize>,
    /// The measured pose, as `x=…, y=…`.
    pub pose: String,
    /// The measured reading.
    pub reading: f64,
    /// Its residual (predicted − measured, matched modulo one turn), reading units.
    pub residual: f64,
    /// Its studentized residual.
    pub t: f64,
    /// Flagged because its reading puts the joint where it cannot be (more than 2π from its
    /// home value, or a stroke beyond the mechanism's size), whatever its `t`: a gross error
    /// that a fit may absorb (a reading of 1e12 fitted by a gain of 1e-12).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub out_of_range: bool,
}

impl Outlier {
    /// `line 6` or `simulated pose x=…, y=…`.
    pub fn place(&self) -> String {
        match self.line {
            Some(line) => format!("line {line}"),
            None => format!("simulated pose {}", self.pose),
        }
    }
}

/// The statistics of one leg's fit.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LegStatistics {
    /// The noise test, if the model declares a non-zero noise and `m > n`.
    pub noise_test: Option<NoiseTest>,
    /// The outlier threshold on `|t|`, if `m > n + 1`.
    pub outlier_threshold: Option<f64>,
    /// Rows beyond the threshold, largest `|t|` first.
    pub outliers: Vec<Outlier>,
    /// Largest `|t|` over the rows, if computed.
    pub largest_t: Option<f64>,
    /// Problem rows of the outliers (for `--drop-outliers`).
    pub outlier_rows: Vec<usize>,
    /// The rows whose readings sit on another turn than the home value, if any.
    pub other_turn: Option<OtherTurn>,
}

/// Readings matched modulo 2π: they sit on another turn than the leg's home value.
#[derive(Debug, Clone, PartialEq)]
pub struct OtherTurn {
    /// The most common number of whole turns between prediction and reading (of equally
    /// common ones, the first in row order).
    pub turns: f64,
    /// How many rows were matched across a turn.
    pub rows: usize,
    /// Their measurement-file lines (if read from a file).
    pub lines: Vec<usize>,
}

/// Expected variance of every residual of `problem` at the unknowns `x`:
/// `σ_q² + Σ_c (∂ψ/∂P_c)² σ_c²`, with each row's pose gradient at its inverse-kinematics
/// solution: the problem's own where its last evaluation was at `x`, else warm-started from
/// its last one ([`IdentificationProblem::map_seeded`]; in parallel for a large problem).
///
/// # Errors
/// The first block whose leg cannot reach its pose.
pub fn row_variances(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    noise: &MeasurementNoise,
) -> Result<Vec<f64>, BlockError> {
    // Row by row, without a loading vector each (the weighted fit asks for them at every
    // reweighting).
    map_pose_loadings(problem, x, noise, |_, w| {
        noise.reading.powi(2) + w.iter().map(|v| v.powi(2)).sum::<f64>()
    })
}

/// How the declared `noise` reaches every residual of `problem` at `x`: per row, `σ_c ∂ψ/∂P_c`
/// over the pose coordinates (each row its own measurement: the poses' noises are
/// independent from row to row of a leg), and the readings' own `σ_q`.
///
/// # Errors
/// The first block whose leg cannot reach its pose.
pub fn row_loadings(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    noise: &MeasurementNoise,
) -> Result<NoiseLoadings, BlockError> {
    let rows = map_pose_loadings(problem, x, noise, |index, w| (index, w.to_vec()))?;
    Ok(NoiseLoadings {
        reading: noise.reading,
        rows,
        also: Vec::new(),
    })
}

/// `f(row, w)` for every row of `problem` at `x`, `w` the row's pose loadings
/// `σ_c ∂ψ/∂P_c` under `noise` (in parallel for a large problem, as
/// [`IdentificationProblem::map_seeded`]).
fn map_pose_loadings<T: Send>(
    problem: &IdentificationProblem<'_>,
    x: &DVector<f64>,
    noise: &MeasurementNoise,
    f: impl Fn(usize, &[f64; 6]) -> T + Sync,
) -> Result<Vec<T>, BlockError> {
    let measured = &problem.mechanism().measured;
    problem.map_seeded(x, |index, leg, solution| {
        let pose = &problem.blocks()[index].pose;
        let gradient = leg.pose_gradient_of(pose, solution, measured);
        f(index, &std::array::from_fn(|c| gradient[c] * noise.pose[c]))
    })
}

/// The hat matrix's factor `W = V_r Σ_r⁻¹` of `jacobian` (n × r: the right singular vectors of
/// its non-negligible singular values, each divided by its value), from its thin SVD without
/// the m × r `U`: `U = J W`, so row `i` of `U` is `J_i W` and the hat matrix is `J W Wᵀ Jᵀ`.
fn hat_factor(jacobian: &DMatrix<f64>) -> DMatrix<f64> {
    let n = jacobian.ncols();
    let svd = jacobian.clone().svd(false, true);
    let Some(v_t) = svd.v_t else {
        return DMatrix::zeros(n, 0);
    };
    let s = &svd.singular_values;
    let largest = s.max();
    let kept: Vec<usize> = (0..s.len()).filter(|&k| s[k] > 1e-12 * largest).collect();
    DMatrix::from_fn(n, kept.len(), |j, k| v_t[(kept[k], j)] / s[kept[k]])
}

/// Row `i` of the column space's orthonormal basis `U = J W` ([`hat_factor`]), into `row`.
fn basis_row(jacobian: &DMatrix<f64>, w: &DMatrix<f64>, i: usize, row: &mut [f64]) {
    for (k, value) in row.iter_mut().enumerate() {
        *value = (0..w.nrows()).map(|j| jacobian[(i, j)] * w[(j, k)]).sum();
    }
}

/// The leverages `‖U_i‖²` of every row, from the factor `w` ([`hat_factor`]).
fn leverages_from(jacobian: &DMatrix<f64>, w: &DMatrix<f64>) -> Vec<f64> {
    let mut row = vec![0.0; w.ncols()];
    (0..jacobian.nrows())
        .map(|i| {
            basis_row(jacobian, w, i, &mut row);
            row.iter().map(|v| v * v).sum()
        })
        .collect()
}

/// Leverages `h_ii` (diagonal of the hat matrix `J (JᵀJ)⁻¹ Jᵀ`) from the thin SVD of `J`.
pub fn leverages(jacobian: &DMatrix<f64>) -> Vec<f64> {
    leverages_from(jacobian, &hat_factor(jacobian))
}

/// Externally studentized residuals of a least-squares fit with residuals `e` and Jacobian
/// `jacobian` (`m × n`); `None` for a row of leverage 1 or without `m > n + 1`.
///
/// The sum of squares without row `i` is `Σ e² − e_i²/(1 − h_ii)`; when row `i` dominates it
/// (a gross outlier), that difference cancels, and it is summed directly from the other rows'
/// leave-one-out residuals `e_j + h_ji e_i / (1 − h_ii)` instead.
pub fn studentized(e: &[f64], jacobian: &DMatrix<f64>) -> Vec<Option<f64>> {
    let (m, n) = jacobian.shape();
    if m <= n + 1 {
        return vec![None; m];
    }
    let w = hat_factor(jacobian);
    let h = leverages_from(jacobian, &w);
    let total: f64 = e.iter().map(|v| v * v).sum();
    let (mut row_i, mut row_j) = (vec![0.0; w.ncols()], vec![0.0; w.ncols()]);
    (0..m)
        .map(|i| {
            let free = 1.0 - h[i];
            if free <= 1e-12 {
                return None;
            }
            let mut without = total - e[i] * e[i] / free;
            if without.is_nan() || without <= 1e-6 * total {
                let shift = e[i] / free;
                basis_row(jacobian, &w, i, &mut row_i);
                without = (0..m)
                    .filter(|&j| j != i)
                    .map(|j| {
                        basis_row(jacobian, &w, j, &mut row_j);
                        let h_ji: f64 = row_j.iter().zip(&row_i).map(|(a, b)| a * b).sum();
                        (e[j] + h_ji * shift).powi(2)
                    })
                    .sum();
            }
            let s = (without.max(0.0) / (m - n - 1) as f64).sqrt();
            let t = e[i] / (s * free.sqrt());
            t.is_finite().then_some(t)
        })
        .collect()
}

/// A figure for a message: three decimals in [1e-3, 1e4), else scientific.
pub fn figure(value: f64) -> String {
    if value == 0.0 || (1e-3..1e4).contains(&value.abs()) {
        format!("{value:.3}")
    } else {
        format!("{value:.3e}")
    }
}

/// The Bonferroni-corrected two-sided threshold on `|t|` for `rows` rows at family level
/// [`OUTLIER_ALPHA`]: Student's t with `dof` degrees of freedom, or the normal law (`None`).
pub fn outlier_threshold(rows: usize, dof: Option<usize>) -> Option<f64> {
    let p = 1.0 - OUTLIER_ALPHA / (2.0 * rows.max(1) as f64);
    let value = match dof {
        Some(0) => return None,
        Some(d) => StudentsT::new(0.0, 1.0, d as f64).ok()?.inverse_cdf(p),
        None => Normal::new(0.0, 1.0).ok()?.inverse_cdf(p),
    };
    value.is_finite().then_some(value)
}

/// The χ² test of residuals `e` (reading units) against expected variances `v` for a fit of
/// `parameters` unknowns; `None` without redundancy or with a zero expected variance.
pub fn noise_test(e: &[f64], v: &[f64], parameters: usize, excluded: usize) -> Option<NoiseTest> {
    let m = e.len();
    if m <= parameters || v.iter().any(|&vi| !(vi > 0.0 && vi.is_finite())) {
        return None;
    }
    let dof = m - parameters;
    let chi_squared: f64 = e.iter().zip(v).map(|(ei, vi)| ei * ei / vi).sum();
    let p_value = ChiSquared::new(dof as f64).ok()?.sf(chi_squared);
    let sum_squares: f64 = e.iter().map(|x| x * x).sum();
    let sigma_ratio = (chi_squared / dof as f64).sqrt();
    let residual_sigma = (sum_squares / dof as f64).sqrt();
    // Σ r²/v = Σ r² / v̄ with v̄ the r²-weighted harmonic mean of the variances.
    let expected_sigma = if chi_squared > 0.0 {
        residual_sigma / sigma_ratio
    } else {
        (m as f64 / v.iter().map(|vi| 1.0 / vi).sum::<f64>()).sqrt()
    };
    Some(NoiseTest {
        chi_squared,
        degrees_of_freedom: dof,
        p_value,
        sigma_ratio,
        residual_sigma,
        expected_sigma,
        excluded,
        rejected: rejects(p_value),
    })
}

/// The leg's rows (positions in `readings`, the leg's rows' raw readings) whose reading puts
/// the joint where it cannot be ([`reading_out_of_range`]), when they are a few of the leg's
/// rows (at most one in ten): gross errors among good rows. When more are, the file is in other
/// units (degrees, millimetres), which the checks before the fit name; none is then an outlier.
fn out_of_range_rows(mechanism: &Mechanism, slot: &LegSlot, readings: &[f64]) -> Vec<usize> {
    let limit = SIZE_FACTOR * mechanism_size(mechanism);
    let leg = &mechanism.legs[slot.leg];
    let rows: Vec<usize> = (0..readings.len())
        .filter(|&k| reading_out_of_range(leg, readings[k], limit))
        .collect();
    if rows.len() * 10 <= readings.len() {
        rows
    } else {
        Vec::new()
    }
}

/// How the leg was fitted, for the statistics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitKind {
    /// Least squares (unweighted, or weighted by the declared noise: `problem`'s own weights).
    LeastSquares,
    /// A robust loss (the problem's weights are the loss's; residuals are standardised by the
    /// declared noise).
    Robust,
}

/// A problem's residuals and Jacobian at one point.
pub type Evaluated<'e> = (&'e DVector<f64>, &'e DMatrix<f64>);

/// The statistics of the leg in `slot` at the estimate `x` of `problem` (as fitted, with its
/// weights), given the residuals and Jacobian there as fitted (`fitted`) and unweighted
/// (`raw`); `noise` is the declared noise.
///
/// # Errors
/// A block whose leg cannot reach its pose.
pub fn leg_statistics(
    problem: &IdentificationProblem<'_>,
    slot: &LegSlot,
    x: &DVector<f64>,
    (fitted, raw): (Evaluated<'_>, Evaluated<'_>),
    noise: Option<&MeasurementNoise>,
    kind: FitKind,
) -> Result<LegStatistics, BlockError> {
    let rows = problem.rows_of(slot);
    let (m, n) = (rows.len(), slot.columns.len());
    let (raw, raw_jacobian) = raw;
    let variances = match noise {
        Some(noise) => Some(row_variances(&problem.unweighted(), x, noise)?),
        None => None,
    };
    let leg_rows = |r: &DVector<f64>| -> Vec<f64> { rows.iter().map(|&i| r[i]).collect() };
    let e = leg_rows(raw);
    let leg_variances: Option<Vec<f64>> = variances
        .as_ref()
        .map(|v| rows.iter().map(|&i| v[i]).collect());
    let positive = leg_variances
        .as_ref()
        .filter(|v| v.iter().all(|&vi| vi > 0.0 && vi.is_finite()));
    let (t, threshold): (Vec<Option<f64>>, Option<f64>) = match (kind, positive) {
        (FitKind::Robust, Some(v)) => {
            let all = variances.as_deref().unwrap_or_default();
            let j = DMatrix::from_fn(m, n, |i, k| {
                raw_jacobian[(rows[i], slot.offset + k)] / all[rows[i]].sqrt()
            });
            let h = leverages(&j);
            let t = e
                .iter()
                .zip(v)
                .zip(&h)
                .map(|((ei, vi), hi)| {
                    let free = 1.0 - hi;
                    (free > 1e-12).then(|| ei / (vi.sqrt() * free.sqrt()))
                })
                .collect();
            (t, outlier_threshold(m, None))
        }
        _ => {
            let (fitted, fitted_jacobian) = fitted;
            let j = problem.slot_jacobian(slot, fitted_jacobian);
            let t = studentized(&leg_rows(fitted), &j);
            let threshold = (m > n + 1)
                .then(|| outlier_threshold(m, Some(m - n - 1)))
                .flatten();
            (t, threshold)
        }
    };
    let mechanism = problem.mechanism();
    let readings: Vec<f64> = rows.iter().map(|&i| problem.blocks()[i].reading).collect();
    let exact = exact_fit(&e, &readings, leg_variances.as_deref());
    let out_of_range = out_of_range_rows(mechanism, slot, &readings);
    let mut flagged: Vec<(usize, f64)> = t
        .iter()
        .enumerate()
        .filter_map(|(k, tk)| tk.map(|v| (k, v)))
        .filter(|(k, v)| {
            out_of_range.contains(k) || (!exact && threshold.is_some_and(|limit| v.abs() > limit))
        })
        .collect();
    // Rows out of range first, then by |t|.
    flagged.sort_by(|a, b| {
        let range = |k: usize| out_of_range.contains(&k);
        range(b.0)
            .cmp(&range(a.0))
            .then(b.1.abs().total_cmp(&a.1.abs()))
    });
    let outliers = flagged
        .iter()
        .map(|&(k, tk)| {
            let block = &problem.blocks()[rows[k]];
            Outlier {
                line: block.line,
                pose: mechanism.pose_text(&block.pose),
                reading: block.reading,
                residual: e[k],
                t: tk,
                out_of_range: out_of_range.contains(&k),
            }
        })
        .collect();
    let outlier_rows: Vec<usize> = flagged.iter().map(|&(k, _)| rows[k]).collect();
    let noise_test = leg_variances.as_ref().and_then(|v| {
        let keep: Vec<usize> = (0..m)
            .filter(|&k| kind == FitKind::LeastSquares || !outlier_rows.contains(&rows[k]))
            .collect();
        let kept_e: Vec<f64> = keep.iter().map(|&k| e[k]).collect();
        let kept_v: Vec<f64> = keep.iter().map(|&k| v[k]).collect();
        noise_test(&kept_e, &kept_v, n, m - keep.len())
    });
    let turns = problem.turns(x)?;
    let shifted: Vec<usize> = rows.iter().copied().filter(|&i| turns[i] != 0.0).collect();
    let other_turn = (!shifted.is_empty()).then(|| OtherTurn {
        turns: most_common(shifted.iter().map(|&i| turns[i])),
        rows: shifted.len(),
        lines: shifted
            .iter()
            .filter_map(|&i| problem.blocks()[i].line)
            .collect(),
    });
    Ok(LegStatistics {
        noise_test,
        outlier_threshold: threshold,
        outliers,
        largest_t: t.iter().flatten().map(|v| v.abs()).reduce(f64::max),
        outlier_rows,
        other_turn,
    })
}

/// The most common of `values` (of equally common ones, the first; 0 for none).
fn most_common(values: impl Iterator<Item = f64>) -> f64 {
    let values: Vec<f64> = values.collect();
    let mut best = (0.0, 0);
    for &v in &values {
        let count = values.iter().filter(|&&w| w.total_cmp(&v).is_eq()).count();
        if count > best.1 {
            best = (v, count);
        }
    }
    best.0
}

/// The leg's warnings: a rejected noise test (with the likely causes and the figures),
/// the outliers, the readings on another turn. `unit` is the reading unit (`rad` or `m`),
/// `joint` the actuated joint and `home` its home value.
pub fn warnings(
    statistics: &LegStatistics,
    leg: &str,
    unit: &str,
    joint: &str,
    home: f64,
) -> Vec<String> {
    let mut warnings = Vec::new();
    if let Some(test) = statistics.noise_test.as_ref().filter(|t| t.rejected) {
        let largest = statistics.largest_t.map_or(String::new(), |t| {
            format!(" (largest studentized residual |t| = {})", figure(t))
        });
        let outliers = match statistics.outliers.first() {
            Some(o) => format!("an outlier row such as {}{largest}", o.place()),
            None => format!("outlier rows{largest}"),
        };
        warnings.push(format!(
            "leg {leg}: the residuals reject the declared noise: residual σ̂ = {:.3e} {unit} \
             against {:.3e} {unit} expected, {} times the declared scatter (χ² = {:.4e} \
             with {} degrees of freedom, p = {:.2e} < {NOISE_TEST_P:e}). Likely causes: readings \
             or measured angles in degrees instead of radians (a factor 57.3), lengths in \
             millimetres instead of metres (a factor 1000), {outliers}, a declared noise that is \
             too small, or a model that does not fit the mechanism. Check the units of the \
             measurement file and the model.",
            test.residual_sigma,
            test.expected_sigma,
            figure(test.sigma_ratio),
            test.chi_squared,
            test.degrees_of_freedom,
            test.p_value
        ));
    }
    for o in &statistics.outliers {
        warnings.push(if o.out_of_range {
            format!(
                "leg {leg}: {} is an outlier: reading {} {unit} puts the joint where it cannot \
                 be (whatever the fit makes of it: residual {:.3e} {unit}, studentized residual \
                 t = {})",
                o.place(),
                o.reading,
                o.residual,
                figure(o.t),
            )
        } else {
            format!(
                "leg {leg}: {} is an outlier: reading {} {unit}, residual {:.3e} {unit}, \
                 studentized residual t = {} beyond ±{} (Bonferroni, family level \
                 {OUTLIER_ALPHA})",
                o.place(),
                o.reading,
                o.residual,
                figure(o.t),
                figure(statistics.outlier_threshold.unwrap_or_default())
            )
        });
    }
    if let Some(OtherTurn { turns, rows, lines }) = &statistics.other_turn {
        let lines = if lines.is_empty() {
            String::new()
        } else {
            let shown: Vec<String> = lines.iter().take(8).map(|l| l.to_string()).collect();
            let more = if lines.len() > 8 { ", …" } else { "" };
            format!(" (lines {}{more})", shown.join(", "))
        };
        warnings.push(format!(
            "leg {leg}, joint {joint}: {rows} reading(s){lines} sit {turns} turn(s) of 2π away \
             from the turn of the joint's home value {home} rad (or of its offset); they were \
             matched modulo 2π. If the home value is in degrees, convert it to radians; \
             otherwise put it on the readings' turn."
        ));
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::{most_common, out_of_range_rows};
    use crate::identify::problem::LegSlot;
    use crate::measure::checks::{mechanism_size, SIZE_FACTOR};
    use crate::model::Mechanism;

    /// A prismatic leg's stroke beyond SIZE_FACTOR times the mechanism's size is out of range
    /// (one and a half times it is, half of it is not), and out-of-range rows are outliers only
    /// while they are at most one in ten of the leg's rows.
    #[test]
    fn strokes_beyond_the_size_limit_are_outliers_when_few() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/3rpr.yaml");
        let mechanism = Mechanism::load(&path).unwrap();
        let limit = SIZE_FACTOR * mechanism_size(&mechanism);
        let slot = LegSlot {
            leg: 0,
            columns: Vec::new(),
            offset: 0,
        };
        let mut readings = vec![0.0; 20];
        readings[7] = 1.5 * limit;
        readings[11] = 0.5 * limit;
        assert_eq!(out_of_range_rows(&mechanism, &slot, &readings), [7]);
        readings[11] = -1.5 * limit;
        assert_eq!(out_of_range_rows(&mechanism, &slot, &readings), [7, 11]);
        readings[3] = 2.0 * limit;
        assert!(out_of_range_rows(&mechanism, &slot, &readings).is_empty());
    }

    #[test]
    fn the_most_common_value_and_the_first_of_equally_common_ones() {
        let of = |values: &[f64]| most_common(values.iter().copied());
        assert_eq!(
            of(&[2.0, -1.0, -1.0, 2.0, -1.0]).to_bits(),
            (-1.0_f64).to_bits()
        );
        assert_eq!(of(&[1.0, -1.0, 1.0, -1.0]).to_bits(), 1.0_f64.to_bits());
        assert_eq!(of(&[-1.0, 1.0, -1.0, 1.0]).to_bits(), (-1.0_f64).to_bits());
        assert_eq!(of(&[3.0]).to_bits(), 3.0_f64.to_bits());
        assert_eq!(of(&[]).to_bits(), 0.0_f64.to_bits());
    }
}
