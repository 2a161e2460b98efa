//! Priors as residual rows (docs/statistics.md §8): an identified parameter known before any
//! measurement to be `μ ± σ` (model file `prior:`, around its nominal value) adds the row
//! `x_j − μ` of variance `σ²` after the data's rows; a previous calibration (`identify --prior`:
//! estimates `μ` and covariance `Σ` of several parameters) adds the rows `L⁻¹ (x − μ)` of
//! variance 1, `Σ = L Lᵀ` over the parameters the problem identifies (the prior's marginal on
//! them). Weighted by the declared noise, as every row is, the least-squares fit is then the
//! maximum a posteriori one. A row of one leg's parameters belongs to its leg's group of the
//! Schur step; rows that couple legs make the problem one group.

use nalgebra::{DMatrix, DVector};

use super::priors::{GroupPriorRow, PriorRow, PriorSigma, Priors};
use super::{IdentificationProblem, LegSlot};
use crate::model::prior_covariance::PriorCovariance;
use crate::model::Mechanism;

/// The prior rows of the problem's unknowns (`names`, in order; `slots` the legs'): the
/// calibration's rows over the unknowns it names, each other unknown's own `prior:` row.
/// Also each unknown's prior σ.
///
/// # Errors
/// The calibration's covariance over the unknowns it names is not positive definite.
pub(super) fn priors_of(
    mechanism: &Mechanism,
    slots: &[LegSlot],
    names: &[String],
) -> Result<(Vec<PriorRow>, Vec<PriorSigma>), String> {
    let calibration = mechanism.prior_covariance.as_ref();
    let in_calibration =
        |name: &str| calibration.and_then(|c| c.parameters.iter().position(|p| p == name));
    let mut rows = Vec::new();
    let mut sigmas = Vec::new();
    // The calibration's rows first.
    if let Some(calibration) = calibration {
        let covered: Vec<(usize, usize)> = names
            .iter()
            .enumerate()
            .filter_map(|(j, n)| in_calibration(n).map(|k| (j, k)))
            .collect();
        if !covered.is_empty() {
            whitened_rows(calibration, &covered, &mut rows, &mut sigmas)?;
        }
    }
    for slot in slots {
        let leg = &mechanism.legs[slot.leg];
        for (k, &c) in slot.columns.iter().enumerate() {
            let p = &leg.params[c];
            let (Some(sigma), None) = (p.prior, in_calibration(&p.name)) else {
                continue;
            };
            let column = slot.offset + k;
            rows.push(PriorRow {
                terms: vec![(column, 1.0, p.nominal)],
                sigma,
                name: format!("`{}`", p.name),
            });
            sigmas.push(PriorSigma { column, sigma });
        }
    }
    Ok((rows, sigmas))
}

/// The rows `L⁻¹ (x − μ)` of the calibration over the unknowns `covered` (`(column, index in
/// the calibration)`), `Σ = L Lᵀ` their block of its covariance.
fn whitened_rows(
    calibration: &PriorCovariance,
    covered: &[(usize, usize)],
    rows: &mut Vec<PriorRow>,
    sigmas: &mut Vec<PriorSigma>,
) -> Result<(), String> {
    let n = covered.len();
    let block = DMatrix::from_fn(n, n, |a, b| {
        calibration.covariance[(covered[a].1, covered[b].1)]
    });
    let cholesky = block.clone().cholesky().ok_or_else(|| {
        format!(
            "{}: the calibration's covariance of the parameters this fit identifies is not \
             positive definite",
            calibration.source.display()
        )
    })?;
    let whitening = cholesky
        .l()
        .try_inverse()
        .ok_or_else(|| format!("{}: a singular covariance", calibration.source.display()))?;
    for a in 0..n {
        let terms = (0..=a)
            .map(|b| {
                let (column, k) = covered[b];
                (column, whitening[(a, b)], calibration.estimates[k])
            })
            .collect();
        rows.push(PriorRow {
            terms,
            sigma: 1.0,
            name: format!(
                "the calibration {} (row {})",
                calibration.source.display(),
                a + 1
            ),
        });
        sigmas.push(PriorSigma {
            column: covered[a].0,
            sigma: block[(a, a)].sqrt(),
        });
    }
    Ok(())
}

impl IdentificationProblem<'_> {
    /// The prior rows, after the data's rows in the residuals' order.
    pub fn prior_rows(&self) -> &[PriorRow] {
        &self.priors.rows
    }

    /// The prior σ of unknown `column`, if it has a prior.
    pub fn prior_sigma(&self, column: usize) -> Option<f64> {
        let sigmas = self.priors.sigmas.iter();
        sigmas
            .filter(|s| s.column == column)
            .map(|s| s.sigma)
            .next()
    }

    /// The same problem with a row for each identified parameter's prior (model file `prior:`)
    /// and the previous calibration's rows (the model's [`PriorCovariance`]), after the data's
    /// rows: the fit becomes the maximum a posteriori one.
    ///
    /// # Errors
    /// The calibration's covariance over the unknowns it names is not positive definite.
    pub fn with_priors(&self) -> Result<Self, String> {
        let (rows, sigmas) = priors_of(self.mechanism, &self.slots, &self.names())?;
        Ok(Self {
            priors: Priors { rows, sigmas }.into(),
            ..self.clone()
        })
    }

    /// The same problem without its prior rows (a least-squares fit of the data alone, or a
    /// factor set that puts its priors on its own factors).
    pub fn without_priors(&self) -> Self {
        Self {
            priors: Default::default(),
            ..self.clone()
        }
    }

    /// A prior row's value at `x`.
    fn prior_value(row: &PriorRow, x: &DVector<f64>) -> f64 {
        row.terms
            .iter()
            .map(|&(j, w, mean)| w * (x[j] - mean))
            .sum()
    }

    /// `r` (the data's residuals) with the prior rows after them, each times its `√w`.
    pub(super) fn with_prior_residuals(&self, r: DVector<f64>, x: &DVector<f64>) -> DVector<f64> {
        let rows = self.prior_rows();
        if rows.is_empty() {
            return r;
        }
        let first = r.len();
        let mut all = r.resize_vertically(first + rows.len(), 0.0);
        for (k, row) in rows.iter().enumerate() {
            all[first + k] = self.row_scale(first + k) * Self::prior_value(row, x);
        }
        all
    }

    /// The data's residuals `r` and Jacobian `jacobian` with the prior rows after them.
    pub(super) fn with_prior_rows(
        &self,
        (r, jacobian): (DVector<f64>, DMatrix<f64>),
        x: &DVector<f64>,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let rows = self.prior_rows();
        if rows.is_empty() {
            return (r, jacobian);
        }
        let first = r.len();
        let mut stacked = jacobian.resize_vertically(first + rows.len(), 0.0);
        for (k, row) in rows.iter().enumerate() {
            for &(j, w, _) in &row.terms {
                stacked[(first + k, j)] = self.row_scale(first + k) * w;
            }
        }
        (self.with_prior_residuals(r, x), stacked)
    }

    /// The Schur group of a prior row: the slot whose own columns it reads (0 when it reads
    /// shared columns only); `None` when it reads several slots' columns.
    fn prior_group(&self, row: &PriorRow) -> Option<usize> {
        let mut group = None;
        for &(j, _, _) in &row.terms {
            let Some(s) = self
                .slots
                .iter()
                .position(|s| (s.offset..s.offset + s.columns.len()).contains(&j))
            else {
                continue;
            };
            match group {
                Some(g) if g != s => return None,
                _ => group = Some(s),
            }
        }
        Some(group.unwrap_or(0))
    }

    /// Whether some prior row couples two legs' groups (the problem is then one group).
    pub(super) fn priors_couple_groups(&self) -> bool {
        self.prior_rows()
            .iter()
            .any(|r| self.prior_group(r).is_none())
    }

    /// The prior rows of group `group` (a slot) for its Schur block: `(own derivatives, shared
    /// derivatives, residual)`, each times its `√w` (the prior rows starting at row `first`).
    pub(super) fn group_prior_rows(
        &self,
        group: usize,
        x: &DVector<f64>,
        first: usize,
    ) -> Vec<GroupPriorRow> {
        let own = self.own_columns();
        let slot = &self.slots[group];
        self.prior_rows()
            .iter()
            .enumerate()
            .filter(|(_, row)| self.prior_group(row) == Some(group))
            .map(|(k, row)| {
                let scale = self.row_scale(first + k);
                let (mut mine, mut shared) = (Vec::new(), Vec::new());
                for &(j, w, _) in &row.terms {
                    match j >= own {
                        true => shared.push((j - own, scale * w)),
                        false => mine.push((j - slot.offset, scale * w)),
                    }
                }
                (mine, shared, scale * Self::prior_value(row, x))
            })
            .collect()
    }
}
