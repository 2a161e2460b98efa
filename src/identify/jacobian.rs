//! The identification Jacobian of a leg, by dual numbers through the implicit function theorem.
//!
//! For each identified parameter, one forward pass in `Dual64` seeded on that parameter through
//! [`reading_at_solution`] (one Newton step from the f64 solution) gives the exact derivative
//! `∂ψ/∂φ_j`. The Newton iterations themselves are never differentiated.
//!
//! Everything that depends only on the parameter vector (the f64 geometry, and one seeded dual
//! geometry per identified parameter) is built once in [`PreparedLeg`] and reused at every pose.

use num_dual::Dual64;

use crate::error::KinematicsError;
use crate::kinematics::inverse::{reading_at_solution, solve_leg, LegSolution};
use crate::model::leg::{LegGeometry, LegModel};

/// A leg ready to be evaluated at many poses for one parameter vector.
#[derive(Debug, Clone)]
pub struct PreparedLeg<'a> {
    leg: &'a LegModel,
    geometry: LegGeometry<f64>,
    seeded: Vec<LegGeometry<Dual64>>,
}

impl<'a> PreparedLeg<'a> {
    /// Prepares `leg` at full parameter vector `phi`, for derivatives with respect to the
    /// parameters listed in `columns` (indices into the leg's parameters).
    pub fn new(leg: &'a LegModel, phi: &[f64], columns: &[usize]) -> Self {
        let mut phi_dual: Vec<Dual64> = phi.iter().map(|&v| Dual64::from(v)).collect();
        let seeded = columns
            .iter()
            .map(|&column| {
                phi_dual[column].eps = 1.0;
                let geometry = leg.geometry(&phi_dual);
                phi_dual[column].eps = 0.0;
                geometry
            })
            .collect();
        Self {
            leg,
            geometry: leg.geometry(phi),
            seeded,
        }
    }

    /// Number of prepared derivative columns.
    pub fn columns(&self) -> usize {
        self.seeded.len()
    }

    /// The predicted reading at `pose`.
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn reading(&self, pose: &[f64; 6], home_pose: &[f64; 6]) -> Result<f64, KinematicsError> {
        let solution = self.solve(pose, home_pose)?;
        Ok(reading_at_solution(
            self.leg,
            &self.geometry,
            pose,
            &solution,
        ))
    }

    /// The predicted reading at `pose`, writing its gradient with respect to the prepared
    /// columns into `gradient` (one value per column).
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn reading_and_gradient(
        &self,
        pose: &[f64; 6],
        home_pose: &[f64; 6],
        gradient: &mut [f64],
    ) -> Result<f64, KinematicsError> {
        let solution = self.solve(pose, home_pose)?;
        Ok(self.reading_and_gradient_at(pose, &solution, gradient))
    }

    /// The leg's inverse kinematics at `pose` with the prepared parameters.
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn solve(
        &self,
        pose: &[f64; 6],
        home_pose: &[f64; 6],
    ) -> Result<LegSolution, KinematicsError> {
        solve_leg(self.leg, &self.geometry, pose, home_pose)
    }

    /// As [`Self::reading_and_gradient`], at an already solved pose.
    pub fn reading_and_gradient_at(
        &self,
        pose: &[f64; 6],
        solution: &LegSolution,
        gradient: &mut [f64],
    ) -> f64 {
        let pose_dual = pose.map(Dual64::from);
        for (slot, geometry) in gradient.iter_mut().zip(&self.seeded) {
            *slot = reading_at_solution(self.leg, geometry, &pose_dual, solution).eps;
        }
        reading_at_solution(self.leg, &self.geometry, pose, solution)
    }
}

/// Predicted reading and its gradient with respect to the parameters listed in `columns`
/// (indices into the leg's parameter vector), at full parameter vector `phi` and pose `pose`.
/// For many poses at one parameter vector, prepare a [`PreparedLeg`] once instead.
///
/// # Errors
/// The leg cannot reach the pose on its home branch.
pub fn reading_gradient(
    leg: &LegModel,
    phi: &[f64],
    columns: &[usize],
    pose: &[f64; 6],
    home_pose: &[f64; 6],
) -> Result<(f64, Vec<f64>), KinematicsError> {
    let mut gradient = vec![0.0; columns.len()];
    let value =
        PreparedLeg::new(leg, phi, columns).reading_and_gradient(pose, home_pose, &mut gradient)?;
    Ok((value, gradient))
}
