//! The closed-form inverse kinematics of a distance leg: passive revolutes whose axes meet at
//! one point `C` at the base (one about `±z` in the plane, two in space: a universal joint),
//! then the actuated prismatic joint along a line through `C`, then optionally fixed offsets
//! along that line to the tip. The tip is `C + (ρ + s) u`, `u` the prismatic axis turned by the
//! revolutes and `s` the offsets' sum along it, so the actuated joint reaching the target `P`
//! is `ρ = σ |P − C| − s`: a distance. The sign `σ` of `ρ + s` is the leg's working mode in the
//! plane (the closure Jacobian's determinant is `−s₁ (ρ + s)`, `s₁` the revolute's axis sign)
//! and the home configuration's in space (where the working mode picks the universal joint's
//! solution instead, [`super::pointing`]).
//!
//! The pattern, recognised from the chain alone ([`DistanceLeg::recognise`]): `closure_dims`
//! moving joints, revolutes first and the actuated prismatic last; no translation between the
//! first revolute and the prismatic joint (their origins' translations zero, no parameter on
//! them); after it only fixed joints without rotation whose translations lie on the prismatic
//! axis' line (a parameter may move only the component along a coordinate axis that the axis
//! is). In the plane, besides, every origin without roll or pitch, the revolute about exactly
//! `±z` and the prismatic axis in the plane. Everything before the first revolute (fixed
//! joints, its origin) is free: it places `C` and the revolutes' frame.

use nalgebra::{Matrix3, Vector3};

use super::inverse::{normalised_determinant, Joints, Solution, SINGULAR_DETERMINANT};
use super::pointing::{composed, on_line, rotation_value, still, Pointed, Pointing};
use crate::model::joint::JointKind;
use crate::model::leg::{LegGeometry, LegModel};
use crate::scalar::{lift, Scalar};

/// A leg recognised as a distance leg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceLeg {
    /// Chain indices of the first revolute, of the second (in space) and of the prismatic
    /// joint.
    first: usize,
    second: Option<usize>,
    prismatic: usize,
    /// The revolutes' unit axes (in their joint frames; the second's zero in the plane).
    revolute_axes: [[f64; 3]; 2],
    /// The prismatic joint's unit axis (in its joint frame).
    axis: [f64; 3],
    /// `σ`: the sign of `ρ + s` on the working mode.
    sigma: f64,
    /// The universal joint's solution on the working mode ([`Pointing::solve`]'s `side`):
    /// the closure Jacobian's determinant is `(ρ + s)² γ |w₁ × w₂|²`, of the side's sign.
    side: f64,
    /// Whether the working mode's determinant is positive.
    home_positive: bool,
}

/// A distance leg's geometry at one parameter vector: `C` and `s` in `T`, the revolutes'
/// frame in f64 (the passive joints are solved in f64 only).
#[derive(Debug, Clone, Copy)]
pub struct DistanceFrame<T> {
    /// The revolutes' common point `C` (world).
    centre: [T; 3],
    /// `s`: the fixed offsets' sum along the prismatic axis.
    offset: T,
    pointing: Pointing,
}

impl DistanceLeg {
    /// The distance-leg pattern of `leg`, if its chain is one exactly (see the module).
    pub fn recognise(leg: &LegModel) -> Option<Self> {
        let dims = leg.closure_dims;
        let n = leg.moving.len();
        if !matches!((dims, n), (2, 2) | (3, 3)) || leg.actuated != n - 1 {
            return None;
        }
        let joints = &leg.joints;
        let (first, prismatic) = (leg.moving[0], leg.moving[n - 1]);
        if joints[prismatic].kind != JointKind::Prismatic
            || leg.moving[..n - 1]
                .iter()
                .any(|&j| joints[j].kind != JointKind::Revolute)
        {
            return None;
        }
        let axis = joints[prismatic].axis;
        let between = (first + 1..=prismatic).all(|j| still(leg, j, 0..3));
        let after = (prismatic + 1..joints.len()).all(|j| {
            joints[j].kind == JointKind::Fixed && still(leg, j, 3..6) && on_line(leg, j, &axis)
        });
        if !between || !after {
            return None;
        }
        let planar = dims == 2;
        let home_positive = leg.branch_sign.is_sign_positive();
        let branch = if home_positive { 1.0 } else { -1.0 };
        let w = joints[first].axis;
        let sigma = if planar {
            let flat = (0..joints.len()).all(|j| still(leg, j, 3..5));
            let about_z = w[0] == 0.0 && w[1] == 0.0 && w[2].abs().to_bits() == 1.0f64.to_bits();
            if !flat || !about_z || axis[2] != 0.0 {
                return None;
            }
            -w[2] * branch
        } else {
            // ρ + s at home on the nominal geometry.
            let offset: f64 = (prismatic + 1..joints.len())
                .map(|j| {
                    let o = &joints[j].origin;
                    o[0] * axis[0] + o[1] * axis[1] + o[2] * axis[2]
                })
                .sum();
            let length = leg.home_joints.get(n - 1)? + offset;
            if !(length != 0.0 && length.is_finite()) {
                return None;
            }
            length.signum()
        };
        let second = (!planar).then(|| leg.moving[1]);
        let second_axis = second.map_or([0.0; 3], |j| joints[j].axis.into());
        Some(Self {
            first,
            second,
            prismatic,
            revolute_axes: [w.into(), second_axis],
            axis: axis.into(),
            sigma,
            side: branch,
            home_positive,
        })
    }

    /// The leg's geometry at `geometry`.
    pub fn frame<T: Scalar>(&self, geometry: &LegGeometry<T>) -> DistanceFrame<T> {
        let base = composed(geometry, 0..self.first + 1);
        let axis = Vector3::from(self.axis);
        let t = &base.translation.vector;
        let offset = self.offset(geometry);
        // The joints after the first revolute up to the prismatic one only turn.
        let (second, pointer) = match self.second {
            Some(second) => {
                let to_second = rotation_value(&composed(geometry, self.first + 1..second + 1));
                let to_prismatic =
                    rotation_value(&composed(geometry, second + 1..self.prismatic + 1));
                (
                    Some(to_second * Vector3::from(self.revolute_axes[1])),
                    to_second * (to_prismatic * axis),
                )
            }
            None => {
                let to_prismatic =
                    rotation_value(&composed(geometry, self.first + 1..self.prismatic + 1));
                (None, to_prismatic * axis)
            }
        };
        let first_axis = Vector3::from(self.revolute_axes[0]);
        DistanceFrame {
            centre: [t[0], t[1], t[2]],
            offset,
            pointing: Pointing::new(rotation_value(&base), first_axis, second, pointer),
        }
    }

    /// [`DistanceFrame::scalars`] of [`Self::frame`] at `geometry`, bit for bit, without the
    /// revolutes' pointing (f64 only): what a derivative pass needs of the frame.
    pub fn frame_scalars<T: Scalar>(&self, geometry: &LegGeometry<T>) -> [T; 8] {
        let t = composed(geometry, 0..self.first + 1).translation.vector;
        let zero = lift::<T>(0.0);
        [
            t[0],
            t[1],
            self.offset(geometry),
            t[2],
            zero,
            zero,
            zero,
            zero,
        ]
    }

    /// `s`: the origins after the prismatic joint along its axis.
    #[inline]
    fn offset<T: Scalar>(&self, geometry: &LegGeometry<T>) -> T {
        let axis = Vector3::from(self.axis);
        (self.prismatic + 1..geometry.origins.len())
            .map(|j| {
                let o = &geometry.origins[j];
                o[0] * lift::<T>(axis[0]) + o[1] * lift::<T>(axis[1]) + o[2] * lift::<T>(axis[2])
            })
            .fold(lift::<T>(0.0), |sum, v| sum + v)
    }

    /// The closure coordinates: 2 in the plane, 3 in space.
    fn dims(&self) -> usize {
        if self.second.is_some() {
            3
        } else {
            2
        }
    }

    /// `P − C` on the closure coordinates and its length; `None` for a zero or non-finite
    /// length.
    fn reach<T: Scalar>(
        &self,
        frame: &DistanceFrame<T>,
        target: &Vector3<T>,
    ) -> Option<([T; 3], T)> {
        let c = &frame.centre;
        let mut e = [target[0] - c[0], target[1] - c[1], target[2] - c[2]];
        if self.dims() == 2 {
            e[2] = lift::<T>(0.0);
        }
        let distance = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        let value = distance.re();
        (value > 0.0 && value.is_finite()).then_some((e, distance))
    }

    /// The solved leg at `target`: `ρ`, the revolutes' angles and world axes, the closure
    /// Jacobian and its normalised determinant; `None` where the generic solve must decide (no
    /// direction, a reach limit at the generic solve's threshold, the other working mode).
    fn solved(
        &self,
        frame: &DistanceFrame<f64>,
        target: &Vector3<f64>,
    ) -> Option<(f64, Pointed, Matrix3<f64>, f64)> {
        let (e, distance) = self.reach(frame, target)?;
        let e = Vector3::from(e);
        let direction = e * (self.sigma / distance);
        let length = self.sigma * distance - frame.offset;
        let pointed = frame.pointing.solve(&direction, self.side)?;
        let dims = self.dims();
        let mut jacobian = Matrix3::zeros();
        for (k, axis) in pointed.axes.iter().take(dims - 1).enumerate() {
            jacobian.set_column(k, &axis.cross(&e));
        }
        jacobian.set_column(dims - 1, &direction);
        if dims == 2 {
            jacobian.row_mut(2).fill(0.0);
        }
        let determinant = normalised_determinant(&jacobian, dims);
        let near_limit = determinant.abs() <= SINGULAR_DETERMINANT;
        if near_limit || determinant.is_sign_positive() != self.home_positive || !length.is_finite()
        {
            return None;
        }
        Some((length, pointed, jacobian, determinant))
    }

    /// The joints reaching `target` (world), revolutes in the 2π window centred on `seed`, with
    /// the closure Jacobian's inverse and normalised determinant: the [`Solution`] Newton's
    /// method converges to, to round-off; `None` where the generic solve must decide.
    pub fn solve(
        &self,
        frame: &DistanceFrame<f64>,
        target: &Vector3<f64>,
        seed: &Joints,
    ) -> Option<Solution> {
        let (length, pointed, jacobian, determinant) = self.solved(frame, target)?;
        let dims = self.dims();
        let mut q = [0.0; 3];
        for k in 0..dims - 1 {
            q[k] = super::dyad::on_turn_of(pointed.angles[k], seed[k]);
        }
        q[dims - 1] = length;
        Solution::closed(q, &jacobian, dims, determinant)
    }

    /// The actuated joint `ρ` at `target` and the actuated row of the closure Jacobian's
    /// inverse there (`σ (P − C) / |P − C|`: the prismatic axis' world direction), without the
    /// passive joints: the reach-limit test on the normalised determinant's magnitude
    /// ([`Pointing::conditioning`]; on the working mode by construction: its sign is the
    /// side's). `None` where [`Self::solve`] leaves the pose to the generic solve (to
    /// round-off at the threshold).
    pub fn actuated_row(
        &self,
        frame: &DistanceFrame<f64>,
        target: &Vector3<f64>,
    ) -> Option<(f64, [f64; 3])> {
        let (e, distance) = self.reach(frame, target)?;
        let u = Vector3::from(e) * (self.sigma / distance);
        let length = self.sigma * distance - frame.offset;
        let conditioning = frame.pointing.conditioning(&u)?;
        (conditioning > SINGULAR_DETERMINANT && length.is_finite())
            .then_some((length, [u[0], u[1], u[2]]))
    }

    /// `ρ = σ |P − C| − s` in `T` (exact derivatives with respect to whatever the frame and the
    /// target carry); `None` for a target at `C`.
    pub fn actuated<T: Scalar>(&self, frame: &DistanceFrame<T>, target: &Vector3<T>) -> Option<T> {
        let (_, distance) = self.reach(frame, target)?;
        Some(distance * lift::<T>(self.sigma) - frame.offset)
    }

    /// [`Self::actuated`] in f64 from the frame's numbers `frame` ([`DistanceFrame::scalars`]:
    /// `C`'s x and y, `s`, `C`'s z) and the target's world `(x, y, z)`, with its partial
    /// derivatives with respect to the frame's eight numbers and the target's three (in the
    /// plane the z's are not closure coordinates: their partials are zero); `None` for a target
    /// at `C`.
    pub fn actuated_partials(
        &self,
        frame: &[f64; 8],
        target: [f64; 3],
    ) -> Option<(f64, [f64; 11])> {
        let across = match self.second {
            Some(_) => target[2] - frame[3],
            None => 0.0,
        };
        let e = [target[0] - frame[0], target[1] - frame[1], across];
        let distance = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        if !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        let value = distance * self.sigma - frame[2];
        let d = e.map(|v| self.sigma * v / distance);
        let mut p = [0.0; 11];
        (p[0], p[1], p[2], p[3]) = (-d[0], -d[1], -1.0, -d[2]);
        (p[8], p[9], p[10]) = (d[0], d[1], d[2]);
        Some((value, p))
    }
}

impl<T: Scalar> DistanceFrame<T> {
    /// The frame's numbers the reading depends on: `C`'s x and y, `s`, `C`'s z (the rest zero).
    pub fn scalars(&self) -> [T; 8] {
        let zero = lift::<T>(0.0);
        let [x, y, z] = self.centre;
        [x, y, self.offset, z, zero, zero, zero, zero]
    }
}
