//! One leg: a serial chain from the base to the platform attachment, its actuator and parameters.

use super::joint::{JointKind, JointModel};
use super::params::{ParamTarget, Parameter};
use crate::scalar::{lift, Scalar};

/// An immutable leg description. Anything that depends on a pose or a parameter vector is
/// computed by the free functions of [`crate::kinematics`], never cached here.
#[derive(Debug, Clone)]
pub struct LegModel {
    /// Leg name.
    pub name: String,
    /// The chain's joints from the base to the tip.
    pub joints: Vec<JointModel>,
    /// Indices (into `joints`) of the moving joints: the unknowns of the closure equations.
    pub moving: Vec<usize>,
    /// Index (into `moving`) of the actuated joint.
    pub actuated: usize,
    /// Nominal actuator gain.
    pub gain: f64,
    /// Nominal actuator offset (radians or metres).
    pub offset: f64,
    /// Nominal attachment point in the platform frame, metres.
    pub attachment: [f64; 3],
    /// The leg's parameters, identified and fixed, in model-file order.
    pub params: Vec<Parameter>,
    /// Number of closure equations (2 in the plane, 3 in space) = number of moving joints.
    pub closure_dims: usize,
    /// The moving joints' values at the home pose with nominal parameters.
    pub home_joints: Vec<f64>,
    /// Sign of the closure Jacobian determinant at home: the working mode to stay on.
    pub branch_sign: f64,
}

/// A leg's geometry for one parameter vector, in scalar type `T` (a value, not a cache).
#[derive(Debug, Clone)]
pub struct LegGeometry<T> {
    /// Origins `[x, y, z, roll, pitch, yaw]` of every chain joint.
    pub origins: Vec<[T; 6]>,
    /// Actuator gain.
    pub gain: T,
    /// Actuator offset.
    pub offset: T,
    /// Attachment in the platform frame.
    pub attachment: [T; 3],
}

impl LegModel {
    /// Nominal values of all the leg's parameters, in order.
    pub fn nominal(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.nominal).collect()
    }

    /// Indices of the identified parameters.
    pub fn identified(&self) -> Vec<usize> {
        (0..self.params.len())
            .filter(|&i| self.params[i].identified)
            .collect()
    }

    /// Names of the identified parameters, in order.
    pub fn identified_names(&self) -> Vec<String> {
        self.params
            .iter()
            .filter(|p| p.identified)
            .map(|p| p.name.clone())
            .collect()
    }

    /// A closure-Jacobian determinant signed so that it is positive on the leg's home branch
    /// (the serial singularity measure). `branch_sign` is ±1: the sign is flipped or kept, not
    /// multiplied, so the value is exactly the determinant's magnitude.
    pub fn home_branch_measure(&self, determinant: f64) -> f64 {
        if self.branch_sign.is_sign_negative() {
            -determinant
        } else {
            determinant
        }
    }

    /// Is the leg on its home branch for a closure-Jacobian determinant `determinant`? (The
    /// inverse kinematics refuses any near-zero determinant before this check.)
    pub fn on_home_branch(&self, determinant: f64) -> bool {
        determinant.is_sign_positive() == self.branch_sign.is_sign_positive()
    }

    /// Is the actuated joint revolute?
    pub fn actuated_is_revolute(&self) -> bool {
        self.joints[self.moving[self.actuated]].kind == JointKind::Revolute
    }

    /// The geometry for the full parameter vector `phi` (one value per parameter of the leg).
    pub fn geometry<T: Scalar>(&self, phi: &[T]) -> LegGeometry<T> {
        let mut geometry = LegGeometry {
            origins: self
                .joints
                .iter()
                .map(|j| j.origin.map(lift::<T>))
                .collect(),
            gain: lift(self.gain),
            offset: lift(self.offset),
            attachment: self.attachment.map(lift::<T>),
        };
        for (param, &value) in self.params.iter().zip(phi) {
            match param.target {
                ParamTarget::JointOrigin { joint, component } => {
                    geometry.origins[joint][component] = value
                }
                ParamTarget::Gain => geometry.gain = value,
                ParamTarget::Offset => geometry.offset = value,
                ParamTarget::Attachment { component } => geometry.attachment[component] = value,
            }
        }
        geometry
    }
}
