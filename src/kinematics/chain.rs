//! Forward kinematics of a leg chain, generic over the scalar (f64 and dual numbers).

use nalgebra::{Matrix3, Rotation3, Translation3, Unit, Vector3};

use crate::model::joint::{JointKind, JointModel};
use crate::model::leg::{LegGeometry, LegModel};
use crate::scalar::{lift, Scalar};

/// A rigid transform (rotation matrix + translation).
pub type Transform<T> = nalgebra::IsometryMatrix3<T>;

/// The transform of a joint origin `[x, y, z, roll, pitch, yaw]` (URDF convention:
/// rotation `Rz(yaw) Ry(pitch) Rx(roll)` then translation).
pub fn origin_transform<T: Scalar>(origin: &[T; 6]) -> Transform<T> {
    Transform::from_parts(
        Translation3::new(origin[0], origin[1], origin[2]),
        Rotation3::from_euler_angles(origin[3], origin[4], origin[5]),
    )
}

/// The motion of a joint for variable `q` (radians or metres).
pub fn joint_motion<T: Scalar>(joint: &JointModel, q: T) -> Transform<T> {
    let axis: Vector3<T> = joint.axis.map(lift::<T>);
    match joint.kind {
        JointKind::Revolute => Transform::from_parts(
            Translation3::identity(),
            Rotation3::from_axis_angle(&Unit::new_unchecked(axis), q),
        ),
        JointKind::Prismatic => {
            Transform::from_parts(Translation3::from(axis * q), Rotation3::identity())
        }
        JointKind::Fixed => Transform::identity(),
    }
}

/// The platform transform of a pose `[x, y, z, roll, pitch, yaw]` in the measurement frame.
pub fn platform_transform<T: Scalar>(pose: &[T; 6]) -> Transform<T> {
    origin_transform(pose)
}

/// World position of a leg's attachment point for a platform pose.
pub fn attachment_world<T: Scalar>(pose: &[T; 6], attachment: &[T; 3]) -> Vector3<T> {
    platform_transform(pose)
        .transform_point(&nalgebra::Point3::from(Vector3::from(*attachment)))
        .coords
}

/// Position of the leg tip (origin of the last chain link) for the moving joints' values `q`.
pub fn tip_position<T: Scalar>(leg: &LegModel, geometry: &LegGeometry<T>, q: &[T]) -> Vector3<T> {
    chain_tip(leg, geometry.origins.iter().map(origin_transform), q)
}

/// Tip position and the geometric Jacobian ∂tip/∂q (column j for moving joint j; unused columns
/// zero), in f64. Revolute: `w × (tip − p)`; prismatic: `w`, with `w` the world axis.
pub fn tip_and_jacobian(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    q: &[f64],
) -> (Vector3<f64>, Matrix3<f64>) {
    chain_tip_and_jacobian(leg, geometry.origins.iter().map(origin_transform), q)
}

/// A leg's joint origins as transforms, computed once for one parameter vector (the
/// trigonometry of the origins' angles is then not redone at every pose and Newton iteration).
/// Gives the same numbers as [`tip_position`] and [`tip_and_jacobian`] on the geometry.
#[derive(Debug, Clone)]
pub struct ChainFrames<T: Scalar> {
    origins: Vec<Transform<T>>,
}

impl<T: Scalar> ChainFrames<T> {
    /// The origin transforms of `geometry`'s joints.
    pub fn new(geometry: &LegGeometry<T>) -> Self {
        Self {
            origins: geometry.origins.iter().map(origin_transform).collect(),
        }
    }

    /// As [`tip_position`].
    pub fn tip(&self, leg: &LegModel, q: &[T]) -> Vector3<T> {
        chain_tip(leg, self.origins.iter().copied(), q)
    }
}

impl ChainFrames<f64> {
    /// As [`tip_and_jacobian`].
    pub fn tip_and_jacobian(&self, leg: &LegModel, q: &[f64]) -> (Vector3<f64>, Matrix3<f64>) {
        chain_tip_and_jacobian(leg, self.origins.iter().copied(), q)
    }
}

/// The tip position for the joints' origin transforms `origins` (one per chain joint).
fn chain_tip<T: Scalar>(
    leg: &LegModel,
    origins: impl Iterator<Item = Transform<T>>,
    q: &[T],
) -> Vector3<T> {
    let mut world_from_link = Transform::<T>::identity();
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(origins) {
        world_from_link *= origin;
        if joint.is_moving() {
            world_from_link *= joint_motion(joint, q[next]);
            next += 1;
        }
    }
    world_from_link.translation.vector
}

/// The tip position and ∂tip/∂q for the joints' origin transforms `origins`.
fn chain_tip_and_jacobian(
    leg: &LegModel,
    origins: impl Iterator<Item = Transform<f64>>,
    q: &[f64],
) -> (Vector3<f64>, Matrix3<f64>) {
    let mut world_from_link = Transform::<f64>::identity();
    let mut axes = [(JointKind::Fixed, Vector3::zeros(), Vector3::zeros()); 3];
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(origins) {
        world_from_link *= origin;
        if joint.is_moving() {
            let axis_world = world_from_link.rotation * joint.axis;
            axes[next] = (joint.kind, axis_world, world_from_link.translation.vector);
            world_from_link *= joint_motion(joint, q[next]);
            next += 1;
        }
    }
    let tip = world_from_link.translation.vector;
    let mut jacobian = Matrix3::zeros();
    for (column, (kind, axis, point)) in axes.iter().enumerate().take(next) {
        let derivative = match kind {
            JointKind::Revolute => axis.cross(&(tip - point)),
            _ => *axis,
        };
        jacobian.set_column(column, &derivative);
    }
    (tip, jacobian)
}

/// World axes of the moving joints for the moving joints' values `q` (f64).
pub fn moving_axes(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    q: &[f64],
) -> Vec<(JointKind, Vector3<f64>)> {
    let mut world_from_link = Transform::<f64>::identity();
    let mut axes = Vec::with_capacity(leg.moving.len());
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(&geometry.origins) {
        world_from_link *= origin_transform(origin);
        if joint.is_moving() {
            axes.push((joint.kind, world_from_link.rotation * joint.axis));
            world_from_link *= joint_motion(joint, q[next]);
            next += 1;
        }
    }
    axes
}

/// World position of an attachment point (in any scalar) on a platform at the f64 transform
/// `platform` ([`platform_transform`] of the pose): the same numbers as [`attachment_world`]
/// when the pose carries no derivative, without redoing the pose's trigonometry in `T`.
pub fn attachment_on<T: Scalar>(platform: &Transform<f64>, attachment: &[T; 3]) -> Vector3<T> {
    let rotation = platform.rotation.matrix().map(lift::<T>);
    rotation * Vector3::from(*attachment) + platform.translation.vector.map(lift::<T>)
}
