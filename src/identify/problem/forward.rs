//! Forward rows: residual blocks that predict what an instrument saw from every leg's reading,
//! through the forward kinematics of the whole mechanism (`instrument.kinematics: forward`).
//!
//! A row holds one reading per leg `s` and the target coordinates `y` the instrument reported
//! (a probe's height, one reflector's position). At the unknowns `φ` (every leg's identified
//! parameters) and the shared ones `θ` (the instrument frame, or the bed plane, and the target
//! offsets), the platform pose `P(s, φ)` is the one that closes every leg in the model's
//! assembly mode ([`ForwardKinematics::solve_near_closed`], warm-started from the row's last
//! configuration), and the residual is `h(P, θ) − y`, `h` the instrument's report
//! ([`crate::measure::targets::observe_in`]).
//!
//! Derivatives by the implicit function theorem, never through Newton's iterations: at the
//! closed pose every leg's inverse kinematics gives back its reading, `ψ_l(P, φ_l) = s_l`, so
//! with `A = ∂ψ/∂P` (one row per leg, over the measured pose coordinates) `∂P/∂φ_l =
//! −A⁻¹ e_l ∂ψ_l/∂φ_l` and `∂P/∂s = A⁻¹`. `∂ψ_l/∂φ_l` is the inverse rows' own dual pass
//! ([`PreparedLeg::reading_and_gradient_of`]), `∂ψ_l/∂P` their pose gradient
//! ([`PreparedLeg::pose_gradient_of`]), and `∂h/∂P`, `∂h/∂θ` multi-lane dual passes of
//! [`observe_in`](crate::measure::targets::observe_in), every column on its own lane
//! (`problem/instrument_derivatives.rs`). So `∂r/∂φ_l = −G e_l ∂ψ_l/∂φ_l` and `∂r/∂s = G` with
//! `G = ∂h/∂P A⁻¹`.
//!
//! A distance row (`instrument.distances`) joins one target's base-frame positions `X_a`, `X_b`
//! at two rows (each row's own pose): residual `|X_a − X_b| − d`, derivatives by the same chain
//! through both rows' poses, `u·(∂X_a/∂P_a ∂P_a/∂x − ∂X_b/∂P_b ∂P_b/∂x)` with `u` the unit
//! vector from `X_b` to `X_a` (and the target offset's own columns). A row may carry readings
//! and no coordinates when only distances name it.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::forward_rows::{Forward, ForwardEvaluation, ForwardRow, Latest};
use super::instrument_derivatives::{Derivatives, PoseFunction, PreparedFunction};
use super::noise::coordinate_sigmas;
use super::pose_moves::{pose_moves, Moves, RowsMoves};
use super::{BlockError, IdentificationProblem};
use crate::error::KinematicsError;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::platform::{Configuration, ForwardKinematics};
use crate::kinematics::KernelRows;
use crate::model::mechanism::MeasurementNoise;

/// Forward rows closed by one task at least (a row is a few microseconds: fewer would spend
/// more on scheduling than on the rows).
const ROWS_PER_TASK: usize = 4;

/// Forward rows from which they are closed on every core: waking the threads costs about
/// what a few dozen rows do (docs/benchmarks.md, the forward benches).
const PARALLEL_ROWS: usize = 64;

/// Rows closed already at the unknowns: their poses and their legs' kernel rows there (taken
/// from the latest evaluation, not copied).
pub(super) type KnownRows = (Vec<[f64; 6]>, Vec<Option<KernelRows>>);

/// One row as closed: its readings and start, and where its pose and its legs' kernel rows
/// are written.
type RowSlots<'r> = (
    (&'r ForwardRow, &'r mut Option<Configuration>),
    (&'r mut [f64; 6], &'r mut Option<KernelRows>),
);

/// Every row's closed pose and, for the Jacobian, how it moves ([`Moves`]), row after row.
pub(super) struct ClosedRows {
    pub(super) poses: Vec<[f64; 6]>,
    /// Each row's legs' kernel rows at its pose, if the forward solve evaluated them there.
    pub(super) rows: Vec<Option<KernelRows>>,
    /// Each row's movements; empty when they were not asked for.
    pub(super) moves: RowsMoves,
}

impl IdentificationProblem<'_> {
    /// Every leg's full parameter vector at the unknowns `x` (legs without a slot nominal).
    pub(super) fn all_leg_parameters(&self, x: &DVector<f64>) -> Vec<Vec<f64>> {
        let mut params = self.mechanism.nominal_parameters();
        for slot in &self.slots {
            params[slot.leg] = self.leg_parameters(slot, x);
        }
        params
    }

    /// Takes each forward row (in row order) as closed at `configurations` for the unknowns
    /// `x`: rows whose readings the model of `x` commanded at known poses (a predicted σ over a
    /// grid) are closed there already, and their evaluation at `x` solves no forward
    /// kinematics (each leg's inverse kinematics for the derivatives starts from its joints).
    pub(crate) fn close_forward_rows_at(
        &self,
        x: &DVector<f64>,
        configurations: Vec<Configuration>,
    ) {
        let Some(forward) = &self.forward else {
            return;
        };
        let poses: Vec<[f64; 6]> = configurations.iter().map(|c| c.pose).collect();
        if poses.len() != forward.rows.len() {
            return;
        }
        let mut starts = forward
            .starts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        for (start, configuration) in starts.iter_mut().zip(configurations) {
            *start = Some(configuration);
        }
        *forward
            .latest
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(Latest {
            key: x.iter().map(|v| v.to_bits()).collect(),
            poses,
            rows: Vec::new(),
            moves: None,
            evaluation: None,
        });
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
        let mut evaluation = ForwardEvaluation {
            residuals: Vec::new(),
            jacobian: None,
            reading_gradients: Vec::new(),
            reading_starts: Vec::new(),
        };
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok(evaluation);
        };
        let key: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
        let mut latest = forward
            .latest
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let known = latest.as_ref().filter(|l| l.key == key);
        let complete = known
            .and_then(|l| l.evaluation.as_ref())
            .filter(|e| !jacobian || e.jacobian.is_some());
        if let Some(evaluation) = complete {
            return Ok(evaluation.clone());
        }
        // This evaluation replaces the latest one: what it knows is taken, not copied (an
        // evaluation that fails leaves none).
        let known = latest.take().filter(|l| l.key == key);
        let instrument = sighted.instrument;
        let params = self.all_leg_parameters(x);
        let shared = sighted.values(x.as_slice());
        let known_poses = known.map(|l| (l.poses, l.rows));
        let closed = self.close_rows(forward, (&params, x), (jacobian, known_poses))?;
        let measured = &self.mechanism.measured;
        let p = self.parameter_count();
        let first_shared = p - sighted.shared.len();
        // Every residual's row of the Jacobian, written in place (one allocation).
        let count = forward
            .rows
            .iter()
            .filter(|r| !r.observed.is_empty())
            .count()
            * instrument.observed_len()
            + forward.distances.len();
        let mut matrix = jacobian.then(|| DMatrix::zeros(count, p));
        evaluation.residuals.reserve(count);
        if jacobian {
            let legs = self.mechanism.legs.len();
            evaluation.reading_gradients.reserve(count * legs);
            evaluation.reading_starts.reserve(count + 1);
        }
        // Each leg's slot, for the chain rule through the pose.
        let slots = (self.mechanism.measured.as_slice(), |l: usize| {
            self.slot_of_leg[l].map(|s| self.slots[s].offset)
        });
        // One residual: its value, ∂r/∂P of each of its rows and its direct ∂r/∂θ.
        let mut push = |value: f64, parts: &[(usize, [f64; 6])], direct: &[f64]| {
            let i = evaluation.residuals.len();
            evaluation.residuals.push(value);
            let Some(matrix) = matrix.as_mut() else {
                return;
            };
            let readings = &mut evaluation.reading_gradients;
            if evaluation.reading_starts.is_empty() {
                evaluation.reading_starts.push(0);
            }
            for (r, by_pose) in parts {
                closed
                    .moves
                    .row(*r)
                    .chain(slots, by_pose, readings, |j, value| {
                        matrix[(i, j)] += value;
                    });
            }
            evaluation.reading_starts.push(readings.len());
            for (j, &value) in direct.iter().enumerate() {
                matrix[(i, first_shared + j)] += value;
            }
        };
        let report = PreparedFunction::new(
            PoseFunction::Report(instrument),
            (&shared, &sighted.shared),
            (measured, jacobian),
        );
        let mut at = Derivatives::default();
        for (r, row) in forward.rows.iter().enumerate() {
            if row.observed.is_empty() {
                continue;
            }
            report.at(&closed.poses[r], &mut at);
            for (o, (value, seen)) in at.values.iter().zip(&row.observed).enumerate() {
                push(value - seen, &[(r, at.by_pose[o])], at.by_shared(o));
            }
        }
        if let Some(target) = instrument.distances.as_ref().map(|d| d.target) {
            let position = PreparedFunction::new(
                PoseFunction::Position(instrument, target),
                (&shared, &sighted.shared),
                (measured, jacobian),
            );
            let (mut a, mut b) = (Derivatives::default(), Derivatives::default());
            let mut direct = vec![0.0; sighted.shared.len()];
            for distance in forward.distances.iter() {
                position.at(&closed.poses[distance.rows[0]], &mut a);
                position.at(&closed.poses[distance.rows[1]], &mut b);
                let gap: [f64; 3] = std::array::from_fn(|k| a.values[k] - b.values[k]);
                let length = gap.iter().map(|g| g * g).sum::<f64>().sqrt();
                let u = gap.map(|g| g / length.max(f64::MIN_POSITIVE));
                // u·∂X/∂P of each row (the second's negated) and u·(∂X_a/∂θ − ∂X_b/∂θ).
                let along = |by_pose: &[[f64; 6]]| -> [f64; 6] {
                    std::array::from_fn(|c| (0..3).map(|k| u[k] * by_pose[k][c]).sum())
                };
                let (by_a, by_b) = (along(&a.by_pose), along(&b.by_pose));
                let parts = [
                    (distance.rows[0], by_a),
                    (distance.rows[1], by_b.map(|v| -v)),
                ];
                for (j, value) in direct.iter_mut().enumerate() {
                    *value = (0..3)
                        .map(|k| u[k] * (a.by_shared(k)[j] - b.by_shared(k)[j]))
                        .sum();
                }
                push(length - distance.value, &parts, &direct);
            }
        }
        evaluation.jacobian = matrix;
        *latest = Some(Latest {
            key,
            poses: closed.poses,
            rows: closed.rows,
            moves: (jacobian && !closed.moves.is_empty()).then_some(closed.moves),
            evaluation: Some(evaluation.clone()),
        });
        Ok(evaluation)
    }

    /// Every row's closed pose at the leg parameters `params` (the unknowns `x`), warm-started
    /// from its last configuration (or `known`, closed there by the latest evaluation, with
    /// the legs' kernel rows it evaluated there), with its movements when `moves`.
    pub(super) fn close_rows(
        &self,
        forward: &Forward,
        (params, x): (&[Vec<f64>], &DVector<f64>),
        (moves, known): (bool, Option<KnownRows>),
    ) -> Result<ClosedRows, BlockError> {
        let mechanism = self.mechanism;
        let count = forward.rows.len();
        let known = known.filter(|(poses, _)| poses.len() == count);
        // Poses already closed at these unknowns need no solve (their configurations are the
        // rows' starts).
        let kinematics = match known {
            Some(_) => None,
            None => Some(ForwardKinematics::with_kernels(
                mechanism,
                params,
                &forward.kernels,
            )),
        };
        let prepared: Vec<PreparedLeg<'_>> = if moves {
            mechanism
                .legs
                .iter()
                .enumerate()
                .map(|(l, leg)| {
                    let columns = self.slot_of_leg[l].map_or(&[][..], |s| &self.slots[s].columns);
                    PreparedLeg::with_kernel(leg, &params[l], columns, forward.kernels[l])
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut starts = forward
            .starts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        // Known rows are where they were closed (their poses and kernel rows moved in).
        let is_known = known.is_some();
        let (poses, rows) = match known {
            Some((poses, rows)) if rows.len() == count => (poses, rows),
            Some((poses, _)) => (poses, vec![None; count]),
            None => (vec![[0.0; 6]; count], vec![None; count]),
        };
        let mut closed = ClosedRows {
            poses,
            rows,
            moves: match moves {
                true => RowsMoves::new(count, prepared.iter().map(|l| l.columns()).sum()),
                false => RowsMoves::default(),
            },
        };
        // Each row's results are written into their place.
        let close = |(index, ((row, start), (pose_out, rows_out))): (usize, RowSlots<'_>),
                     moves_out: Option<(&mut Moves, &mut [f64])>| {
            let fail = |source: KinematicsError| self.forward_error(index, source, x);
            let configuration = start.get_or_insert_with(|| Configuration::home(mechanism));
            let pose = match (is_known, &kinematics) {
                (true, _) => *pose_out,
                (false, Some(kinematics)) => kinematics
                    .solve_near_closed(&row.readings, configuration, rows_out)
                    .map_err(fail)?,
                (false, None) => {
                    return Err(fail(KinematicsError::NotAssemblable {
                        residual: f64::INFINITY,
                    }))
                }
            };
            // solve_near_closed may fall back to a continuation from home: keep where it closed.
            configuration.pose = pose;
            *pose_out = pose;
            if let Some(moves_out) = moves_out {
                let joints = &configuration.joints;
                pose_moves(
                    mechanism,
                    &prepared,
                    (&pose, rows_out.as_ref()),
                    joints,
                    moves_out,
                )
                .map_err(fail)?;
            }
            Ok(())
        };
        // Rows are independent: each closed from its own start (the same poses whatever the
        // order), every row closed (its start kept for the next evaluation) and the first
        // failing row in row order reported; many rows are closed on every core.
        let results: Vec<Result<(), BlockError>> = if count >= PARALLEL_ROWS {
            let slots = closed.poses.par_iter_mut().zip(closed.rows.par_iter_mut());
            let rows = forward
                .rows
                .par_iter()
                .zip(starts.par_iter_mut())
                .zip(slots);
            let rows = rows.enumerate().with_min_len(ROWS_PER_TASK);
            if moves {
                let moves = closed.moves.par_slots_mut().with_min_len(ROWS_PER_TASK);
                rows.zip(moves)
                    .map(|(row, m)| close(row, Some(m)))
                    .collect()
            } else {
                rows.map(|row| close(row, None)).collect()
            }
        } else {
            let slots = closed.poses.iter_mut().zip(closed.rows.iter_mut());
            let rows = forward.rows.iter().zip(starts.iter_mut()).zip(slots);
            let mut moves_out = closed.moves.slots_mut();
            rows.enumerate()
                .map(|row| close(row, moves_out.next()))
                .collect()
        };
        results.into_iter().collect::<Result<(), BlockError>>()?;
        Ok(closed)
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
    /// measurement (a row, or a distance) and, over its own noise sources then the readings it
    /// depends on, `σ ∂r/∂·`: a coordinate's `σ_i` on its own residual and the row's readings'
    /// `σ_q ∂r/∂s`; a distance's declared σ on its own measurement, and its two rows' readings
    /// on theirs (laid out as those rows' loadings, [`crate::identify::sandwich::NoiseLoadings::also`], indices among the
    /// forward residuals): the distance moves with the readings its rows' residuals read too.
    ///
    /// # Errors
    /// As [`Self::evaluate_forward`].
    pub(super) fn forward_loadings(
        &self,
        x: &DVector<f64>,
        noise: &MeasurementNoise,
    ) -> Result<ForwardLoadings, BlockError> {
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok((Vec::new(), Vec::new()));
        };
        let evaluation = self.evaluate_forward(x, true)?;
        let sigmas = coordinate_sigmas(sighted.instrument, noise);
        let per_row = sigmas.len();
        let distance_sigma = sighted
            .instrument
            .distances
            .as_ref()
            .map_or(0.0, |d| d.noise * noise.scale);
        // Each residual's measurement, and its coordinate (a row's) or its rows' measurements
        // (a distance's), in the residuals' order.
        let coordinates = forward
            .rows
            .iter()
            .filter(|row| !row.observed.is_empty())
            .flat_map(|row| (0..per_row).map(move |o| (row.source, Ok(o))));
        let distances = forward.distances.iter().map(|d| {
            let sources = d.rows.map(|r| forward.rows[r].source);
            (d.source, Err(sources))
        });
        let (mut own, mut also) = (Vec::new(), Vec::new());
        let residuals = coordinates
            .chain(distances)
            .zip((0..).map(|i| evaluation.reading_gradient(i)));
        for (residual, ((source, kind), readings)) in residuals.enumerate() {
            let reading_loadings = |gradient: &[f64]| {
                let mut loading = vec![0.0; per_row + 1 + gradient.len()];
                for (l, g) in gradient.iter().enumerate() {
                    loading[per_row + 1 + l] = noise.reading * g;
                }
                loading
            };
            match kind {
                Ok(o) => {
                    let mut loading = reading_loadings(readings);
                    loading[o] = sigmas[o];
                    own.push((source, loading));
                }
                Err(sources) => {
                    let mut loading = vec![0.0; per_row + 1];
                    loading[per_row] = distance_sigma;
                    own.push((source, loading));
                    // The readings of its first row, then its second's.
                    let legs = readings.len() / 2;
                    for (row, gradient) in sources.iter().zip(readings.chunks(legs.max(1))) {
                        if noise.reading > 0.0 {
                            also.push((residual, *row, reading_loadings(gradient)));
                        }
                    }
                }
            }
        }
        Ok((own, also))
    }
}

/// The loadings of a problem's forward residuals ([`IdentificationProblem::forward_loadings`]):
/// each residual's on its own measurement, and the distances' on their rows' readings
/// `(residual, measurement, loading)`.
pub(super) type ForwardLoadings = (Vec<(usize, Vec<f64>)>, Vec<(usize, usize, Vec<f64>)>);
