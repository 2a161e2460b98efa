//! The closed-form inverse kinematics of a carriage leg (a linear delta's): the actuated
//! prismatic joint first (the carriage, moving the point `K(q) = K₀ + q v` along the unit
//! world direction `v`), then two passive revolutes whose axes meet at `K(q)` (a universal
//! joint), then a fixed rod of length `L` to the tip. The tip is on the sphere of radius `L`
//! about `K(q)`, so the carriage reaching the target `P` solves `|P − K₀ − q v| = L`:
//! `q = v·e + σ √((v·e)² − |e|² + L²)` with `e = P − K₀`, the sign `σ` the home
//! configuration's (the rod's side of the carriage along `v`); the universal joint's two
//! solutions are told apart by the working mode ([`super::pointing`]).
//!
//! The pattern, recognised from the chain alone ([`CarriageLeg::recognise`]): a spatial leg
//! (`closure_dims` 3) whose moving joints are the actuated prismatic joint then two revolutes,
//! with no translation from the first revolute to the second (their origins' translations
//! zero, no parameter on them). Everything else is free: fixed joints and origins before the
//! carriage (its line), between it and the first revolute (the joint's offset from the
//! carriage), after the second revolute (the rod, any rigid offset).

use nalgebra::{Matrix3, Vector3};

use super::chain::{tip_position, Transform};
use super::inverse::{normalised_determinant, Joints, Solution, SINGULAR_DETERMINANT};
use super::pointing::{composed, rotation_value, still, vector_value, Pointed, Pointing};
use crate::model::joint::JointKind;
use crate::model::leg::{LegGeometry, LegModel};
use crate::scalar::{lift, Scalar};

/// A leg recognised as a carriage leg.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarriageLeg {
    /// Chain indices of the prismatic joint and of the two revolutes.
    joints: [usize; 3],
    /// The prismatic joint's and the revolutes' unit axes (in their joint frames).
    axes: [[f64; 3]; 3],
    /// `σ`: the sign of `q − v·e`, the rod's side of the carriage (minus the sign of `v`
    /// along the rod) at home.
    sigma: f64,
    /// The universal joint's solution on the working mode ([`Pointing::solve`]'s `side`): the
    /// closure Jacobian's determinant is `L² (v·u) γ |w₁ × w₂|²`, `u` the rod's direction.
    side: f64,
    /// Whether the working mode's determinant is positive.
    home_positive: bool,
}

/// A carriage leg's geometry at one parameter vector: the carriage line and the rod's length
/// in `T`, the revolutes' frame in f64 (the passive joints are solved in f64 only).
#[derive(Debug, Clone, Copy)]
pub struct CarriageFrame<T> {
    /// `K₀`: the revolutes' common point at a zero carriage (world).
    start: [T; 3],
    /// `v`: the carriage's world direction (unit).
    direction: [T; 3],
    /// `L²`.
    squared_rod: T,
    pointing: Pointing,
}

/// The carriage's line in a leg's geometry ([`CarriageLeg::frame`]).
struct CarriageLine<T: Scalar> {
    /// The carriage joint's frame at a zero carriage.
    carriage: Transform<T>,
    /// From the carriage's frame to the first revolute's.
    to_first: Transform<T>,
    /// The first revolute's joint index.
    first: usize,
    /// `v`: the carriage's world direction.
    direction: [T; 3],
}

/// A carriage leg solved at one target.
struct Solved {
    /// The carriage.
    q: f64,
    pointed: Pointed,
    jacobian: Matrix3<f64>,
    determinant: f64,
}

impl CarriageLeg {
    /// The carriage-leg pattern of `leg`, if its chain is one exactly (see the module).
    pub fn recognise(leg: &LegModel) -> Option<Self> {
        if leg.closure_dims != 3 || leg.moving.len() != 3 || leg.actuated != 0 {
            return None;
        }
        let [p, r1, r2] = [leg.moving[0], leg.moving[1], leg.moving[2]];
        let kinds = [
            JointKind::Prismatic,
            JointKind::Revolute,
            JointKind::Revolute,
        ];
        if [p, r1, r2]
            .iter()
            .zip(kinds)
            .any(|(&j, kind)| leg.joints[j].kind != kind)
        {
            return None;
        }
        if !(r1 + 1..=r2).all(|j| still(leg, j, 0..3)) {
            return None;
        }
        let home_positive = leg.branch_sign.is_sign_positive();
        let mut kernel = Self {
            joints: [p, r1, r2],
            axes: [p, r1, r2].map(|j| leg.joints[j].axis.into()),
            sigma: 1.0,
            side: 1.0,
            home_positive,
        };
        // The rod's side of the carriage at home, on the nominal geometry.
        let geometry = leg.geometry(&leg.nominal());
        let frame = kernel.frame(&geometry);
        let home = leg.home_joints.first()?;
        let tip = tip_position(leg, &geometry, &leg.home_joints);
        let v = Vector3::from(frame.direction);
        let rod = tip - Vector3::from(frame.start) - v * *home;
        let along = v.dot(&rod);
        if !(along != 0.0 && along.is_finite()) {
            return None;
        }
        kernel.sigma = -along.signum();
        let branch = if home_positive { 1.0 } else { -1.0 };
        kernel.side = -kernel.sigma * branch;
        Some(kernel)
    }

    /// The leg's geometry at `geometry`.
    pub fn frame<T: Scalar>(&self, geometry: &LegGeometry<T>) -> CarriageFrame<T> {
        let [_, _, r2] = self.joints;
        let [_, w1, w2] = self.axes.map(Vector3::from);
        let (line, rod) = self.line(geometry);
        let base = line.carriage * line.to_first;
        let to_second = rotation_value(&composed(geometry, line.first + 1..r2 + 1));
        let t = &base.translation.vector;
        CarriageFrame {
            start: [t[0], t[1], t[2]],
            direction: line.direction,
            squared_rod: rod.dot(&rod),
            pointing: Pointing::new(
                rotation_value(&base),
                w1,
                Some(to_second * w2),
                to_second * vector_value(&rod),
            ),
        }
    }

    /// [`CarriageFrame::scalars`] of [`Self::frame`] at `geometry`, bit for bit, without the
    /// revolutes' pointing (f64 only) and the base's rotation: what a derivative pass needs of
    /// the frame.
    pub fn frame_scalars<T: Scalar>(&self, geometry: &LegGeometry<T>) -> [T; 8] {
        let (line, rod) = self.line(geometry);
        // The translation of `carriage * to_first`, summed as the isometries' product sums it.
        let shift = line.carriage.rotation * line.to_first.translation.vector;
        let t = line.carriage.translation.vector + shift;
        let [vx, vy, vz] = line.direction;
        [t[0], t[1], t[2], vx, vy, vz, rod.dot(&rod), lift::<T>(0.0)]
    }

    /// The carriage's line at `geometry`: its frame, the transform on to the first revolute
    /// and the carriage's world direction; and the rod (from the second revolute to the tip,
    /// in the rod's frame).
    fn line<T: Scalar>(&self, geometry: &LegGeometry<T>) -> (CarriageLine<T>, Vector3<T>) {
        let [p, r1, r2] = self.joints;
        let carriage = composed(geometry, 0..p + 1);
        let a = Vector3::from(self.axes[0]);
        let direction = carriage.rotation.matrix() * a.map(lift::<T>);
        let to_first = composed(geometry, p + 1..r1 + 1);
        let rod = composed(geometry, r2 + 1..geometry.origins.len())
            .translation
            .vector;
        let line = CarriageLine {
            carriage,
            to_first,
            first: r1,
            direction: [direction[0], direction[1], direction[2]],
        };
        (line, rod)
    }

    /// The carriage `q` reaching `target` on the home side and the target from the start
    /// `e = P − K₀`; `None` where the sphere misses the carriage line or touches it (a reach
    /// limit) or a number is not finite.
    fn carriage<T: Scalar>(
        &self,
        frame: &CarriageFrame<T>,
        target: &Vector3<T>,
    ) -> Option<(T, [T; 3])> {
        let (k, v) = (&frame.start, &frame.direction);
        let e = [target[0] - k[0], target[1] - k[1], target[2] - k[2]];
        let along = v[0] * e[0] + v[1] * e[1] + v[2] * e[2];
        let discriminant =
            along * along - (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) + frame.squared_rod;
        let value = discriminant.re();
        if !(value > 0.0 && value.is_finite()) {
            return None;
        }
        Some((along + discriminant.sqrt() * lift::<T>(self.sigma), e))
    }

    /// The solved leg at `target`: the carriage, the rod `P − K(q)`, the revolutes' angles
    /// and world axes, the closure Jacobian and its normalised determinant; `None` where the
    /// generic solve must decide.
    fn solved(&self, frame: &CarriageFrame<f64>, target: &Vector3<f64>) -> Option<Solved> {
        let (q, e) = self.carriage(frame, target)?;
        let v = Vector3::from(frame.direction);
        let rod = Vector3::from(e) - v * q;
        let length = frame.squared_rod.sqrt();
        let pointed = frame.pointing.solve(&(rod / length), self.side)?;
        let mut jacobian = Matrix3::zeros();
        jacobian.set_column(0, &v);
        for (k, axis) in pointed.axes.iter().enumerate() {
            jacobian.set_column(k + 1, &axis.cross(&rod));
        }
        let determinant = normalised_determinant(&jacobian, 3);
        let near_limit = determinant.abs() <= SINGULAR_DETERMINANT;
        if near_limit || determinant.is_sign_positive() != self.home_positive || !q.is_finite() {
            return None;
        }
        Some(Solved {
            q,
            pointed,
            jacobian,
            determinant,
        })
    }

    /// The joints reaching `target` (world), revolutes in the 2π window centred on `seed`, with
    /// the closure Jacobian's inverse and normalised determinant: the [`Solution`] Newton's
    /// method converges to, to round-off; `None` where the generic solve must decide.
    pub fn solve(
        &self,
        frame: &CarriageFrame<f64>,
        target: &Vector3<f64>,
        seed: &Joints,
    ) -> Option<Solution> {
        let Solved {
            q,
            pointed,
            jacobian,
            determinant,
            ..
        } = self.solved(frame, target)?;
        let mut joints = [q, 0.0, 0.0];
        for k in 0..2 {
            joints[k + 1] = super::dyad::on_turn_of(pointed.angles[k], seed[k + 1]);
        }
        Solution::closed(joints, &jacobian, 3, determinant)
    }

    /// The carriage `q` at `target` and the actuated row of the closure Jacobian's inverse
    /// there (`r / (r·v)`, `r` the rod), without the universal joint's angles: the reach-limit
    /// test on the normalised determinant's magnitude `|v·u|` times
    /// [`Pointing::conditioning`] (on the working mode by construction: the side is picked
    /// for it). `None` where [`Self::solve`] leaves the pose to the generic solve (to
    /// round-off at the threshold).
    pub fn actuated_row(
        &self,
        frame: &CarriageFrame<f64>,
        target: &Vector3<f64>,
    ) -> Option<(f64, [f64; 3])> {
        let (q, e) = self.carriage(frame, target)?;
        let v = Vector3::from(frame.direction);
        let rod = Vector3::from(e) - v * q;
        let along = rod.dot(&v);
        let u = rod / frame.squared_rod.sqrt();
        let conditioning = frame.pointing.conditioning(&u)? * u.dot(&v).abs();
        let row = rod / along;
        (conditioning > SINGULAR_DETERMINANT && row.iter().all(|x| x.is_finite()))
            .then_some((q, [row[0], row[1], row[2]]))
    }

    /// The carriage `q` at `target` in `T` (exact derivatives with respect to whatever the
    /// frame and the target carry); `None` where the sphere misses the line.
    pub fn actuated<T: Scalar>(&self, frame: &CarriageFrame<T>, target: &Vector3<T>) -> Option<T> {
        self.carriage(frame, target).map(|(q, _)| q)
    }

    /// Where the carriage `actuated` puts the universal joint, `K(q) = K₀ + q v` (world), and the
    /// rod's length `L`: the leg's tip is on the sphere of radius `L` about it.
    pub(crate) fn tip_sphere(&self, frame: &CarriageFrame<f64>, actuated: f64) -> ([f64; 3], f64) {
        let (k, v) = (frame.start, frame.direction);
        let centre = [0, 1, 2].map(|i| k[i] + actuated * v[i]);
        (centre, frame.squared_rod.sqrt())
    }

    /// [`Self::actuated`] in f64 from the frame's numbers `frame` ([`CarriageFrame::scalars`]:
    /// `K₀`, `v`, `L²`) and the target's world `(x, y, z)`, with its partial derivatives with
    /// respect to the frame's eight numbers and the target's three: with `e = P − K₀`,
    /// `a = v·e` and `D = a² − |e|² + L²`, `∂q/∂P = −∂q/∂K₀ = v + σ (a v − e)/√D`,
    /// `∂q/∂v = e (1 + σ a/√D)` and `∂q/∂L² = σ/(2√D)`. The value is [`Self::actuated`]'s bit
    /// for bit; `None` where the sphere misses the line.
    pub fn actuated_partials(
        &self,
        frame: &[f64; 8],
        target: [f64; 3],
    ) -> Option<(f64, [f64; 11])> {
        let (k, v, squared_rod) = (
            [frame[0], frame[1], frame[2]],
            [frame[3], frame[4], frame[5]],
            frame[6],
        );
        let e = [target[0] - k[0], target[1] - k[1], target[2] - k[2]];
        let along = v[0] * e[0] + v[1] * e[1] + v[2] * e[2];
        let discriminant = along * along - (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) + squared_rod;
        if !(discriminant > 0.0 && discriminant.is_finite()) {
            return None;
        }
        let root = discriminant.sqrt();
        let value = along + root * self.sigma;
        let by_target: [f64; 3] =
            std::array::from_fn(|i| v[i] + self.sigma * (along * v[i] - e[i]) / root);
        let stretch = 1.0 + self.sigma * along / root;
        let mut p = [0.0; 11];
        for i in 0..3 {
            p[i] = -by_target[i];
            p[3 + i] = e[i] * stretch;
            p[8 + i] = by_target[i];
        }
        p[6] = self.sigma / (2.0 * root);
        Some((value, p))
    }
}

impl<T: Scalar> CarriageFrame<T> {
    /// The frame's numbers the reading depends on: `K₀`, `v`, `L²` (the last zero).
    pub fn scalars(&self) -> [T; 8] {
        let [kx, ky, kz] = self.start;
        let [vx, vy, vz] = self.direction;
        [kx, ky, kz, vx, vy, vz, self.squared_rod, lift::<T>(0.0)]
    }
}
