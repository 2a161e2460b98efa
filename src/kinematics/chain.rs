//! Forward kinematics of a leg chain, generic over the scalar (f64 and dual numbers).

use std::borrow::Borrow;
use std::sync::OnceLock;

use nalgebra::{Matrix3, Rotation3, Translation3, Vector3};

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

/// The platform transform of a pose `[x, y, z, roll, pitch, yaw]` in the measurement frame.
pub fn platform_transform<T: Scalar>(pose: &[T; 6]) -> Transform<T> {
    origin_transform(pose)
}

/// [`platform_transform`] of an f64 pose, without the trigonometry when the orientation is
/// exactly `+0` (the rows of a planar mechanism, at every evaluation of a large problem): the
/// same bits, since `sin(+0) = +0` and `cos(+0) = 1` exactly, which makes the rotation the
/// identity with its `−sin(pitch)` entry at `−0`.
pub fn platform_transform_f64(pose: &[f64; 6]) -> Transform<f64> {
    if pose[3..].iter().any(|angle| angle.to_bits() != 0) {
        return platform_transform(pose);
    }
    #[rustfmt::skip]
    let rotation = Matrix3::new(
        1.0, 0.0, 0.0,
        0.0, 1.0, 0.0,
        -0.0, 0.0, 1.0,
    );
    Transform::from_parts(
        Translation3::new(pose[0], pose[1], pose[2]),
        Rotation3::from_matrix_unchecked(rotation),
    )
}

/// World position of a leg's attachment point for a platform pose.
pub fn attachment_world<T: Scalar>(pose: &[T; 6], attachment: &[T; 3]) -> Vector3<T> {
    platform_transform(pose)
        .transform_point(&nalgebra::Point3::from(Vector3::from(*attachment)))
        .coords
}

/// Position of the leg tip (origin of the last chain link) for the moving joints' values `q`.
pub fn tip_position<T: Scalar>(leg: &LegModel, geometry: &LegGeometry<T>, q: &[T]) -> Vector3<T> {
    chain_tip(leg, geometry.origins.iter().map(Rigid::from_origin), q)
}

/// Tip position and the geometric Jacobian ∂tip/∂q (column j for moving joint j; unused columns
/// zero), in f64. Revolute: `w × (tip − p)`; prismatic: `w`, with `w` the world axis.
pub fn tip_and_jacobian(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    q: &[f64],
) -> (Vector3<f64>, Matrix3<f64>) {
    chain_tip_and_jacobian(leg, geometry.origins.iter().map(Rigid::from_origin), q)
}

/// A leg's joint origins as rigid transforms, computed once for one parameter vector (the
/// trigonometry of the origins' angles is then not redone at every pose and Newton iteration).
/// Gives the same numbers as [`tip_position`] and [`tip_and_jacobian`] on the geometry.
#[derive(Debug, Clone)]
pub struct ChainFrames<T: Scalar> {
    origins: Vec<Rigid<T>>,
}

impl<T: Scalar> ChainFrames<T> {
    /// The origin transforms of `geometry`'s joints.
    pub fn new(geometry: &LegGeometry<T>) -> Self {
        Self {
            origins: geometry.origins.iter().map(Rigid::from_origin).collect(),
        }
    }

    /// As [`tip_position`], for joint values without derivatives (f64): the joints' motions
    /// are computed in f64 and enter the products as constants.
    pub fn tip(&self, leg: &LegModel, q: &[f64]) -> Vector3<T> {
        let last = chain_walk(
            leg,
            self.origins.iter(),
            |frame, joint, k| frame.moved_constant(joint, q[k]),
            |_, _| {},
        );
        Vector3::from(last)
    }
}

/// A geometry's [`ChainFrames`] built on first use: a leg whose closed-form kernel solves every
/// pose never needs its chain (the frames' trigonometry is then not done at all).
#[derive(Debug, Clone, Default)]
pub struct LazyChainFrames(OnceLock<ChainFrames<f64>>);

impl LazyChainFrames {
    /// Frames not built yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The frames of `geometry` (the geometry these frames are always asked for), built at the
    /// first call.
    pub fn get(&self, geometry: &LegGeometry<f64>) -> &ChainFrames<f64> {
        self.0.get_or_init(|| ChainFrames::new(geometry))
    }
}

impl ChainFrames<f64> {
    /// As [`tip_and_jacobian`].
    pub fn tip_and_jacobian(&self, leg: &LegModel, q: &[f64]) -> (Vector3<f64>, Matrix3<f64>) {
        chain_tip_and_jacobian(leg, self.origins.iter(), q)
    }
}

/// A rigid transform (rotation matrix by rows, translation) with hand-written 3×3 products:
/// nalgebra's products of generic matrices go through a general kernel, several times slower
/// at this size, and a joint's motion only changes the rotation (revolute) or the translation
/// (prismatic).
#[derive(Debug, Clone, Copy)]
struct Rigid<T> {
    rotation: [[T; 3]; 3],
    translation: [T; 3],
}

/// Rodrigues' rotation about the unit `axis` by the angle whose sine is `s` and cosine `c`
/// (`t = 1 − c`): `R = c I + s [a]× + t a aᵀ`, for f64 constants and scalars alike.
fn rodrigues<U>(axis: [U; 3], s: U, c: U, t: U) -> [[U; 3]; 3]
where
    U: Copy + std::ops::Add<Output = U> + std::ops::Sub<Output = U> + std::ops::Mul<Output = U>,
{
    let [x, y, z] = axis;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

impl<T: Scalar> Rigid<T> {
    /// The transform of a joint origin (as [`origin_transform`]).
    fn from_origin(origin: &[T; 6]) -> Self {
        let transform = origin_transform(origin);
        let matrix = transform.rotation.matrix();
        Self {
            rotation: std::array::from_fn(|i| std::array::from_fn(|j| matrix[(i, j)])),
            translation: std::array::from_fn(|i| transform.translation.vector[i]),
        }
    }

    /// `self ∘ other`.
    fn compose(&self, other: &Self) -> Self {
        let r = &self.rotation;
        Self {
            rotation: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    r[i][0] * other.rotation[0][j]
                        + r[i][1] * other.rotation[1][j]
                        + r[i][2] * other.rotation[2][j]
                })
            }),
            translation: std::array::from_fn(|i| {
                r[i][0] * other.translation[0]
                    + r[i][1] * other.translation[1]
                    + r[i][2] * other.translation[2]
                    + self.translation[i]
            }),
        }
    }

    /// The rotation applied to a vector.
    fn rotate(&self, v: &[T; 3]) -> [T; 3] {
        let r = &self.rotation;
        std::array::from_fn(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
    }

    /// `self` followed by a joint's motion `motion` (in f64 constants or scalars `T`): a
    /// rotation turns the frame, a translation (in the frame's own axes) moves it.
    fn moved_by<U: Copy>(&self, motion: &Motion<U>) -> Self
    where
        T: std::ops::Mul<U, Output = T>,
    {
        let r = &self.rotation;
        match motion {
            Motion::Rotation(m) => Self {
                rotation: std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        r[i][0] * m[0][j] + r[i][1] * m[1][j] + r[i][2] * m[2][j]
                    })
                }),
                translation: self.translation,
            },
            Motion::Translation(a) => Self {
                rotation: self.rotation,
                translation: std::array::from_fn(|i| {
                    self.translation[i] + (r[i][0] * a[0] + r[i][1] * a[1] + r[i][2] * a[2])
                }),
            },
            Motion::Still => *self,
        }
    }

    /// `self` followed by joint `joint`'s motion for a constant (f64) variable `q`: the motion
    /// is computed in f64 and multiplies as constants (no derivative work for it).
    fn moved_constant(&self, joint: &JointModel, q: f64) -> Self {
        self.moved_by(&joint_motion(joint, q))
    }

    /// `self` followed by joint `joint`'s motion for variable `q`.
    fn moved(&self, joint: &JointModel, q: T) -> Self {
        self.moved_by(&joint_motion(joint, q))
    }
}

/// What a joint's variable does to the frame that follows it, in the joint's frame.
#[derive(Debug, Clone, Copy)]
enum Motion<U> {
    /// A rotation (matrix by rows) about the joint axis.
    Rotation([[U; 3]; 3]),
    /// A translation along the joint axis.
    Translation([U; 3]),
    /// No motion.
    Still,
}

/// The motion of joint `joint` for its variable `q` (f64, or a scalar carrying derivatives):
/// the one place a [`JointKind`] becomes a motion, for every chain walker of this module.
fn joint_motion<U: Scalar>(joint: &JointModel, q: U) -> Motion<U> {
    let axis: [U; 3] = std::array::from_fn(|i| lift::<U>(joint.axis[i]));
    match joint.kind {
        JointKind::Revolute => {
            let (s, c) = nalgebra::ComplexField::sin_cos(q);
            Motion::Rotation(rodrigues(axis, s, c, lift::<U>(1.0) - c))
        }
        JointKind::Prismatic => Motion::Translation(axis.map(|a| a * q)),
        JointKind::Fixed => Motion::Still,
    }
}

/// The derivative of the tip position with respect to a moving joint's variable, for the
/// joint's world axis `axis` through the world point `point` and the tip `tip`: `axis × (tip −
/// point)` for a rotation, `axis` for a translation, zero for a joint that does not move.
fn tip_derivative(
    kind: JointKind,
    axis: &Vector3<f64>,
    point: &Vector3<f64>,
    tip: &Vector3<f64>,
) -> Vector3<f64> {
    match kind {
        JointKind::Revolute => axis.cross(&(tip - point)),
        JointKind::Prismatic => *axis,
        JointKind::Fixed => Vector3::zeros(),
    }
}

/// The world position of the chain's last link (the tip) for the joints' origin transforms
/// `origins` (one per chain joint), moving joint `k`'s frame by `motion(frame, joint, k)`; calls
/// `at_moving(k, frame)` with the frame of moving joint `k` before its motion.
fn chain_walk<T: Scalar, R: Borrow<Rigid<T>>>(
    leg: &LegModel,
    origins: impl Iterator<Item = R>,
    motion: impl Fn(&Rigid<T>, &JointModel, usize) -> Rigid<T>,
    mut at_moving: impl FnMut(usize, &Rigid<T>),
) -> [T; 3] {
    let mut world: Option<Rigid<T>> = None;
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(origins) {
        let mut frame = match &world {
            Some(world) => world.compose(origin.borrow()),
            None => *origin.borrow(),
        };
        if joint.is_moving() {
            at_moving(next, &frame);
            frame = motion(&frame, joint, next);
            next += 1;
        }
        world = Some(frame);
    }
    // The tip: the last link's origin (the world origin for a chain without joints).
    world.map_or([lift(0.0); 3], |last| last.translation)
}

/// The tip position for the joints' origin transforms `origins` (one per chain joint).
fn chain_tip<T: Scalar, R: Borrow<Rigid<T>>>(
    leg: &LegModel,
    origins: impl Iterator<Item = R>,
    q: &[T],
) -> Vector3<T> {
    let last = chain_walk(leg, origins, |f, joint, k| f.moved(joint, q[k]), |_, _| {});
    Vector3::from(last)
}

/// The tip position and ∂tip/∂q for the joints' origin transforms `origins`.
fn chain_tip_and_jacobian<R: Borrow<Rigid<f64>>>(
    leg: &LegModel,
    origins: impl Iterator<Item = R>,
    q: &[f64],
) -> (Vector3<f64>, Matrix3<f64>) {
    let mut axes = [(JointKind::Fixed, Vector3::zeros(), Vector3::zeros()); 3];
    let motion = |f: &Rigid<f64>, joint: &JointModel, k: usize| f.moved(joint, q[k]);
    let last = chain_walk(leg, origins, motion, |k, frame| {
        let joint = &leg.joints[leg.moving[k]];
        let axis = frame.rotate(&[joint.axis[0], joint.axis[1], joint.axis[2]]);
        axes[k] = (
            joint.kind,
            Vector3::from(axis),
            Vector3::from(frame.translation),
        );
    });
    let tip = Vector3::from(last);
    let mut jacobian = Matrix3::zeros();
    for (column, (kind, axis, point)) in axes.iter().enumerate().take(leg.moving.len()) {
        jacobian.set_column(column, &tip_derivative(*kind, axis, point, &tip));
    }
    (tip, jacobian)
}

/// World axes of the moving joints for the moving joints' values `q` (f64). Only the links'
/// rotations matter: the origins' and the revolute joints' (a prismatic motion moves a link
/// without turning it).
pub fn moving_axes(
    leg: &LegModel,
    geometry: &LegGeometry<f64>,
    q: &[f64],
) -> Vec<(JointKind, Vector3<f64>)> {
    let mut world_from_link = Rotation3::<f64>::identity();
    let mut axes = Vec::with_capacity(leg.moving.len());
    let mut next = 0;
    for (joint, origin) in leg.joints.iter().zip(&geometry.origins) {
        world_from_link *= Rotation3::from_euler_angles(origin[3], origin[4], origin[5]);
        if joint.is_moving() {
            axes.push((joint.kind, world_from_link * joint.axis));
            match joint_motion(joint, q[next]) {
                Motion::Rotation(r) => {
                    let matrix = Matrix3::from_fn(|i, j| r[i][j]);
                    world_from_link *= Rotation3::from_matrix_unchecked(matrix);
                }
                Motion::Translation(_) | Motion::Still => {}
            }
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

/// A leg chain prepared for its tip position in scalar `T` (dual numbers: the identification's
/// derivative pass) by backward accumulation, `tip = O₁M₁(O₂M₂(… OₙMₙ(0)))`: matrix–vector
/// products only, and the origins' rotations as f64 constants where they carry no derivative
/// (no identified parameter among their angles). The same numbers as
/// [`ChainFrames::tip`] up to round-off, at a fraction of the cost in vector duals.
#[derive(Debug, Clone)]
pub struct TipChain<T> {
    links: Vec<TipLink<T>>,
}

/// One chain joint of a [`TipChain`]: its origin's rotation and translation.
#[derive(Debug, Clone)]
struct TipLink<T> {
    rotation: OriginRotation<T>,
    translation: [T; 3],
}

/// An origin's rotation: constant (f64) or carrying derivatives.
#[derive(Debug, Clone)]
enum OriginRotation<T> {
    Constant([[f64; 3]; 3]),
    Variable([[T; 3]; 3]),
}

impl<T: Scalar> TipChain<T> {
    /// The chain of `geometry`; `variable_angles[j]` says whether joint `j`'s origin angles
    /// carry derivatives (if not, their f64 values are used).
    pub fn new(geometry: &LegGeometry<T>, variable_angles: &[bool]) -> Self {
        let links = geometry
            .origins
            .iter()
            .enumerate()
            .map(|(j, origin)| {
                let rigid = Rigid::from_origin(origin);
                let rotation = if variable_angles.get(j).copied().unwrap_or(true) {
                    OriginRotation::Variable(rigid.rotation)
                } else {
                    let values = origin.map(|v| v.re());
                    OriginRotation::Constant(Rigid::from_origin(&values).rotation)
                };
                TipLink {
                    rotation,
                    translation: rigid.translation,
                }
            })
            .collect();
        Self { links }
    }

    /// The tip position for the moving joints' values `q` (f64: their motions enter as
    /// constants).
    pub fn tip(&self, leg: &LegModel, q: &[f64]) -> Vector3<T> {
        let zero = lift::<T>(0.0);
        let mut p = [zero; 3];
        let mut next = leg.moving.len();
        for (joint, link) in leg.joints.iter().zip(&self.links).rev() {
            if joint.is_moving() {
                next -= 1;
                match joint_motion(joint, q[next]) {
                    Motion::Rotation(r) => p = constant_times(&r, &p),
                    Motion::Translation(a) => {
                        for (pi, ai) in p.iter_mut().zip(a) {
                            *pi += lift::<T>(ai);
                        }
                    }
                    Motion::Still => {}
                }
            }
            let [x, y, z] = match &link.rotation {
                OriginRotation::Constant(r) => constant_times(r, &p),
                OriginRotation::Variable(r) => [
                    r[0][0] * p[0] + r[0][1] * p[1] + r[0][2] * p[2],
                    r[1][0] * p[0] + r[1][1] * p[1] + r[1][2] * p[2],
                    r[2][0] * p[0] + r[2][1] * p[1] + r[2][2] * p[2],
                ],
            };
            let [tx, ty, tz] = link.translation;
            p = [x + tx, y + ty, z + tz];
        }
        Vector3::new(p[0], p[1], p[2])
    }
}

/// `r · p` for an f64 matrix and a vector of scalars.
#[inline]
fn constant_times<T: Scalar>(r: &[[f64; 3]; 3], p: &[T; 3]) -> [T; 3] {
    [
        p[0] * r[0][0] + p[1] * r[0][1] + p[2] * r[0][2],
        p[0] * r[1][0] + p[1] * r[1][1] + p[2] * r[1][2],
        p[0] * r[2][0] + p[1] * r[2][1] + p[2] * r[2][2],
    ]
}

/// World position of an attachment point (in any scalar) on a platform at the f64 transform
/// `platform`, with the platform's rotation and translation as f64 constants: the numbers of
/// [`attachment_on`] without lifting the rotation into `T`.
pub fn attachment_on_constant<T: Scalar>(
    platform: &Transform<f64>,
    attachment: &[T; 3],
) -> Vector3<T> {
    let m = platform.rotation.matrix();
    let t = &platform.translation.vector;
    let row = |i: usize| {
        attachment[0] * m[(i, 0)] + attachment[1] * m[(i, 1)] + attachment[2] * m[(i, 2)] + t[i]
    };
    Vector3::new(row(0), row(1), row(2))
}

#[cfg(test)]
mod tests {
    use super::{platform_transform, platform_transform_f64, Transform};

    /// The shortcut for an orientation of exactly `+0` gives the Euler-angle transform bit for
    /// bit (its `−0` entry included), and every other orientation (`−0` too) goes through it.
    #[test]
    fn the_f64_platform_transform_equals_the_generic_one_bit_for_bit() {
        let bits = |t: Transform<f64>| -> Vec<u64> {
            t.to_homogeneous().iter().map(|v| v.to_bits()).collect()
        };
        let poses = [
            [0.3, -1.2, 0.0, 0.0, 0.0, 0.0],
            [-0.0, 1e-300, 7.5, 0.0, 0.0, 0.0],
            [0.3, -1.2, 0.1, -0.0, 0.0, 0.0],
            [0.3, -1.2, 0.1, 0.0, -0.0, -0.0],
            [0.3, -1.2, 0.1, 0.2, -0.1, 1.3],
            [0.3, -1.2, 0.1, 0.0, 0.0, 1e-9],
        ];
        for pose in poses {
            let generic = platform_transform(&pose);
            assert_eq!(
                bits(platform_transform_f64(&pose)),
                bits(generic),
                "{pose:?}"
            );
        }
        // The shortcut's rotation is not the plain identity: −sin(+0) is −0.
        let planar = platform_transform_f64(&poses[0]);
        assert_eq!(
            planar.rotation.matrix()[(2, 0)].to_bits(),
            (-0.0f64).to_bits()
        );
    }
}
