//! The problem as argmin and the Schur-complement solver take it: `Operator` (the residuals),
//! `Jacobian` (dual numbers) and [`BorderedLeastSquares`] (each leg's rows one group, the shared
//! parameters its border; forward rows couple every leg: one group of all the legs' columns),
//! and a leg's rows and columns of the Jacobian.

use argmin::core::{Error as ArgminError, Jacobian, Operator};
use std::borrow::Cow;

use nalgebra::{DMatrix, DVector};

use super::residuals::Column;
use super::{IdentificationProblem, LegSlot};
use crate::solver::bordered::{BorderedBlock, BorderedLayout, BorderedLeastSquares};

impl BorderedLeastSquares for IdentificationProblem<'_> {
    fn layout(&self) -> BorderedLayout {
        if self.forward.is_some() || self.priors_couple_groups() {
            // Every forward row couples every leg (as a prior row may): one group of all the
            // legs' columns.
            return BorderedLayout {
                own: vec![self.own_columns()],
                shared: self.shared_columns().len(),
            };
        }
        BorderedLayout {
            own: self.slots.iter().map(|s| s.columns.len()).collect(),
            shared: self.shared_columns().len(),
        }
    }

    /// Each slot's rows: their residuals, their derivatives with respect to the slot's own
    /// columns and to the shared ones.
    fn bordered(&self, x: &DVector<f64>) -> std::result::Result<Vec<BorderedBlock>, ArgminError> {
        if self.forward.is_some() || self.priors_couple_groups() {
            let (r, jacobian) = self.residuals_and_jacobian(x)?;
            let own = self.own_columns();
            return Ok(vec![BorderedBlock {
                own: jacobian.columns(0, own).into_owned(),
                shared: jacobian.columns(own, jacobian.ncols() - own).into_owned(),
                residuals: r,
            }]);
        }
        let matches = self.turn_matches(x);
        let s = self.shared_columns().len();
        let blocks = self.evaluated(x, true, |evaluation| {
            let block = |(group, slot): (usize, &LegSlot)| {
                let rows = self.rows_of(slot);
                let mut block = BorderedBlock {
                    residuals: DVector::zeros(rows.len()),
                    own: DMatrix::zeros(rows.len(), slot.columns.len()),
                    shared: DMatrix::zeros(rows.len(), s),
                };
                for (row, &i) in rows.iter().enumerate() {
                    let (own, shared) = (&mut block.own, &mut block.shared);
                    block.residuals[row] =
                        self.row_derivatives((i, evaluation, &matches), |column, g| match column {
                            Column::Own(k) => own[(row, k)] = g,
                            Column::Shared(k) => shared[(row, k)] = g,
                        });
                }
                // The leg's priors: rows of its own group, after its data's.
                let priors = self.group_prior_rows(group, x, self.blocks.len());
                if !priors.is_empty() {
                    let (m, count) = (rows.len(), rows.len() + priors.len());
                    block.residuals = block.residuals.clone().resize_vertically(count, 0.0);
                    block.own = block.own.clone().resize_vertically(count, 0.0);
                    block.shared = block.shared.clone().resize_vertically(count, 0.0);
                    for (k, (own, shared, residual)) in priors.into_iter().enumerate() {
                        block.residuals[m + k] = residual;
                        for (column, derivative) in own {
                            block.own[(m + k, column)] = derivative;
                        }
                        for (column, derivative) in shared {
                            block.shared[(m + k, column)] = derivative;
                        }
                    }
                }
                block
            };
            self.slots.iter().enumerate().map(block).collect()
        })?;
        Ok(blocks)
    }
}

impl Operator for IdentificationProblem<'_> {
    type Param = DVector<f64>;
    type Output = DVector<f64>;

    fn apply(&self, x: &Self::Param) -> Result<Self::Output, ArgminError> {
        Ok(self.residuals(x)?)
    }
}

impl Jacobian for IdentificationProblem<'_> {
    type Param = DVector<f64>;
    type Jacobian = DMatrix<f64>;

    fn jacobian(&self, x: &Self::Param) -> Result<Self::Jacobian, ArgminError> {
        Ok(self.residuals_and_jacobian(x)?.1)
    }
}

impl IdentificationProblem<'_> {
    /// The rows and columns of the leg in `slot` of the problem's Jacobian `c`: borrowed
    /// when they are all of it (a problem of one leg, whose slot starts at column 0), else
    /// copied.
    pub fn slot_jacobian<'c>(&self, slot: &LegSlot, c: &'c DMatrix<f64>) -> Cow<'c, DMatrix<f64>> {
        let n = slot.columns.len();
        if self.slots.len() == 1 && c.ncols() == n {
            return Cow::Borrowed(c);
        }
        // Forward rows are every leg's: all the rows.
        let rows: Vec<usize> = match self.forward {
            Some(_) => (0..c.nrows()).collect(),
            None => self.rows_of(slot),
        };
        Cow::Owned(DMatrix::from_fn(rows.len(), n, |i, j| {
            c[(rows[i], slot.offset + j)]
        }))
    }

    /// Row indices of the blocks of the leg in `slot`.
    pub fn rows_of(&self, slot: &LegSlot) -> Vec<usize> {
        (0..self.blocks.len())
            .filter(|&i| self.blocks[i].leg == slot.leg)
            .collect()
    }
}
