//! The closed-form inverse kinematics of a planar two-revolute dyad reaching a point: a circle
//! intersection, generic over the scalar (f64 for the solve, dual numbers for the exact
//! derivatives of the reading from the same code).
//!
//! The pattern, recognised from the chain alone ([`Dyad::recognise`]): a planar leg
//! (`closure_dims` 2) whose moving joints are exactly two revolutes about `±z`, every chain
//! joint's origin without roll or pitch (nominal zero and no parameter on them), any number of
//! fixed joints before, between and after. Every rotation of the chain is then about `z`, and
//! the tip's `(x, y)` is `A + R(α + θ₁) u + R(α + θ₁ + β + θ₂) v`: the base point `A` and angle
//! `α` of the first revolute, the link `u` from it to the second (the elbow `B`) and the angle
//! `β` between them, the link `v` from the elbow to the tip (θₖ the joint's rotation, its value
//! times its axis' sign). The elbow is on both the circle of radius `|u|` about `A` and the
//! circle of radius `|v|` about the target `P`; the leg's working mode (the sign of its closure
//! Jacobian's determinant at home) picks which of the two intersections.

use std::f64::consts::TAU;

use nalgebra::{Matrix3, Vector3};

use super::arc_tangent;
use super::inverse::{normalised_determinant, wrap_angle, Joints, Solution, SINGULAR_DETERMINANT};
use crate::model::joint::JointKind;
use crate::model::leg::{LegGeometry, LegModel};
use crate::model::params::ParamTarget;
use crate::scalar::{lift, Scalar};

/// A leg recognised as a planar two-revolute dyad: where its revolutes are and how they turn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dyad {
    /// Chain indices of the first and second revolute.
    joints: [usize; 2],
    /// The sign of each revolute's axis (`+1` about `+z`, `−1` about `−z`).
    signs: [f64; 2],
    /// Which revolute is actuated (0 or 1).
    actuated: usize,
    /// The elbow's side of the line from the base point to the target: `+1` to the left.
    side: f64,
    /// Whether the working mode's determinant is positive ([`LegModel::on_home_branch`]).
    home_positive: bool,
}

/// A dyad's geometry at one parameter vector, in scalar `T` (see the module's notation).
#[derive(Debug, Clone, Copy)]
pub struct DyadFrame<T> {
    /// The first revolute's position `A`, world `(x, y)`.
    base: [T; 2],
    /// `|u|²` and `|v|²`.
    squared_lengths: [T; 2],
    /// The world direction of `u` at `θ₁ = 0`: `(cos, sin)` of `α + ∠u`.
    inner_direction: [T; 2],
    /// `(cos, sin)` of `β + ∠v − ∠u`: the turn from the direction of `u` to that of `v` at
    /// `θ₂ = 0`.
    outer_turn: [T; 2],
}

/// Chain-origin components that must stay zero for the chain to be planar: roll and pitch.
const OUT_OF_PLANE: [usize; 2] = [3, 4];

impl Dyad {
    /// The dyad pattern of `leg`, if its chain is one exactly (see the module); `None` for any
    /// other chain (extra moving joints, a prismatic joint, a tilted axis or origin).
    pub fn recognise(leg: &LegModel) -> Option<Self> {
        if leg.closure_dims != 2 || leg.moving.len() != 2 {
            return None;
        }
        let mut signs = [0.0; 2];
        for (sign, &j) in signs.iter_mut().zip(&leg.moving) {
            let joint = &leg.joints[j];
            let axis = joint.axis;
            if joint.kind != JointKind::Revolute || axis[0] != 0.0 || axis[1] != 0.0 {
                return None;
            }
            // Exactly ±z (a unit axis: |z| = 1 bit for bit).
            if axis[2].abs().to_bits() != 1.0f64.to_bits() {
                return None;
            }
            *sign = axis[2];
        }
        let tilted = leg
            .joints
            .iter()
            .any(|joint| OUT_OF_PLANE.iter().any(|&c| joint.origin[c] != 0.0));
        let tilting_parameter = leg.params.iter().any(|p| {
            matches!(p.target, ParamTarget::JointOrigin { component, .. }
                if OUT_OF_PLANE.contains(&component))
        });
        if tilted || tilting_parameter {
            return None;
        }
        // The determinant of the closure Jacobian is −s₁s₂·side·h·d (h the elbow's distance
        // from the line, d the base–target distance): the side that gives the home sign.
        let home_positive = leg.branch_sign.is_sign_positive();
        let home = if home_positive { 1.0 } else { -1.0 };
        Some(Self {
            joints: [leg.moving[0], leg.moving[1]],
            signs,
            actuated: leg.actuated,
            side: -signs[0] * signs[1] * home,
            home_positive,
        })
    }

    /// The dyad's geometry at `geometry` (composing the chain's origins in the plane).
    pub fn frame<T: Scalar>(&self, geometry: &LegGeometry<T>) -> DyadFrame<T> {
        let zero = lift::<T>(0.0);
        let mut position = [zero; 2];
        let mut angle = zero;
        let mut parts = [([zero; 2], zero); 2];
        for (j, origin) in geometry.origins.iter().enumerate() {
            let [x, y] = rotated(angle, [origin[0], origin[1]]);
            position = [position[0] + x, position[1] + y];
            angle += origin[5];
            if let Some(k) = self.joints.iter().position(|&r| r == j) {
                // The next part is measured in this revolute's moved frame.
                parts[k] = (position, angle);
                position = [zero; 2];
                angle = zero;
            }
        }
        let [(base, alpha), (u, beta)] = parts;
        let v = position;
        let squared = |w: [T; 2]| w[0] * w[0] + w[1] * w[1];
        let unit = |w: [T; 2]| {
            let norm = squared(w).sqrt();
            [w[0] / norm, w[1] / norm]
        };
        let (u_hat, v_hat) = (unit(u), unit(v));
        // v̂ · conj(û) turned by β, as complex numbers.
        let relative = [
            v_hat[0] * u_hat[0] + v_hat[1] * u_hat[1],
            v_hat[1] * u_hat[0] - v_hat[0] * u_hat[1],
        ];
        DyadFrame {
            base,
            squared_lengths: [squared(u), squared(v)],
            inner_direction: rotated(alpha, u_hat),
            outer_turn: rotated(beta, relative),
        }
    }

    /// The elbow's position from the base (`B − A`) and the target's from the elbow (`P − B`)
    /// reaching the world point `target` on the leg's working mode; `None` if the circles do
    /// not meet.
    fn elbow<T: Scalar>(&self, frame: &DyadFrame<T>, target: [T; 2]) -> Option<[[T; 2]; 2]> {
        let e = [target[0] - frame.base[0], target[1] - frame.base[1]];
        let d2 = e[0] * e[0] + e[1] * e[1];
        let [l2, outer2] = frame.squared_lengths;
        // The elbow's projection on the base–target line and its distance from it, both over
        // the line's length d: B − A = (a/d) e + side (h/d) e⊥.
        let along = (l2 - outer2 + d2) / (lift::<T>(2.0) * d2);
        let across2 = l2 / d2 - along * along;
        if across2.re().is_nan() || across2.re() <= 0.0 {
            return None;
        }
        let across = across2.sqrt() * lift::<T>(self.side);
        let to_elbow = [along * e[0] - across * e[1], along * e[1] + across * e[0]];
        Some([to_elbow, [e[0] - to_elbow[0], e[1] - to_elbow[1]]])
    }

    /// The rotation `θ₁` or `θ₂` (`which`, before its axis sign and turns) of the solved dyad
    /// `elbow` ([`Self::elbow`]), in (−π, π].
    fn rotation<T: Scalar>(frame: &DyadFrame<T>, elbow: &[[T; 2]; 2], which: usize) -> T {
        let (cross, dot) = Self::rotation_sides(frame, elbow, which);
        cross.atan2(dot)
    }

    /// [`Self::rotation`] in f64 with the kernels' arc tangent ([`super::arc_tangent::atan2`]:
    /// the same angle to a few ulp, without libm's rounding-mode switches).
    #[inline]
    fn rotation_f64(frame: &DyadFrame<f64>, elbow: &[[f64; 2]; 2], which: usize) -> f64 {
        let (cross, dot) = Self::rotation_sides(frame, elbow, which);
        arc_tangent::atan2(cross, dot)
    }

    /// The cross and dot products of the link's direction at a zero rotation with where the
    /// solution puts it: the rotation is their arc tangent.
    fn rotation_sides<T: Scalar>(
        frame: &DyadFrame<T>,
        elbow: &[[T; 2]; 2],
        which: usize,
    ) -> (T, T) {
        let (reference, link) = if which == 0 {
            (frame.inner_direction, elbow[0])
        } else {
            let [c, s] = frame.outer_turn;
            let b = elbow[0];
            ([c * b[0] - s * b[1], s * b[0] + c * b[1]], elbow[1])
        };
        let cross = reference[0] * link[1] - reference[1] * link[0];
        let dot = reference[0] * link[0] + reference[1] * link[1];
        (cross, dot)
    }

    /// The joints reaching `target` (world `(x, y)`; the leg's attachment at the pose), in the
    /// 2π window centred on `seed` (as Newton's solution from `seed` is), with the closure
    /// Jacobian's inverse and normalised determinant at them: the [`Solution`] Newton's method
    /// converges to, to round-off. `None` where the generic solve must decide: the circles do
    /// not meet, or the pose is at the generic solve's reach-limit threshold (a serial
    /// singularity).
    pub fn solve(
        &self,
        frame: &DyadFrame<f64>,
        target: &Vector3<f64>,
        seed: &Joints,
    ) -> Option<Solution> {
        let elbow = self.elbow(frame, [target[0], target[1]])?;
        let mut q = [0.0; 3];
        for (k, value) in q.iter_mut().take(2).enumerate() {
            let rotation = self.signs[k] * Self::rotation_f64(frame, &elbow, k);
            *value = on_turn_of(rotation, seed[k]);
        }
        // The closure Jacobian's columns sₖ z × (tip − pivotₖ) at tip = target: the pivots
        // are the base and the elbow.
        let arms = [
            [elbow[0][0] + elbow[1][0], elbow[0][1] + elbow[1][1]],
            elbow[1],
        ];
        let mut jacobian = Matrix3::zeros();
        for (k, arm) in arms.iter().enumerate() {
            jacobian[(0, k)] = -self.signs[k] * arm[1];
            jacobian[(1, k)] = self.signs[k] * arm[0];
        }
        let determinant = normalised_determinant(&jacobian, 2);
        // At the generic solve's own threshold Newton reports a reach limit, or a pose beyond
        // it: the generic solve decides (and names) those; above it the closed form is
        // accurate (the elbow's distance from the line is at least 1e-4 of the links).
        let near_limit = determinant.abs() <= SINGULAR_DETERMINANT;
        let on_branch = determinant.is_sign_positive() == self.home_positive;
        if near_limit || !on_branch || !q.iter().all(|v| v.is_finite()) {
            return None;
        }
        Solution::closed(q, &jacobian, 2, determinant)
    }

    /// The actuated joint's rotation reaching `target` on the working mode (in (−π, π] times
    /// its axis sign, before any whole turn) and the actuated row of the closure Jacobian's
    /// inverse there (its third entry zero): what a forward solve needs from a leg, with one
    /// arc tangent instead of [`Self::solve`]'s two. `None` where [`Self::solve`] leaves the
    /// pose to the generic solve (the circles do not meet, a reach limit, the other mode).
    pub fn actuated_row(
        &self,
        frame: &DyadFrame<f64>,
        target: &Vector3<f64>,
    ) -> Option<(f64, [f64; 3])> {
        let elbow = self.elbow(frame, [target[0], target[1]])?;
        let k = self.actuated;
        let rotation = self.signs[k] * Self::rotation_f64(frame, &elbow, k);
        // The closure Jacobian as in `solve`: columns sₖ z × (tip − pivotₖ).
        let arms = [
            [elbow[0][0] + elbow[1][0], elbow[0][1] + elbow[1][1]],
            elbow[1],
        ];
        let columns = [0, 1].map(|c| [-self.signs[c] * arms[c][1], self.signs[c] * arms[c][0]]);
        let determinant = columns[0][0] * columns[1][1] - columns[1][0] * columns[0][1];
        // |normalised determinant| ≤ the threshold, squared (no square roots): the same test
        // but within round-off of the threshold itself.
        let squared = |c: [f64; 2]| (c[0] * c[0] + c[1] * c[1]).max(f64::MIN_POSITIVE);
        let scale = squared(columns[0]) * squared(columns[1]);
        let near_limit =
            determinant * determinant <= SINGULAR_DETERMINANT * SINGULAR_DETERMINANT * scale;
        if near_limit
            || determinant.is_nan()
            || determinant.is_sign_positive() != self.home_positive
        {
            return None;
        }
        // Row k of the 2 × 2 inverse: the other column turned, over the determinant.
        let other = columns[1 - k];
        let sign = if k == 0 { 1.0 } else { -1.0 };
        let row = [
            sign * other[1] / determinant,
            -sign * other[0] / determinant,
            0.0,
        ];
        (rotation.is_finite() && row.iter().all(|v| v.is_finite())).then_some((rotation, row))
    }

    /// The actuated joint's value reaching `target` (in `T`: exact derivatives with respect
    /// to whatever the frame and the target carry), on the turn of the f64 `solution` (the
    /// same pose solved): its value part is the solution's joint to round-off. `None` if the
    /// circles do not meet in `T`'s value part.
    pub fn actuated<T: Scalar>(
        &self,
        frame: &DyadFrame<T>,
        target: &Vector3<T>,
        solution: &Solution,
    ) -> Option<T> {
        let elbow = self.elbow(frame, [target[0], target[1]])?;
        let k = self.actuated;
        let value = Self::rotation(frame, &elbow, k) * lift::<T>(self.signs[k]);
        let turns = ((solution.q[k] - value.re()) / TAU).round();
        Some(value + lift::<T>(turns * TAU))
    }
}

impl Dyad {
    /// Where the actuated joint's value `actuated` puts the elbow when the actuated revolute is
    /// the first one (at the base): the elbow's world `(x, y)` and the length `|v|` from it to
    /// the leg's tip, the radius of the circle the tip is on. `None` when the actuated joint is
    /// the elbow's own (the elbow then depends on the passive joint).
    pub(crate) fn elbow_circle(
        &self,
        frame: &DyadFrame<f64>,
        actuated: f64,
    ) -> Option<([f64; 2], f64)> {
        if self.actuated != 0 {
            return None;
        }
        // The rotation from the inner direction is the joint value times its axis' sign.
        let (s, c) = (self.signs[0] * actuated).sin_cos();
        let [i0, i1] = frame.inner_direction;
        let length = frame.squared_lengths[0].sqrt();
        let elbow = [
            frame.base[0] + length * (c * i0 - s * i1),
            frame.base[1] + length * (s * i0 + c * i1),
        ];
        Some((elbow, frame.squared_lengths[1].sqrt()))
    }
}

impl<T: Scalar> DyadFrame<T> {
    /// The frame's eight numbers, the inputs [`Dyad::actuated_partials`] differentiates by:
    /// the base point `A` (x, y), `|u|²`, `|v|²`, the inner direction (cos, sin) and the outer
    /// turn (cos, sin).
    pub fn scalars(&self) -> [T; 8] {
        let [b0, b1] = self.base;
        let [l2, o2] = self.squared_lengths;
        let [i0, i1] = self.inner_direction;
        let [c, s] = self.outer_turn;
        [b0, b1, l2, o2, i0, i1, c, s]
    }
}

impl Dyad {
    /// [`Self::actuated`] in f64 from the frame's numbers `frame` ([`DyadFrame::scalars`]) and
    /// the target's world `(x, y)`, with its partial derivatives with respect to those ten
    /// inputs (the eight of the frame, then the target's two) by the chain rule written out
    /// backwards through the circle intersection and the arc tangent: the value of
    /// [`Self::solve`]'s actuated joint (the same operations and arc tangent) and, to round-off,
    /// [`Self::actuated`]'s value and derivatives, without dual numbers. `None` where the
    /// circles do not meet.
    pub fn actuated_partials(
        &self,
        frame: &[f64; 8],
        target: [f64; 2],
        solution: &Solution,
    ) -> Option<(f64, [f64; 10])> {
        let [b0, b1, l2, o2, i0, i1, c, s] = *frame;
        // Forward, as `elbow` and `rotation`.
        let e = [target[0] - b0, target[1] - b1];
        let d2 = e[0] * e[0] + e[1] * e[1];
        let along = (l2 - o2 + d2) / (2.0 * d2);
        let across2 = l2 / d2 - along * along;
        if across2.is_nan() || across2 <= 0.0 {
            return None;
        }
        let root = across2.sqrt();
        let across = root * self.side;
        let b = [along * e[0] - across * e[1], along * e[1] + across * e[0]];
        let k = self.actuated;
        let (r, l) = if k == 0 {
            ([i0, i1], b)
        } else {
            (
                [c * b[0] - s * b[1], s * b[0] + c * b[1]],
                [e[0] - b[0], e[1] - b[1]],
            )
        };
        let cross = r[0] * l[1] - r[1] * l[0];
        let dot = r[0] * l[0] + r[1] * l[1];
        let value = arc_tangent::atan2(cross, dot) * self.signs[k];
        let turns = ((solution.q[k] - value) / TAU).round();
        // Backwards: ∂θ/∂(cross, dot), then through r and l to the elbow and the inputs.
        let n2 = cross * cross + dot * dot;
        let (g_cross, g_dot) = (dot / n2, -cross / n2);
        let g_r = [
            g_cross * l[1] + g_dot * l[0],
            -g_cross * l[0] + g_dot * l[1],
        ];
        let g_l = [
            -g_cross * r[1] + g_dot * r[0],
            g_cross * r[0] + g_dot * r[1],
        ];
        let mut p = [0.0; 10];
        let mut g_e = [0.0; 2];
        let g_b = if k == 0 {
            p[4] = g_r[0];
            p[5] = g_r[1];
            g_l
        } else {
            p[6] = g_r[0] * b[0] + g_r[1] * b[1];
            p[7] = -g_r[0] * b[1] + g_r[1] * b[0];
            g_e = g_l;
            [
                g_r[0] * c + g_r[1] * s - g_l[0],
                -g_r[0] * s + g_r[1] * c - g_l[1],
            ]
        };
        let mut g_along = g_b[0] * e[0] + g_b[1] * e[1];
        let g_across = -g_b[0] * e[1] + g_b[1] * e[0];
        g_e[0] += g_b[0] * along + g_b[1] * across;
        g_e[1] += -g_b[0] * across + g_b[1] * along;
        let g_across2 = g_across * self.side / (2.0 * root);
        let mut g_l2 = g_across2 / d2;
        let mut g_d2 = -g_across2 * l2 / (d2 * d2);
        g_along += -2.0 * along * g_across2;
        g_l2 += g_along / (2.0 * d2);
        let g_o2 = -g_along / (2.0 * d2);
        g_d2 += g_along * (1.0 - 2.0 * along) / (2.0 * d2);
        g_e[0] += 2.0 * e[0] * g_d2;
        g_e[1] += 2.0 * e[1] * g_d2;
        (p[0], p[1], p[2], p[3]) = (-g_e[0], -g_e[1], g_l2, g_o2);
        (p[8], p[9]) = (g_e[0], g_e[1]);
        let sign = self.signs[k];
        Some((value + turns * TAU, p.map(|v| v * sign)))
    }
}

/// `w` turned by `angle`.
fn rotated<T: Scalar>(angle: T, w: [T; 2]) -> [T; 2] {
    let (s, c) = angle.sin_cos();
    [c * w[0] - s * w[1], s * w[0] + c * w[1]]
}

/// `rotation` (in (−π, π]) moved by whole turns into the 2π window centred on `seed`: the
/// turn Newton's method from `seed` converges to.
pub(crate) fn on_turn_of(rotation: f64, seed: f64) -> f64 {
    let difference = rotation - seed;
    // No turn when the difference is well inside (−π, π) (no call to `round`).
    let turns = if difference.abs() < 3.0 {
        0.0
    } else {
        ((difference - wrap_angle(difference)) / TAU).round()
    };
    if turns != 0.0 {
        rotation - turns * TAU
    } else {
        rotation
    }
}
