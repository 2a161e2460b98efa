//! Where a forward model's rows take the instrument's target, and how those points move with
//! the unknowns: the raw material of naming what the observations cannot see as motions of
//! the mechanism ([`crate::identify::gauges`]).

use nalgebra::{DMatrix, DVector};

use super::forward::ClosedRows;
use super::instrument_derivatives::{derivatives, PoseFunction};
use super::{BlockError, IdentificationProblem};

/// One forward row's target point in the base frame and its derivative.
#[derive(Debug, Clone)]
pub struct ReachedPoint {
    /// The target's position in the base frame at the row's closed pose, metres.
    pub position: [f64; 3],
    /// Its derivative with respect to the problem's unknowns (3 × unknowns): through the
    /// closed pose (the implicit function theorem of the forward rows) and the target's offset.
    pub moves: DMatrix<f64>,
}

impl IdentificationProblem<'_> {
    /// Per forward row, the instrument's distance target (its first target without distances)
    /// in the base frame where the row's readings take it at the unknowns `x`, with its
    /// derivative. Empty without forward rows.
    ///
    /// # Errors
    /// As the forward rows' evaluation: a row whose forward kinematics does not close.
    pub fn reached_points(&self, x: &DVector<f64>) -> Result<Vec<ReachedPoint>, BlockError> {
        let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) else {
            return Ok(Vec::new());
        };
        let instrument = sighted.instrument;
        let target = instrument.distances.as_ref().map_or(0, |d| d.target);
        // The poses the latest evaluation closed at `x`, if it was there, and their moves if
        // it took the Jacobian: no solve again.
        let key: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
        let known = forward
            .latest
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .as_ref()
            .filter(|l| l.key == key)
            .map(|l| (l.poses.clone(), l.rows.clone(), l.moves.clone()));
        let closed = match known {
            Some((poses, rows, Some(moves))) => ClosedRows { poses, rows, moves },
            known => {
                let params = self.all_leg_parameters(x);
                let known = known.map(|(poses, rows, _)| (poses, rows));
                self.close_rows(forward, (&params, x), (true, known))?
            }
        };
        let shared = sighted.values(x.as_slice());
        let p = self.parameter_count();
        let first_shared = p - sighted.shared.len();
        let slots: Vec<(usize, usize)> = self.slots.iter().map(|s| (s.leg, s.offset)).collect();
        Ok(closed
            .poses
            .iter()
            .zip(closed.moves.rows())
            .map(|(pose, row_moves)| {
                let at = derivatives(
                    PoseFunction::Position(instrument, target),
                    (&shared, &sighted.shared),
                    pose,
                    (&self.mechanism.measured, true),
                );
                let dx =
                    row_moves.by_unknowns(self.parameter_count(), &self.mechanism.measured, &slots);
                let by_pose = DMatrix::from_fn(3, 6, |k, c| at.by_pose[k][c]);
                let mut moves = by_pose * dx;
                for k in 0..3 {
                    for (j, &value) in at.by_shared(k).iter().enumerate() {
                        moves[(k, first_shared + j)] += value;
                    }
                }
                let values = &at.values;
                ReachedPoint {
                    position: [values[0], values[1], values[2]],
                    moves,
                }
            })
            .collect())
    }
}
