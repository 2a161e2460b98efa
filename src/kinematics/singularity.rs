//! Singularity measures, scale-free and signed so that they are positive in the home working
//! and assembly modes.
//!
//! * **Serial (type I), per leg**: the determinant of the leg's closure Jacobian ∂F/∂q with
//!   unit-norm columns (for the 5R, the sine of the angle A–P–B at the tip, `l sin β / |P − A|`,
//!   β the angle between the two links). It vanishes when the leg is stretched or folded; the
//!   leg's inverse kinematics breaks down there.
//! * **Parallel (type II)**: each leg's closure, projected on the direction `n` orthogonal to its
//!   passive joints' columns, gives one row `nᵀ ∂F/∂X` of the parallel Jacobian A
//!   (`A dX + B dq_actuated = 0`). The measure is det A with unit-norm rows (for the 5R,
//!   `((P−B₁)/L₁) × ((P−B₂)/L₂)`); it vanishes where the platform gains a degree of freedom.

use nalgebra::{DMatrix, Vector3};
use num_dual::Dual64;

use super::chain::{attachment_world, tip_and_jacobian};
use super::inverse::{solve_leg, LegSolution};
use crate::error::KinematicsError;
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;

/// Serial measure of leg `leg` at `pose` for its full parameter vector `phi`.
///
/// # Errors
/// The leg cannot reach the pose on its home branch.
pub fn serial_measure(
    mechanism: &Mechanism,
    leg: usize,
    phi: &[f64],
    pose: &[f64; 6],
) -> Result<f64, KinematicsError> {
    let model = &mechanism.legs[leg];
    let solution = solve_leg(model, &model.geometry(phi), pose, &mechanism.home_pose)?;
    Ok(model.home_branch_measure(solution.normalised_determinant))
}

/// The parallel (type II) measure for one parameter set, signed by the home assembly mode.
#[derive(Debug, Clone)]
pub struct ParallelMeasure<'a> {
    mechanism: &'a Mechanism,
    geometries: Vec<LegGeometry<f64>>,
    home_sign: f64,
}

impl<'a> ParallelMeasure<'a> {
    /// Prepares the measure for parameters `params` (one full vector per leg).
    ///
    /// # Errors
    /// A leg cannot reach the home pose, the mechanism has not as many legs as measured
    /// coordinates, or the home pose itself is singular.
    pub fn new(mechanism: &'a Mechanism, params: Vec<Vec<f64>>) -> Result<Self, KinematicsError> {
        let geometries = mechanism
            .legs
            .iter()
            .zip(&params)
            .map(|(leg, phi)| leg.geometry(phi))
            .collect();
        let mut measure = Self {
            mechanism,
            geometries,
            home_sign: 1.0,
        };
        let home = measure.at(&mechanism.home_pose)?;
        if home == 0.0 {
            return Err(KinematicsError::AssemblyModeChange);
        }
        measure.home_sign = home.signum();
        Ok(measure)
    }

    /// The measure at `pose` (positive in the home assembly mode).
    ///
    /// # Errors
    /// A leg cannot reach the pose on its home branch, or the legs do not match the measured
    /// coordinates in number (no square parallel Jacobian).
    pub fn at(&self, pose: &[f64; 6]) -> Result<f64, KinematicsError> {
        let mechanism = self.mechanism;
        let solutions = mechanism
            .legs
            .iter()
            .zip(&self.geometries)
            .map(|(leg, geometry)| solve_leg(leg, geometry, pose, &mechanism.home_pose))
            .collect::<Result<Vec<_>, _>>()?;
        self.at_solutions(pose, &solutions)
    }

    /// The measure at `pose` from the legs' inverse-kinematics solutions there.
    ///
    /// # Errors
    /// The legs do not match the measured coordinates in number.
    pub fn at_solutions(
        &self,
        pose: &[f64; 6],
        solutions: &[LegSolution],
    ) -> Result<f64, KinematicsError> {
        let mechanism = self.mechanism;
        let coordinates = &mechanism.measured;
        if mechanism.legs.len() != coordinates.len() {
            return Err(KinematicsError::NotSquare {
                legs: mechanism.legs.len(),
                coordinates: coordinates.len(),
            });
        }
        let mut rows = DMatrix::zeros(mechanism.legs.len(), coordinates.len());
        let pose_dual = pose.map(Dual64::from);
        for (l, (leg, solution)) in mechanism.legs.iter().zip(solutions).enumerate() {
            let geometry = &self.geometries[l];
            let (_, jacobian) = tip_and_jacobian(leg, geometry, &solution.q);
            let passive: Vec<Vector3<f64>> = (0..leg.moving.len())
                .filter(|&i| i != leg.actuated)
                .map(|i| jacobian.column(i).into_owned())
                .collect();
            let normal = orthogonal_direction(&passive, leg.closure_dims);
            let attachment = geometry.attachment.map(Dual64::from);
            for (k, &c) in coordinates.iter().enumerate() {
                let mut seeded = pose_dual;
                seeded[c].eps = 1.0;
                let moved = attachment_world(&seeded, &attachment);
                // The row is nᵀ ∂(X·attachment)/∂X = −nᵀ ∂F/∂X. Its sign does not matter: the
                // measure is signed by the home assembly mode, computed the same way.
                rows[(l, k)] = (0..leg.closure_dims)
                    .map(|d| normal[d] * moved[d].eps)
                    .sum::<f64>();
            }
        }
        for mut row in rows.row_iter_mut() {
            // A zero row (a leg with no closure direction) stays zero and makes the measure 0.
            let norm = row.norm().max(f64::MIN_POSITIVE);
            row /= norm;
        }
        Ok(self.home_sign * rows.determinant())
    }

    /// The legs' geometries for the measure's parameters (built once).
    pub fn geometries(&self) -> &[LegGeometry<f64>] {
        &self.geometries
    }
}

/// A vector orthogonal to the passive columns (d = 2: one column; d = 3: two columns). Its
/// length does not matter: the parallel Jacobian's rows are normalised.
fn orthogonal_direction(passive: &[Vector3<f64>], dims: usize) -> Vector3<f64> {
    match (dims, passive) {
        (2, [p]) => Vector3::new(-p.y, p.x, 0.0),
        (3, [p, q]) => p.cross(q),
        _ => Vector3::zeros(),
    }
}
