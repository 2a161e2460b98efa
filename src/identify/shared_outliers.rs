//! Outlier rows of a fit through an instrument (every observation kind: a touch's height, a
//! distance, a measured pose's readings, a tracker's targets): the externally studentized
//! residual of every residual of the problem, each first divided by its declared σ (`√v_i`,
//! the diagonal of the noise's covariance), against the Bonferroni-corrected quantile of
//! Student's t on `m − n − 1` degrees of freedom, as a leg's rows are tested
//! (docs/statistics.md §3). A flagged residual is named by its row's line and what it measures;
//! `--drop-outliers` refits without every residual of the flagged rows' measurements (a
//! measured pose's readings go together) by giving them zero weight. After a robust fit, whose
//! residuals do not follow least-squares algebra, `t_i = e_i / √(1 − h_ii)` with `e_i` the
//! residual in declared σ and `h_ii` the leverage of the σ-scaled Jacobian, against the normal
//! law, as a robust leg fit's rows are tested.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::problem::IdentificationProblem;
use super::statistics::{exact_fit, leverages, outlier_threshold, studentized, FitKind};

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
/// declared scatter). `kind` says how the fit was made: least squares (externally studentized
/// residuals, Student's t) or a robust loss (residuals in declared σ over `√(1 − h)`, the
/// normal law); `jacobian` is the unweighted one.
pub fn outliers(
    problem: &IdentificationProblem<'_>,
    (r, jacobian): (&DVector<f64>, &DMatrix<f64>),
    variances: &[f64],
    kept: &[usize],
    kind: FitKind,
) -> (Vec<RowOutlier>, Option<f64>) {
    let (m, n) = (kept.len(), jacobian.ncols());
    if m <= n + 1 || variances.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
        return (Vec::new(), None);
    }
    let e: Vec<f64> = kept.iter().map(|&i| r[i] / variances[i].sqrt()).collect();
    let scaled = DMatrix::from_fn(m, n, |k, j| {
        jacobian[(kept[k], j)] / variances[kept[k]].sqrt()
    });
    let (t, threshold) = match kind {
        FitKind::LeastSquares => (
            studentized(&e, &scaled),
            outlier_threshold(m, Some(m - n - 1)),
        ),
        FitKind::Robust => (robust_t(&e, &scaled), outlier_threshold(m, None)),
    };
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
        // A prior's row is no measurement: it takes part in the leverages, is never flagged.
        .filter(|(k, _)| !places[kept[*k]].prior)
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

/// A robust fit's standardised residuals: `e_i / √(1 − h_ii)` (`e` in declared σ, `h` the
/// leverages of the σ-scaled Jacobian); `None` for a row of leverage 1.
fn robust_t(e: &[f64], scaled: &DMatrix<f64>) -> Vec<Option<f64>> {
    e.iter()
        .zip(leverages(scaled))
        .map(|(ei, hi)| {
            let free = 1.0 - hi;
            (free > 1e-12).then(|| ei / free.sqrt())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use nalgebra::DMatrix;

    use super::{outliers, robust_t, FitKind};
    use crate::identify::problem::IdentificationProblem;
    use crate::identify::statistics::outlier_threshold;
    use crate::measure::observations::read;
    use crate::model::Mechanism;

    /// The test needs every residual's declared variance: one that is zero or not finite
    /// leaves nothing to divide by, and no residual is tested (no threshold either); the same
    /// residuals with positive variances get a threshold. And without redundancy (`m ≤ n + 1`
    /// kept residuals) there is no test.
    #[test]
    fn no_residual_is_tested_without_a_positive_finite_variance_or_redundancy() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mechanism = Mechanism::load(&root.join("models/5r-tracker.yaml")).unwrap();
        let observations = read(&root.join("examples/data/5r-tracker.csv"), &mechanism).unwrap();
        let problem = IdentificationProblem::through_instrument(&mechanism, &observations).unwrap();
        let (r, jacobian) = problem.residuals_and_jacobian(&problem.start()).unwrap();
        let all: Vec<usize> = (0..r.len()).collect();
        let kinds = [FitKind::LeastSquares, FitKind::Robust];
        let positive = vec![1e-8; r.len()];
        for kind in kinds {
            let (_, threshold) = outliers(&problem, (&r, &jacobian), &positive, &all, kind);
            assert!(
                threshold.is_some(),
                "{kind:?}: positive variances are tested"
            );
            // Least squares: Student's t on the m − n − 1 degrees of freedom of a residual
            // left out of its own fit; robust: the normal law.
            let (m, n) = (r.len(), jacobian.ncols());
            let dof = match kind {
                FitKind::LeastSquares => Some(m - n - 1),
                FitKind::Robust => None,
            };
            assert_eq!(threshold, outlier_threshold(m, dof), "{kind:?}");
            for bad in [0.0, f64::INFINITY, f64::NAN, -1e-8] {
                let mut variances = positive.clone();
                variances[3] = bad;
                let (flagged, threshold) =
                    outliers(&problem, (&r, &jacobian), &variances, &all, kind);
                assert!(flagged.is_empty() && threshold.is_none(), "{kind:?} {bad}");
            }
            let few: Vec<usize> = (0..=jacobian.ncols()).collect();
            let (_, threshold) = outliers(&problem, (&r, &jacobian), &positive, &few, kind);
            assert!(threshold.is_none(), "{kind:?}: n + 1 kept residuals");
            let enough: Vec<usize> = (0..jacobian.ncols() + 2).collect();
            let (_, threshold) = outliers(&problem, (&r, &jacobian), &positive, &enough, kind);
            assert!(threshold.is_some(), "{kind:?}: n + 2 kept residuals");
        }
    }

    /// Four rows fitting one mean: each leverage is 1/4, so each residual (in σ) is divided by
    /// √(3/4); a row of leverage 1 (the only one seeing its own unknown) has none.
    #[test]
    fn robust_t_divides_by_the_room_the_leverage_leaves() {
        let scaled = DMatrix::from_element(4, 1, 1.0);
        let t = robust_t(&[0.3, -0.6, 0.9, 0.0], &scaled);
        for (got, e) in t.iter().zip([0.3, -0.6, 0.9, 0.0]) {
            let got = got.expect("a leverage below 1");
            assert!((got - e / 0.75f64.sqrt()).abs() < 1e-15, "{got} vs {e}");
        }
        let lone = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1.0]);
        assert_eq!(robust_t(&[0.5, 0.5], &lone), [None, None]);
    }
}
