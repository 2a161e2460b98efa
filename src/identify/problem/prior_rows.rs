//! Priors as residual rows (docs/statistics.md, "Priors"): an identified parameter known before
//! any measurement to be `μ ± σ` (model file `prior:`, around its nominal value) adds the row
//! `x_j − μ` of variance `σ²` after the data's rows. Weighted by the declared noise, as every
//! row is, the least-squares fit is then the maximum a posteriori one: the data's rows by
//! `1/v_i`, the prior's by `1/σ²`. A prior row's derivative is 1 in its own column: it belongs
//! to its leg's group of the Schur step.

use nalgebra::{DMatrix, DVector};

use super::{IdentificationProblem, LegSlot};
use crate::model::Mechanism;

/// One prior: unknown `column` is `mean ± sigma` before any measurement.
#[derive(Debug, Clone, PartialEq)]
pub struct PriorRow {
    /// The unknown's index in the problem's parameter vector.
    pub column: usize,
    /// The prior's mean (the parameter's nominal value), SI units.
    pub mean: f64,
    /// The prior's standard deviation, SI units.
    pub sigma: f64,
    /// The parameter's name.
    pub name: String,
}

/// The prior rows of the identified columns of `slots` (in the order of the unknowns).
fn leg_priors(mechanism: &Mechanism, slots: &[LegSlot]) -> Vec<PriorRow> {
    slots
        .iter()
        .flat_map(|slot| {
            let leg = &mechanism.legs[slot.leg];
            slot.columns.iter().enumerate().filter_map(move |(k, &c)| {
                let p = &leg.params[c];
                p.prior.map(|sigma| PriorRow {
                    column: slot.offset + k,
                    mean: p.nominal,
                    sigma,
                    name: p.name.clone(),
                })
            })
        })
        .collect()
}

impl IdentificationProblem<'_> {
    /// The prior rows, after the data's rows in the residuals' order.
    pub fn prior_rows(&self) -> &[PriorRow] {
        &self.priors
    }

    /// The same problem with a row for each identified parameter's prior (model file
    /// `prior:`), after the data's rows: the fit becomes the maximum a posteriori one.
    pub fn with_priors(&self) -> Self {
        Self {
            priors: leg_priors(self.mechanism, &self.slots).into(),
            ..self.clone()
        }
    }

    /// The same problem without its prior rows (a least-squares fit of the data alone, or a
    /// factor set that puts its priors on its own factors).
    pub fn without_priors(&self) -> Self {
        Self {
            priors: Vec::new().into(),
            ..self.clone()
        }
    }

    /// The prior rows' residuals `x_j − μ` at `x`, each times its `√w` (row `first + k`).
    fn prior_residuals(&self, x: &DVector<f64>, first: usize) -> impl Iterator<Item = f64> + '_ {
        let values: Vec<f64> = self.priors.iter().map(|p| x[p.column] - p.mean).collect();
        values
            .into_iter()
            .enumerate()
            .map(move |(k, v)| v * self.row_scale(first + k))
    }

    /// `r` (the data's residuals) with the prior rows after them.
    pub(super) fn with_prior_residuals(&self, r: DVector<f64>, x: &DVector<f64>) -> DVector<f64> {
        if self.priors.is_empty() {
            return r;
        }
        let first = r.len();
        let count = first + self.priors.len();
        DVector::from_iterator(
            count,
            r.iter().copied().chain(self.prior_residuals(x, first)),
        )
    }

    /// The data's residuals `r` and Jacobian `jacobian` with the prior rows after them.
    pub(super) fn with_prior_rows(
        &self,
        (r, jacobian): (DVector<f64>, DMatrix<f64>),
        x: &DVector<f64>,
    ) -> (DVector<f64>, DMatrix<f64>) {
        if self.priors.is_empty() {
            return (r, jacobian);
        }
        let first = r.len();
        let mut stacked = jacobian.resize_vertically(first + self.priors.len(), 0.0);
        for (k, p) in self.priors.iter().enumerate() {
            stacked[(first + k, p.column)] = self.row_scale(first + k);
        }
        (self.with_prior_residuals(r, x), stacked)
    }

    /// The prior rows of the leg in `slot`, for its Schur group: `(own column, residual,
    /// derivative)`, each times its `√w` (the prior rows starting at row `first`).
    pub(super) fn slot_prior_rows(
        &self,
        slot: &LegSlot,
        x: &DVector<f64>,
        first: usize,
    ) -> Vec<(usize, f64, f64)> {
        let own = slot.offset..slot.offset + slot.columns.len();
        self.priors
            .iter()
            .enumerate()
            .filter(|(_, p)| own.contains(&p.column))
            .map(|(k, p)| {
                let scale = self.row_scale(first + k);
                (
                    p.column - slot.offset,
                    scale * (x[p.column] - p.mean),
                    scale,
                )
            })
            .collect()
    }
}
