//! How a forward row's closed pose moves with the unknowns and the readings (the implicit
//! function theorem of `problem/forward.rs`): `∂P/∂s = A⁻¹` and `∂P/∂φ_l = −A⁻¹ e_l ∂ψ_l/∂φ_l`,
//! `A = ∂ψ/∂P` over the measured coordinates, kept in fixed storage as `A⁻¹` and each leg's
//! `∂ψ_l/∂φ_l` (never as a 6 × unknowns matrix: a residual's row is chained through them
//! directly).
//!
//! A leg whose closed-form kernel reaches the pose gives its row of `A` and its `∂ψ_l/∂φ_l`
//! from the kernel's actuated row and f64 partials
//! ([`PreparedLeg::actuated_gradients`]), without solving its passive joints again; any other
//! leg is solved at the pose and differentiated at its solution.

use nalgebra::{DMatrix, SMatrix, Vector3};
use rayon::prelude::*;

use crate::error::KinematicsError;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::chain::platform_transform_f64;
use crate::kinematics::inverse::Joints;
use crate::kinematics::pose_derivative::pose_derivatives;
use crate::kinematics::KernelRows;
use crate::model::mechanism::Mechanism;

/// How one closed pose moves (see the module), but its legs' gradients (kept for all the rows
/// in one buffer, [`RowsMoves`]).
#[derive(Debug, Clone, Default)]
pub(super) struct Moves {
    /// The measured coordinates' count `n` (as many as legs, at most six).
    n: usize,
    /// `A⁻¹`: row `j` the `j`-th measured coordinate, column `l` leg `l`.
    inverse: [[f64; 6]; 6],
    /// Where each leg's `∂ψ_l/∂φ_l` starts in the row's gradients (and the last one ends).
    starts: [usize; 7],
}

/// Every row's [`Moves`] and their legs' gradients: `width` values a row (every leg's
/// `∂ψ_l/∂φ_l` over its prepared columns, leg after leg), all in one buffer.
#[derive(Debug, Clone, Default)]
pub(super) struct RowsMoves {
    moves: Vec<Moves>,
    own: Vec<f64>,
    width: usize,
}

impl RowsMoves {
    /// Room for `count` rows of `width` gradient values each.
    pub(super) fn new(count: usize, width: usize) -> Self {
        Self {
            moves: vec![Moves::default(); count],
            // A chunk a row even when there are no gradients (chunks are at least 1 long).
            own: vec![0.0; count * width.max(1)],
            width,
        }
    }

    /// Whether it holds no row.
    pub(super) fn is_empty(&self) -> bool {
        self.moves.is_empty()
    }

    /// Row `r`'s movements.
    pub(super) fn row(&self, r: usize) -> RowMoves<'_> {
        let chunk = self.width.max(1);
        RowMoves {
            moves: &self.moves[r],
            own: &self.own[r * chunk..r * chunk + self.width],
        }
    }

    /// Every row's movements, in row order.
    pub(super) fn rows(&self) -> impl Iterator<Item = RowMoves<'_>> {
        (0..self.moves.len()).map(|r| self.row(r))
    }

    /// Every row's slots to write its movements into ([`pose_moves`]), in row order.
    pub(super) fn slots_mut(&mut self) -> impl Iterator<Item = (&mut Moves, &mut [f64])> {
        let width = self.width;
        let chunks = self.own.chunks_mut(width.max(1));
        (self.moves.iter_mut().zip(chunks)).map(move |(m, own)| (m, &mut own[..width]))
    }

    /// [`Self::slots_mut`] for rayon, in row order.
    pub(super) fn par_slots_mut(
        &mut self,
    ) -> impl IndexedParallelIterator<Item = (&mut Moves, &mut [f64])> {
        let width = self.width;
        let chunks = self.own.par_chunks_mut(width.max(1));
        (self.moves.par_iter_mut().zip(chunks)).map(move |(m, own)| (m, &mut own[..width]))
    }
}

/// One row's movements: its [`Moves`] and its legs' gradients.
#[derive(Debug, Clone, Copy)]
pub(super) struct RowMoves<'a> {
    moves: &'a Moves,
    own: &'a [f64],
}

impl RowMoves<'_> {
    /// Leg `l`'s `∂ψ_l/∂φ_l`.
    fn own(&self, l: usize) -> &[f64] {
        &self.own[self.moves.starts[l]..self.moves.starts[l + 1]]
    }

    /// A residual's `∂r/∂s` (one value per leg) for its `∂r/∂P` `by_pose` (over the six pose
    /// coordinates; the `measured` ones read), appended to `readings`, and its `∂r/∂x` through
    /// the pose, `add(column, value)` for each identified leg parameter.
    /// `measured` the model's measured pose coordinates, `offset_of(l)` the first unknown of
    /// leg `l`'s identified parameters (if it has any).
    pub(super) fn chain(
        &self,
        (measured, offset_of): (&[usize], impl Fn(usize) -> Option<usize>),
        by_pose: &[f64; 6],
        readings: &mut Vec<f64>,
        mut add: impl FnMut(usize, f64),
    ) {
        for l in 0..self.moves.n {
            let mut by_reading = 0.0;
            for (j, &c) in measured.iter().enumerate() {
                by_reading += by_pose[c] * self.moves.inverse[j][l];
            }
            readings.push(by_reading);
            let Some(offset) = offset_of(l) else {
                continue;
            };
            for (k, value) in self.own(l).iter().enumerate() {
                add(offset + k, -by_reading * value);
            }
        }
    }

    /// `∂P/∂x`: 6 × `unknowns`, zero rows for the coordinates the model does not measure
    /// (`measured` the measured ones; `slots` each identified leg and the first unknown of its
    /// parameters).
    pub(super) fn by_unknowns(
        &self,
        unknowns: usize,
        measured: &[usize],
        slots: &[(usize, usize)],
    ) -> DMatrix<f64> {
        let mut matrix = DMatrix::zeros(6, unknowns);
        for (j, &c) in measured.iter().enumerate() {
            for &(leg, offset) in slots {
                for (k, &value) in self.own(leg).iter().enumerate() {
                    matrix[(c, offset + k)] = -self.moves.inverse[j][leg] * value;
                }
            }
        }
        matrix
    }
}

/// How the closed pose `pose` of `mechanism` moves (see the module), the legs `prepared` at the
/// unknowns (one per leg, prepared for their slots' columns), `seeds` the row's joints (the
/// turn a kernel reads its joints on, and the start of a leg solved again); `rows` the legs'
/// kernel rows if the forward solve evaluated them (used where they are at exactly `pose`).
/// Written into `moves` and its legs' gradients into `own` (as long as the prepared legs'
/// columns together), which are not to be read after an error.
///
/// # Errors
/// As many measured coordinates as legs (at most six) are needed; a leg solved again that
/// cannot reach the pose; a singular `A` (an assembly-mode change).
pub(super) fn pose_moves(
    mechanism: &Mechanism,
    prepared: &[PreparedLeg<'_>],
    (pose, rows): (&[f64; 6], Option<&KernelRows>),
    seeds: &[Joints],
    (moves, own): (&mut Moves, &mut [f64]),
) -> Result<(), KinematicsError> {
    let measured = &mechanism.measured;
    let (n, legs) = (measured.len(), prepared.len());
    if legs != n || n > 6 || mechanism.legs.len() != legs {
        return Err(KinematicsError::NotAssemblable {
            residual: f64::INFINITY,
        });
    }
    // The forward solve's platform, bit for bit (its kernel rows were evaluated on it).
    let platform = platform_transform_f64(pose);
    // The platform's derivatives: a position's is a unit translation (moving every point
    // by it exactly), an angle's a rotation's derivative.
    let angles = measured.iter().any(|&c| c >= 3);
    let derivatives = angles.then(|| pose_derivatives(pose, measured));
    let mut starts = [0; 7];
    for (l, leg) in prepared.iter().enumerate() {
        starts[l + 1] = starts[l] + leg.columns();
    }
    if own.len() != starts[legs] {
        return Err(KinematicsError::NotAssemblable {
            residual: f64::INFINITY,
        });
    }
    // A = ∂ψ/∂P over the measured coordinates, and each leg's ∂ψ_l/∂φ_l.
    let mut a = [[0.0; 6]; 6];
    for (l, leg) in prepared.iter().enumerate() {
        let gradient = &mut own[starts[l]..starts[l + 1]];
        let seed = seeds.get(l);
        let known = rows.and_then(|rows| rows.leg_at(pose, l));
        let row = match leg.actuated_gradients(&platform, (seed, known), gradient) {
            Some(row) => row,
            None => {
                let home = &mechanism.home_pose;
                let solution = leg.solve_warm_on(&platform, pose, home, seed)?;
                leg.reading_and_gradient_on(&platform, &solution, gradient);
                let dims = leg.leg().closure_dims.min(3);
                let inverse = solution.closure_inverse.row(leg.leg().actuated);
                std::array::from_fn(|k| if k < dims { inverse[k] } else { 0.0 })
            }
        };
        let attachment = Vector3::from(leg.geometry().attachment);
        let gain = leg.geometry().gain;
        for (j, &c) in measured.iter().enumerate() {
            let moved = match &derivatives {
                Some(derivatives) => derivatives[j].of(&attachment),
                None => Vector3::ith(c, 1.0),
            };
            let actuated: f64 = (0..3).map(|k| row[k] * moved[k]).sum();
            a[l][j] = actuated / gain;
        }
    }
    moves.inverse = inverse(&a, n).ok_or(KinematicsError::AssemblyModeChange)?;
    (moves.n, moves.starts) = (n, starts);
    Ok(())
}

/// The inverse of `a`'s leading `n × n` block (`n ≤ 6`) in fixed storage, `None` if singular or
/// not finite.
fn inverse(a: &[[f64; 6]; 6], n: usize) -> Option<[[f64; 6]; 6]> {
    match n {
        1 => inverse_of::<1>(a),
        2 => inverse_of::<2>(a),
        3 => inverse_of::<3>(a),
        4 => inverse_of::<4>(a),
        5 => inverse_of::<5>(a),
        6 => inverse_of::<6>(a),
        _ => None,
    }
}

fn inverse_of<const N: usize>(a: &[[f64; 6]; 6]) -> Option<[[f64; 6]; 6]> {
    let matrix = SMatrix::<f64, N, N>::from_fn(|i, j| a[i][j]);
    let inverse = matrix.try_inverse()?;
    if !inverse.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut out = [[0.0; 6]; 6];
    for (i, row) in out.iter_mut().enumerate().take(N) {
        for (j, value) in row.iter_mut().enumerate().take(N) {
            *value = inverse[(i, j)];
        }
    }
    Some(out)
}
