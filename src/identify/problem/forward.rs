//! Forward rows: residual blocks that predict what an instrument saw from every leg's reading,
//! through the forward kinematics of the whole mechanism (`instrument.kinematics: forward`).
//!
//! A row holds one reading per leg `s` and the target coordinates `y` the instrument reported
//! (a probe's height, one reflector's position). At the unknowns `φ` (every leg's identified
//! parameters) and the shared ones `θ` (the instrument frame, or the bed plane, and the target
//! offsets), the platform pose `P(s, φ)` is the one that closes every leg in the model's
//! assembly mode ([`ForwardKinematics::solve_near`], warm-started from the row's last
//! configuration), and the residual is `h(P, θ) − y`, `h` the instrument's report
//! ([`observe_in`]).
//!
//! Derivatives by the implicit function theorem, never through Newton's iterations: at the
//! closed pose every leg's inverse kinematics gives back its reading, `ψ_l(P, φ_l) = s_l`, so
//! with `A = ∂ψ/∂P` (one row per leg, over the measured pose coordinates) `∂P/∂φ_l =
//! −A⁻¹ e_l ∂ψ_l/∂φ_l` and `∂P/∂s = A⁻¹`. `∂ψ_l/∂φ_l` is the inverse rows' own dual pass
//! ([`PreparedLeg::reading_and_gradient_of`]), `∂ψ_l/∂P` their pose gradient
//! ([`PreparedLeg::pose_gradient_of`]), and `∂h/∂P`, `∂h/∂θ` one dual pass of [`observe_in`]
//! per column. So `∂r/∂φ_l = −G e_l ∂ψ_l/∂φ_l` and `∂r/∂s = G` with `G = ∂h/∂P A⁻¹`.

use std::sync::{Arc, Mutex};

use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

use super::{BlockError, IdentificationProblem};
use crate::error::KinematicsError;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::inverse::joints;
use crate::kinematics::platform::{Configuration, ForwardKinematics};
use crate::measure::targets::observe_in;
use crate::model::mechanism::MeasurementNoise;

/// One forward row: every leg's reading and what the instrument reported there.
#[derive(Debug, Clone)]
pub(super) struct ForwardRow {
    /// The row's index in the observations.
    pub(super) source: usize,
    /// Line in the measurement file, if read from one.
    pub(super) line: Option<usize>,
    /// One reading per leg of the mechanism.
    pub(super) readings: Vec<f64>,
    /// The targets' coordinates, in measurement-row order.
    pub(super) observed: Vec<f64>,
}

/// The forward rows of a problem and their warm starts.
#[derive(Debug, Clone)]
pub(super) struct Forward {
    /// The rows (shared by the problem's clones).
    pub(super) rows: Arc<Vec<ForwardRow>>,
    /// Each row's configuration at its last solve (the next one's start), shared by the
    /// problem's clones (evaluated one after the other, never at once).
    pub(super) starts: Arc<Mutex<Vec<Option<Configuration>>>>,
}

impl Forward {
    /// The forward part of a problem over `rows`.
    pub(super) fn new(rows: Vec<ForwardRow>) -> Self {
        let starts = vec![None; rows.len()];
        Self {
            rows: Arc::new(rows),
            starts: Arc::new(Mutex::new(starts)),
        }
    }

    /// The same rows with fresh warm starts (a derived problem starts its own).
    pub(super) fn renewed(&self) -> Self {
        Self::new(self.rows.to_vec())
    }
}

/// One predicted coordinate's derivatives: with respect to the unknowns (in the order of `x`),
/// then to each leg's reading.
type CoordinateDerivatives = (Vec<f64>, Vec<f64>);

/// What one evaluation of the forward rows gives: the residuals, and on request their
/// derivatives with respect to the unknowns and to the readings.
pub(super) struct ForwardEvaluation {
    /// `h(P, θ) − y`, row after row, every coordinate of a row.
    pub(super) residuals: Vec<f64>,
    /// `∂r/∂x` (one row per residual), if asked for.
    pub(super) jacobian: Option<DMatrix<f64>>,
    /// `∂r/∂s` per residual, over the row's readings (one per leg), if the Jacobian was asked
    /// for.
    pub(super) reading_gradients: Vec<Vec<f64>>,
}

impl IdentificationProblem<'_> {
    /// Every leg's full parameter vector at the unknowns `x` (legs without a slot nominal).
    fn all_leg_parameters(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        let mut params = self.mechanism.nominal_parameters();
        for slot in &self.slots {
            params[slot.leg] = self.leg_parameters(slot, x);
        }
        params
    }

    /// The forward rows evaluated at `x`: residuals, and with `jacobian` their derivatives.
    ///
    /// # Errors
    /// The first row whose forward kinematics does not close (beyond reach, or only in
    /// another assembly mode), or whose legs' inverse kinematics fail at the closed pose.
    pub(super) fn evaluate_forward(
        &self,
        x: &DVector<f64>,
        jacobian: bool,
    ) -> Result<ForwardEvaluation, BlockError> {
        let mechanism = self.mechanism;
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok(ForwardEvaluation {
                residuals: Vec::new(),
                jacobian: None,
                reading_gradients: Vec::new(),
            });
        };
        let params = self.all_leg_parameters(x);
        let shared = sighted.values(x.as_slice());
        let kinematics = ForwardKinematics::new(mechanism, &params);
        let per_row = sighted.instrument.observed_len();
        let m = forward.rows.len() * per_row;
        let mut residuals = Vec::with_capacity(m);
        let mut matrix = jacobian.then(|| DMatrix::zeros(m, self.parameter_count()));
        let mut reading_gradients = Vec::new();
        let prepared: Vec<PreparedLeg<'_>> = if jacobian {
            mechanism
                .legs
                .iter()
                .enumerate()
                .map(|(l, leg)| {
                    let columns = self.slot_of_leg[l].map_or(&[][..], |s| &self.slots[s].columns);
                    PreparedLeg::new(leg, &params[l], columns)
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut starts = self.forward_starts(forward);
        for (index, row) in forward.rows.iter().enumerate() {
            let fail = |source: KinematicsError| self.forward_error(index, source, x);
            let start = &mut starts[index];
            let pose = match start {
                Some(configuration) => kinematics.solve_near(&row.readings, configuration),
                None => {
                    let mut configuration = self.home_configuration();
                    let pose = kinematics.solve_near(&row.readings, &mut configuration);
                    *start = Some(configuration);
                    pose
                }
            }
            .map_err(fail)?;
            // solve_near falls back to a continuation from home: keep what it closed at.
            if let Some(configuration) = start.as_mut() {
                configuration.pose = pose;
            }
            let predicted = observe_in::<f64>(sighted.instrument, &shared, &pose);
            residuals.extend(predicted.iter().zip(&row.observed).map(|(p, y)| p - y));
            if let Some(matrix) = matrix.as_mut() {
                let configuration = start.as_ref().map(|c| c.joints.clone());
                let derivatives = self
                    .row_derivatives_forward((&prepared, &shared), &pose, configuration.as_deref())
                    .map_err(fail)?;
                let first = index * per_row;
                for (o, (columns, readings)) in derivatives.into_iter().enumerate() {
                    for (j, value) in columns.into_iter().enumerate() {
                        matrix[(first + o, j)] = value;
                    }
                    reading_gradients.push(readings);
                }
            }
        }
        Ok(ForwardEvaluation {
            residuals,
            jacobian: matrix,
            reading_gradients,
        })
    }

    /// The rows' warm starts (a poisoned lock only loses them).
    fn forward_starts<'f>(
        &self,
        forward: &'f Forward,
    ) -> std::sync::MutexGuard<'f, Vec<Option<Configuration>>> {
        forward
            .starts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The mechanism at home: the start of a row's first forward solve.
    fn home_configuration(&self) -> Configuration {
        Configuration {
            pose: self.mechanism.home_pose,
            joints: self
                .mechanism
                .legs
                .iter()
                .map(|l| joints(&l.home_joints))
                .collect(),
        }
    }

    /// Per coordinate of one row at its closed pose `pose`: its derivatives with respect to
    /// the unknowns (in the order of `x`) and to each leg's reading (see the module's
    /// documentation).
    fn row_derivatives_forward(
        &self,
        (prepared, shared): (&[PreparedLeg<'_>], &[f64]),
        pose: &[f64; 6],
        configuration: Option<&[crate::kinematics::inverse::Joints]>,
    ) -> Result<Vec<CoordinateDerivatives>, KinematicsError> {
        let mechanism = self.mechanism;
        let sighted = self
            .sighted
            .as_ref()
            .expect("forward rows see an instrument");
        let measured = &mechanism.measured;
        let n = measured.len();
        let legs = mechanism.legs.len();
        if legs != n {
            return Err(KinematicsError::NotAssemblable {
                residual: f64::INFINITY,
            });
        }
        // A = ∂ψ/∂P over the measured coordinates, and each leg's ∂ψ_l/∂φ_l.
        let mut a = DMatrix::zeros(legs, n);
        let mut own: Vec<Vec<f64>> = Vec::with_capacity(legs);
        let home = &mechanism.home_pose;
        for (l, leg) in prepared.iter().enumerate() {
            let seed = configuration.map(|c| &c[l]);
            let solution = leg.solve_warm(pose, home, seed)?;
            let mut gradient = vec![0.0; leg.columns()];
            leg.reading_and_gradient_of(pose, &solution, &mut gradient);
            let d = leg.pose_gradient_of(pose, &solution, measured);
            for (j, &c) in measured.iter().enumerate() {
                a[(l, j)] = d[c];
            }
            own.push(gradient);
        }
        let lu = a.lu();
        // ∂h/∂P over the measured coordinates and ∂h/∂θ over the identified shared ones.
        let instrument = sighted.instrument;
        let lifted = |values: &[f64]| values.iter().map(|&v| Dual64::from(v)).collect::<Vec<_>>();
        let coordinates = instrument.observed_len();
        let mut h_pose = DMatrix::zeros(coordinates, n);
        for (j, &c) in measured.iter().enumerate() {
            let mut seeded = pose.map(Dual64::from);
            seeded[c] = seeded[c].derivative();
            let report = observe_in(instrument, &lifted(shared), &seeded);
            for (o, value) in report.iter().enumerate() {
                h_pose[(o, j)] = value.eps;
            }
        }
        let mut h_shared = DMatrix::zeros(coordinates, sighted.shared.len());
        for (j, &k) in sighted.shared.iter().enumerate() {
            let mut seeded = lifted(shared);
            seeded[k] = seeded[k].derivative();
            let report = observe_in(instrument, &seeded, &pose.map(Dual64::from));
            for (o, value) in report.iter().enumerate() {
                h_shared[(o, j)] = value.eps;
            }
        }
        // G = ∂h/∂P A⁻¹: Gᵀ = A⁻ᵀ (∂h/∂P)ᵀ.
        let g = lu
            .solve(&DMatrix::identity(n, n))
            .map(|inverse| &h_pose * inverse)
            .filter(|g| g.iter().all(|v| v.is_finite()))
            .ok_or(KinematicsError::AssemblyModeChange)?;
        let first_shared = self.parameter_count() - sighted.shared.len();
        Ok((0..coordinates)
            .map(|o| {
                let mut columns = vec![0.0; self.parameter_count()];
                for slot in &self.slots {
                    for (k, &value) in own[slot.leg].iter().enumerate() {
                        columns[slot.offset + k] = -g[(o, slot.leg)] * value;
                    }
                }
                for j in 0..sighted.shared.len() {
                    columns[first_shared + j] = h_shared[(o, j)];
                }
                let readings = (0..legs).map(|l| g[(o, l)]).collect();
                (columns, readings)
            })
            .collect())
    }

    /// The error of forward row `index` at the unknowns `x`, located.
    fn forward_error(&self, index: usize, source: KinematicsError, x: &DVector<f64>) -> BlockError {
        let row = self
            .forward
            .as_ref()
            .map(|f| &f.rows[index])
            .expect("a forward row");
        let location = match row.line {
            Some(line) => {
                format!("the forward kinematics of every leg's reading (measurement line {line})")
            }
            None => format!("the forward kinematics of every leg's reading (row {index})"),
        };
        BlockError {
            block: self.blocks.len() + index,
            source,
            location,
            parameters: self.trial_parameters(x),
        }
    }

    /// The loadings of the declared `noise` on the forward residuals at `x`: per residual, its
    /// row (one measurement) and, over the row's target coordinates then its readings,
    /// `σ ∂r/∂·` (a coordinate's own residual `σ_i`, the readings' `σ_q G`).
    ///
    /// # Errors
    /// As [`Self::evaluate_forward`].
    pub(super) fn forward_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<Vec<(usize, Vec<f64>)>, BlockError> {
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok(Vec::new());
        };
        let evaluation = self.evaluate_forward(x, true)?;
        let sigmas: Vec<f64> = sighted
            .instrument
            .targets
            .iter()
            .flat_map(|t| t.pose_indices())
            .map(|&c| noise.pose[c])
            .collect();
        let per_row = sigmas.len();
        let mut rows = Vec::with_capacity(evaluation.residuals.len());
        for (i, readings) in evaluation.reading_gradients.iter().enumerate() {
            let (row, o) = (i / per_row, i % per_row);
            let mut loading = vec![0.0; per_row + readings.len()];
            loading[o] = sigmas[o];
            for (l, g) in readings.iter().enumerate() {
                loading[per_row + l] = noise.reading * g;
            }
            rows.push((forward.rows[row].source, loading));
        }
        Ok(rows)
    }
}
