//! Outlier rows of a fit through an instrument (every observation kind: a touch's height, a
//! distance, a measured pose's readings, a tracker's targets): the externally studentized
//! residual of every residual of the problem, each first divided by its declared σ (`√v_i`,
//! the diagonal of the noise's covariance), against the Bonferroni-corrected quantile of
//! Student's t on `m − n − 1` degrees of freedom, as a leg's rows are tested
//! (docs/statistics.md §3). A flagged residual is named by its row's line and what it measures;
//! `--drop-outliers` refits without every residual of the flagged rows' measurements (a
//! measured pose's readings go together) by giving them zero weight.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::problem::IdentificationProblem;
use super::statistics::{exact_fit, outlier_threshold, studentized};

/// One residual flagged as an outlier (or dropped).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RowOutlier {
    /// Where it comes from: `line 12, `z.nozzle``.
    pub place: String,
    /// Line of the measurement file, if read from one.
    pub line: Option<usize>,
    /// The measurement it belongs to (its row in the observations).
    #[serde(skip)]
    pub measurement: usize,
    /// Its residual (predicted − measured), in the measurement's units.
    pub residual: f64,
    /// Its externally studentized residual.
    pub t: f64,
}

/// The outlier test over the residuals `r` (Jacobian `jacobian`) of `problem`, each with its
/// declared variance `variances[i]`, the residuals `kept` only (the others dropped): the
/// flagged residuals, largest `|t|` first, and the threshold on `|t|` (`None` without enough
/// redundancy). Nothing is flagged on an exact fit (residuals at round-off or far below the
/// declared scatter).
pub fn outliers(
    problem: &IdentificationProblem<'_>,
    (r, jacobian): (&DVector<f64>, &DMatrix<f64>),
    variances: &[f64],
    kept: &[usize],
) -> (Vec<RowOutlier>, Option<f64>) {
    let (m, n) = (kept.len(), jacobian.ncols());
    if m <= n + 1 || variances.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
        return (Vec::new(), None);
    }
    let e: Vec<f64> = kept.iter().map(|&i| r[i] / variances[i].sqrt()).collect();
    let scaled = DMatrix::from_fn(m, n, |k, j| {
        jacobian[(kept[k], j)] / variances[kept[k]].sqrt()
    });
    let t = studentized(&e, &scaled);
    let threshold = outlier_threshold(m, Some(m - n - 1));
    let raw: Vec<f64> = kept.iter().map(|&i| r[i]).collect();
    let kept_variances: Vec<f64> = kept.iter().map(|&i| variances[i]).collect();
    if exact_fit(&raw, &[], Some(&kept_variances)) {
        return (Vec::new(), threshold);
    }
    let places = problem.residual_places();
    let mut flagged: Vec<RowOutlier> = t
        .iter()
        .enumerate()
        .filter_map(|(k, tk)| tk.map(|v| (k, v)))
        .filter(|(_, v)| threshold.is_some_and(|limit| v.abs() > limit))
        .map(|(k, v)| {
            let place = &places[kept[k]];
            RowOutlier {
                place: place.text(),
                line: place.line,
                measurement: place.measurement,
                residual: r[kept[k]],
                t: v,
            }
        })
        .collect();
    flagged.sort_by(|a, b| b.t.abs().total_cmp(&a.t.abs()));
    (flagged, threshold)
}

/// The residuals of `problem` kept when the measurements of `dropped` are left out: every
/// residual of another measurement.
pub fn kept_residuals(problem: &IdentificationProblem<'_>, dropped: &[RowOutlier]) -> Vec<usize> {
    problem
        .residual_places()
        .iter()
        .enumerate()
        .filter(|(_, p)| !dropped.iter().any(|d| d.measurement == p.measurement))
        .map(|(i, _)| i)
        .collect()
}
