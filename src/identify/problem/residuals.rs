//! The residuals of the inverse-kinematics blocks and their derivatives: each block's platform
//! (measured, or fitted from the targets an instrument saw), its leg's predicted reading matched
//! modulo one turn of a revolute actuator, weighted rows, the row-by-row derivatives the dense
//! Jacobian and the bordered layout are made of, and the message of a block that fails.

use nalgebra::{DMatrix, DVector};

use super::state::Evaluation;
use super::{BlockError, IdentificationProblem, LegSlot, Placed};
use crate::error::{KinematicsError, Result};
use crate::identify::residual::{turn_in_reading_units, turns};
use crate::measure::targets::platform_pose;
use crate::model::params::ParamTarget;

/// What turn matching needs of one slot's leg at one parameter vector.
#[derive(Debug, Clone, Copy)]
pub(super) struct TurnMatch {
    gain: f64,
    /// Position of the gain among the slot's identified columns, if identified.
    gain_column: Option<usize>,
    revolute: bool,
}

impl<'a> IdentificationProblem<'a> {
    /// Block `index`'s platform: its measured pose (its transform kept), or the pose fitted
    /// from its targets at the shared values `shared`.
    pub(super) fn placed(&self, index: usize, shared: &[f64]) -> Placed {
        match self.sighting() {
            Some(sighted) => {
                let observed = &sighted.rows[index].observed;
                let home = &self.mechanism.home_pose;
                Placed::at(platform_pose::<f64>(
                    sighted.instrument,
                    shared,
                    observed,
                    home,
                ))
            }
            None => {
                let pose = self.blocks[index].pose;
                match self.platforms.get(index) {
                    Some(&platform) => Placed { pose, platform },
                    None => Placed::at(pose),
                }
            }
        }
    }

    /// Each slot's gain and whether its actuator turns, at the unknowns `x`.
    pub(super) fn turn_matches(&self, x: &DVector<f64>) -> Vec<TurnMatch> {
        self.slots
            .iter()
            .map(|slot| {
                let leg = &self.mechanism.legs[slot.leg];
                TurnMatch {
                    gain: self.gain_at(slot, x),
                    gain_column: slot
                        .columns
                        .iter()
                        .position(|&c| leg.params[c].target == ParamTarget::Gain),
                    revolute: leg.actuated_is_revolute(),
                }
            })
            .collect()
    }

    /// The actuator gain of the leg in `slot` at the unknowns `x`: the value
    /// [`crate::model::leg::LegModel::geometry`] of [`Self::leg_parameters`] gives it (the last
    /// gain parameter's, else the leg's own), without building the geometry.
    pub(super) fn gain_at(&self, slot: &LegSlot, x: &DVector<f64>) -> f64 {
        let leg = &self.mechanism.legs[slot.leg];
        let mut gain = leg.gain;
        for (c, param) in leg.params.iter().enumerate() {
            if param.target == ParamTarget::Gain {
                gain = match slot.columns.iter().rposition(|&k| k == c) {
                    Some(k) => x[slot.offset + k],
                    None => param.nominal,
                };
            }
        }
        gain
    }

    /// `√w` of row `row` (1 when unweighted).
    pub fn row_scale(&self, row: usize) -> f64 {
        self.row_scales
            .as_ref()
            .and_then(|s| s.get(row))
            .copied()
            .unwrap_or(1.0)
    }

    /// The forward rows' residuals (of [`Self::evaluate_forward`]), each times its `√w`
    /// (after the blocks' `first` rows), and their Jacobian rows likewise if given.
    fn weigh_forward(
        &self,
        first: usize,
        residuals: &mut [f64],
        jacobian: Option<&mut DMatrix<f64>>,
    ) {
        if self.row_scales.is_none() {
            return;
        }
        for (k, r) in residuals.iter_mut().enumerate() {
            *r *= self.row_scale(first + k);
        }
        if let Some(jacobian) = jacobian {
            for k in 0..jacobian.nrows() {
                let scale = self.row_scale(first + k);
                jacobian.row_mut(k).scale_mut(scale);
            }
        }
    }

    /// Residuals `predicted − measured` reading (matched modulo one turn, times `√w_i` if
    /// weighted), one per block, then a forward problem's rows, then the priors' rows
    /// (`problem/prior_rows.rs`).
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn residuals(&self, x: &DVector<f64>) -> Result<DVector<f64>, BlockError> {
        let data = self.data_residuals(x)?;
        Ok(self.with_prior_residuals(data, x))
    }

    /// The data's residuals (of [`Self::residuals`]): the blocks', then the forward rows'.
    fn data_residuals(&self, x: &DVector<f64>) -> Result<DVector<f64>, BlockError> {
        let blocks = self.block_residuals(x)?;
        if self.forward.is_none() {
            return Ok(blocks);
        }
        // The blocks' rows, then the forward rows'.
        let mut forward = self.evaluate_forward(x, false)?.residuals;
        self.weigh_forward(blocks.len(), &mut forward, None);
        if blocks.is_empty() {
            return Ok(DVector::from_vec(forward));
        }
        let count = blocks.len() + forward.len();
        Ok(DVector::from_iterator(
            count,
            blocks.iter().copied().chain(forward),
        ))
    }

    /// The blocks' residuals (of [`Self::residuals`]).
    fn block_residuals(&self, x: &DVector<f64>) -> Result<DVector<f64>, BlockError> {
        if self.blocks.is_empty() {
            return Ok(DVector::zeros(0));
        }
        let matches = self.turn_matches(x);
        self.evaluated(x, false, |evaluation| {
            DVector::from_iterator(
                self.blocks.len(),
                self.blocks.iter().enumerate().map(|(i, block)| {
                    let predicted = evaluation.predicted[i];
                    let m = matches[self.slot_of_leg[block.leg].unwrap_or_default()];
                    let n = turns(predicted, block.reading, m.gain, m.revolute);
                    self.row_scale(i)
                        * (predicted - block.reading - n * turn_in_reading_units(m.gain))
                }),
            )
        })
    }

    /// Whole turns of the actuated joint removed from each block's residual at `x` (zero for
    /// prismatic actuators): non-zero where the readings sit on another turn than the leg's
    /// home value.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn turns(&self, x: &DVector<f64>) -> Result<Vec<f64>, BlockError> {
        let matches = self.turn_matches(x);
        self.evaluated(x, false, |evaluation| {
            self.blocks
                .iter()
                .zip(&evaluation.predicted)
                .map(|(block, &predicted)| {
                    let m = matches[self.slot_of_leg[block.leg].unwrap_or_default()];
                    turns(predicted, block.reading, m.gain, m.revolute)
                })
                .collect()
        })
    }

    /// Row `i`'s residual at `evaluation` (turn-matched, times `√w_i`), each of its
    /// derivatives passed to `put`.
    pub(super) fn row_derivatives(
        &self,
        (i, evaluation, matches): (usize, &Evaluation, &[TurnMatch]),
        mut put: impl FnMut(Column, f64),
    ) -> f64 {
        let block = &self.blocks[i];
        let s = self.slot_of_leg[block.leg].unwrap_or_default();
        let own = self.own_width();
        let width = own + self.shared_columns().len();
        let gradient = &evaluation.gradients[i * width..(i + 1) * width];
        let predicted = evaluation.predicted[i];
        let tm = matches[s];
        let n = turns(predicted, block.reading, tm.gain, tm.revolute);
        let turn = turn_in_reading_units(tm.gain);
        let scale = self.row_scale(i);
        for (k, &g) in gradient[..self.slots[s].columns.len()].iter().enumerate() {
            let mut g = g;
            if tm.gain_column == Some(k) && n != 0.0 {
                // d(−n·2π/gain)/d gain = n·2π/gain².
                g += n * turn / tm.gain;
            }
            put(Column::Own(k), g * scale);
        }
        for (j, &g) in gradient[own..].iter().enumerate() {
            put(Column::Shared(j), g * scale);
        }
        scale * (predicted - block.reading - n * turn)
    }

    /// Residuals and the identification Jacobian ∂r/∂x (block-structured: a block's row is
    /// non-zero only in its own leg's columns and the shared ones), from one dual pass per
    /// block; the rows as [`Self::residuals`]'.
    ///
    /// # Errors
    /// The first block whose leg cannot reach its pose.
    pub fn residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        let data = self.data_residuals_and_jacobian(x)?;
        Ok(self.with_prior_rows(data, x))
    }

    /// The data's residuals and Jacobian (of [`Self::residuals_and_jacobian`]).
    fn data_residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        let (r, jacobian) = self.block_residuals_and_jacobian(x)?;
        if self.forward.is_none() {
            return Ok((r, jacobian));
        }
        // The blocks' rows, then the forward rows'.
        let mut forward = self.evaluate_forward(x, true)?;
        let mut below = forward
            .jacobian
            .take()
            .unwrap_or_else(|| DMatrix::zeros(0, self.parameter_count()));
        self.weigh_forward(r.len(), &mut forward.residuals, Some(&mut below));
        if r.is_empty() {
            return Ok((DVector::from_vec(forward.residuals), below));
        }
        let (m, count) = (r.len(), forward.residuals.len());
        let mut stacked = DMatrix::zeros(m + count, self.parameter_count());
        stacked.rows_mut(0, m).copy_from(&jacobian);
        stacked.rows_mut(m, count).copy_from(&below);
        let all = r.iter().copied().chain(forward.residuals);
        Ok((DVector::from_iterator(m + count, all), stacked))
    }

    /// The blocks' residuals and Jacobian (of [`Self::residuals_and_jacobian`]).
    fn block_residuals_and_jacobian(
        &self,
        x: &DVector<f64>,
    ) -> Result<(DVector<f64>, DMatrix<f64>), BlockError> {
        if self.blocks.is_empty() {
            return Ok((DVector::zeros(0), DMatrix::zeros(0, self.parameter_count())));
        }
        let matches = self.turn_matches(x);
        let (m, p, first) = (
            self.blocks.len(),
            self.parameter_count(),
            self.own_columns(),
        );
        self.evaluated(x, true, |evaluation| {
            let mut r = DVector::zeros(m);
            let mut jacobian = DMatrix::zeros(m, p);
            // Column-major: entry (i, j) at i + j·m.
            let entries = jacobian.as_mut_slice();
            for (i, block) in self.blocks.iter().enumerate() {
                let offset = self.slots[self.slot_of_leg[block.leg].unwrap_or_default()].offset;
                r[i] = self.row_derivatives((i, evaluation, &matches), |column, g| {
                    let j = match column {
                        Column::Own(k) => offset + k,
                        Column::Shared(k) => first + k,
                    };
                    entries[i + j * m] = g;
                });
            }
            (r, jacobian)
        })
    }

    /// The error of block `block` at the unknowns `x`, located (file line or block) and with the
    /// trial parameter values.
    pub fn block_error(
        &self,
        block: usize,
        source: KinematicsError,
        x: &DVector<f64>,
    ) -> BlockError {
        let mut location = match self.blocks[block].line {
            Some(line) => format!("measurement line {line}"),
            None => format!("residual block {block}"),
        };
        if self.sighting().is_some() {
            let leg = &self.mechanism.legs[self.blocks[block].leg].name;
            location = format!("leg `{leg}` at the pose fitted from the targets ({location})");
        }
        BlockError {
            block,
            source,
            location,
            parameters: self.trial_parameters(x),
        }
    }

    /// The unknowns `x` by name, `name = value, …`, for a message.
    pub(super) fn trial_parameters(&self, x: &DVector<f64>) -> String {
        self.names()
            .iter()
            .zip(x.iter())
            .map(|(name, &value)| format!("{name} = {}", short(value)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A parameter value for messages: six decimals for ordinary magnitudes, else scientific.
fn short(value: f64) -> String {
    if value == 0.0 || (1e-3..1e6).contains(&value.abs()) {
        format!("{value:.6}")
    } else {
        format!("{value:.6e}")
    }
}

/// A column of a row's derivatives: the `k`-th identified parameter of its leg, or the
/// `k`-th identified shared parameter.
#[derive(Debug, Clone, Copy)]
pub(super) enum Column {
    Own(usize),
    Shared(usize),
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::short;
    use crate::identify::problem::IdentificationProblem;
    use crate::model::params::ParamTarget;
    use crate::model::Mechanism;

    /// The gain turn matching takes is the leg geometry's at the same unknowns, whether the
    /// gain is identified (its unknown's value) or held (its nominal value, or the leg's own
    /// without a gain parameter).
    #[test]
    fn the_turn_matching_gain_is_the_geometrys() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
        let mechanism = Mechanism::load(&path).unwrap();
        let params = &mechanism.legs[0].params;
        let k = params.iter().position(|p| p.target == ParamTarget::Gain);
        let k = k.expect("the 5R's legs have a gain parameter");
        for (identified, nominal) in [(true, 1.0), (false, 1.25), (false, -0.75)] {
            let mechanism = mechanism.edited(|parts| {
                let param = &mut parts.legs[0].params[k];
                (param.identified, param.nominal) = (identified, nominal);
            });
            let problem = IdentificationProblem::new(&mechanism, &[0], Vec::new());
            let slot = &problem.slots()[0];
            let x = problem.start().map(|v| v * 1.1 + 0.01);
            let geometry = mechanism.legs[0].geometry(&problem.leg_parameters(slot, &x));
            let value = problem.gain_at(slot, &x);
            assert_eq!(
                value.to_bits(),
                geometry.gain.to_bits(),
                "{identified} {nominal}"
            );
            let expected = match slot.columns.iter().position(|&c| c == k) {
                Some(column) => x[column],
                None => nominal,
            };
            assert_eq!(
                value.to_bits(),
                expected.to_bits(),
                "{identified} {nominal}"
            );
            assert_ne!(value.to_bits(), 1.0f64.to_bits(), "{identified} {nominal}");
        }
        // Without a gain parameter: the leg's own gain.
        let mechanism = mechanism.edited(|parts| {
            parts.legs[0].gain = 0.5;
            parts.legs[0].params.remove(k);
        });
        let problem = IdentificationProblem::new(&mechanism, &[0], Vec::new());
        let x = problem.start();
        let value = problem.gain_at(&problem.slots()[0], &x);
        assert_eq!(value.to_bits(), 0.5f64.to_bits());
    }

    #[test]
    fn message_values_have_six_decimals_or_an_exponent() {
        for (value, text) in [
            (0.0, "0.000000"),
            (0.5, "0.500000"),
            (-3.25, "-3.250000"),
            (1e-3, "0.001000"),
            (999_999.0, "999999.000000"),
            (1e6, "1.000000e6"),
            (-2.5e7, "-2.500000e7"),
            (1e-4, "1.000000e-4"),
            (-9.9e-4, "-9.900000e-4"),
            (f64::INFINITY, "inf"),
        ] {
            assert_eq!(short(value), text, "{value}");
        }
    }
}
