//! Passive revolutes about axes through one point turning a link onto a wanted direction: the
//! passive joints of the prismatic legs' kernels ([`super::distance_leg`],
//! [`super::carriage_leg`]). One revolute about `±z` in the plane (an angle between two
//! directions), two in space (a universal joint: Paden–Kahan's second subproblem, the working
//! mode picking one of its two solutions); and what the kernels' recognition and preparation
//! share: which joints' origins must stay still, and the chain's origins composed.

use nalgebra::{Matrix3, Vector3};

use super::arc_tangent;
use super::chain::{origin_transform, Transform};
use crate::model::leg::{LegGeometry, LegModel};
use crate::model::params::ParamTarget;
use crate::scalar::Scalar;

/// Below this `1 − (w₁·w₂)²` the two revolutes' axes are taken as parallel: no universal joint.
const PARALLEL_AXES: f64 = 1e-12;

/// Where the revolutes are and what they turn, at one parameter vector (f64), in the world
/// frame's terms: the link's world direction is `frame · R(w₁, θ₁) · R(w₂, θ₂) · pointer`.
#[derive(Debug, Clone, Copy)]
pub struct Pointing {
    /// The world rotation of the first revolute's joint frame.
    frame: Matrix3<f64>,
    /// The first revolute's unit axis (in its joint frame).
    first: Vector3<f64>,
    /// The second revolute's unit axis at `θ₁ = 0` (in the first's joint frame); `None`: one
    /// revolute (in the plane).
    second: Option<Vector3<f64>>,
    /// The link's unit direction at zero angles (in the first's joint frame).
    pointer: Vector3<f64>,
}

/// The revolutes' angles turning the link onto a direction, and their world axes there.
#[derive(Debug, Clone, Copy)]
pub struct Pointed {
    /// `θ₁` and `θ₂` (the second zero for one revolute), in (−π, π].
    pub angles: [f64; 2],
    /// The revolutes' world axes at the solution.
    pub axes: [Vector3<f64>; 2],
}

impl Pointing {
    /// The revolutes of rotation `frame` (world, of the first's joint frame), axes `first` and
    /// `second` (see the fields), turning the link direction `pointer` (any length).
    pub fn new(
        frame: Matrix3<f64>,
        first: Vector3<f64>,
        second: Option<Vector3<f64>>,
        pointer: Vector3<f64>,
    ) -> Self {
        Self {
            frame,
            first,
            second,
            pointer: pointer / pointer.norm(),
        }
    }

    /// The angles turning the link onto the world unit `direction`, with two revolutes on the
    /// side `side` (±1: the sign of the component of the first axis' turned cone point along
    /// `w₁ × w₂`, which the working mode fixes); `None` if no angle reaches it (a direction off
    /// the second revolute's cone, parallel axes) or the solution is degenerate.
    pub fn solve(&self, direction: &Vector3<f64>, side: f64) -> Option<Pointed> {
        let wanted = self.frame.tr_mul(direction);
        let w1 = self.first;
        let world_first = self.frame * w1;
        let Some(w2) = self.second else {
            let (y, x) = turn_sides(&w1, &self.pointer, &wanted);
            let angle = arc_tangent::atan2(y, x);
            return angle.is_finite().then_some(Pointed {
                angles: [angle, 0.0],
                axes: [world_first, Vector3::zeros()],
            });
        };
        let Cone {
            k,
            alpha,
            beta,
            across2,
            ..
        } = self.cone(&w2, &wanted)?;
        let normal = w1.cross(&w2);
        let c = w1 * alpha + w2 * beta + normal * (side * across2.sqrt());
        let (y2, x2) = turn_sides(&w2, &self.pointer, &c);
        let (y1, x1) = turn_sides(&w1, &c, &wanted);
        let angles = [arc_tangent::atan2(y1, x1), arc_tangent::atan2(y2, x2)];
        // The second axis turned by θ₁ about the first (Rodrigues, from the arc tangent's
        // sides: no sine or cosine call).
        let h = (x1 * x1 + y1 * y1).sqrt();
        let (cos, sin) = (x1 / h, y1 / h);
        let turned = w2 * cos + normal * sin + w1 * (k * (1.0 - cos));
        let pointed = Pointed {
            angles,
            axes: [world_first, self.frame * turned],
        };
        (angles.iter().all(|a| a.is_finite()) && h > 0.0).then_some(pointed)
    }

    /// How far the revolutes are from losing a direction of motion when the link points along
    /// the world unit `direction`: `|γ| |w₁ × w₂|² / (|w₁ × u| |w₂ × u|)` with two revolutes
    /// (the magnitude of the normalised determinant of the columns `ωₖ × u` and `u`, whichever
    /// side [`Self::solve`] takes: a universal joint's singularity at zero), 1 with one
    /// revolute in the plane (its column is across the link). The same numbers as
    /// [`Self::solve`] without its angles; `None` where it finds none.
    pub fn conditioning(&self, direction: &Vector3<f64>) -> Option<f64> {
        let Some(w2) = self.second else {
            return Some(1.0);
        };
        let wanted = self.frame.tr_mul(direction);
        let Cone {
            n, p1, p2, across2, ..
        } = self.cone(&w2, &wanted)?;
        // |ωₖ × u|² = 1 − (ωₖ · u)²: ω₁ · u = w₁ · wanted, ω₂ · u = w₂ · c = w₂ · pointer.
        let sines = (1.0 - p1 * p1) * (1.0 - p2 * p2);
        if sines.is_nan() || sines <= 0.0 {
            return None;
        }
        Some((across2 / sines).sqrt() * n)
    }

    /// The direction `c` the second revolute (axis `w2`) turns the pointer to, for the link to
    /// point along `wanted` (in the first's joint frame): on its cone about `w₂`
    /// (`w₂·c = w₂·pointer`) and on the first's cone through `wanted` (`w₁·c = w₁·wanted`),
    /// `c = α w₁ + β w₂ ± √(across2) w₁ × w₂`. `None` for parallel axes or cones that do not
    /// meet.
    fn cone(&self, w2: &Vector3<f64>, wanted: &Vector3<f64>) -> Option<Cone> {
        let w1 = self.first;
        let k = w1.dot(w2);
        let n = 1.0 - k * k;
        if n.is_nan() || n <= PARALLEL_AXES {
            return None;
        }
        let (p1, p2) = (w1.dot(wanted), w2.dot(&self.pointer));
        let alpha = (p1 - k * p2) / n;
        let beta = (p2 - k * p1) / n;
        let across2 = (1.0 - alpha * alpha - beta * beta - 2.0 * alpha * beta * k) / n;
        if across2.is_nan() || across2 <= 0.0 {
            return None;
        }
        Some(Cone {
            k,
            n,
            p1,
            p2,
            alpha,
            beta,
            across2,
        })
    }
}

/// What [`Pointing::cone`] finds: `k = w₁·w₂`, `n = 1 − k²`, `p₁ = w₁·wanted`,
/// `p₂ = w₂·pointer`, and `c`'s coefficients `α`, `β` and squared `across2`.
#[derive(Debug, Clone, Copy)]
struct Cone {
    k: f64,
    n: f64,
    p1: f64,
    p2: f64,
    alpha: f64,
    beta: f64,
    across2: f64,
}

/// The sine and cosine sides (unnormalised) of the angle turning `from` onto `to` about the
/// unit `axis`: `(axis · (from × to), from⊥ · to⊥)`, ⊥ the parts across the axis.
fn turn_sides(axis: &Vector3<f64>, from: &Vector3<f64>, to: &Vector3<f64>) -> (f64, f64) {
    let y = axis.dot(&from.cross(to));
    let x = from.dot(to) - axis.dot(from) * axis.dot(to);
    (y, x)
}

/// Whether chain joint `j`'s origin components `components` are zero and no parameter moves
/// them.
pub fn still(leg: &LegModel, j: usize, components: std::ops::Range<usize>) -> bool {
    let zero = components
        .clone()
        .all(|c| leg.joints[j].origin[c].to_bits() == 0.0f64.to_bits());
    let moved = leg.params.iter().any(|p| {
        matches!(p.target, ParamTarget::JointOrigin { joint, component }
            if joint == j && components.contains(&component))
    });
    zero && !moved
}

/// Whether chain joint `j`'s origin translation lies on the line along the unit `axis` (its
/// cross product with the axis zero to round-off: a few ulp of its length, as a direction
/// written in decimals allows), for every value of the parameters on it: a parameter may move
/// only the component along a coordinate axis `axis` is.
pub fn on_line(leg: &LegModel, j: usize, axis: &Vector3<f64>) -> bool {
    let t = Vector3::new(
        leg.joints[j].origin[0],
        leg.joints[j].origin[1],
        leg.joints[j].origin[2],
    );
    let cross = t.cross(axis);
    let along = cross.norm() <= 4.0 * f64::EPSILON * t.norm();
    let movable = leg.params.iter().all(|p| match p.target {
        ParamTarget::JointOrigin { joint, component } if joint == j && component < 3 => {
            (0..3).all(|c| c == component || axis[c] == 0.0)
        }
        _ => true,
    });
    along && movable
}

/// The composed origin transforms of chain joints `joints` (moving joints at zero).
pub fn composed<T: Scalar>(
    geometry: &LegGeometry<T>,
    joints: std::ops::Range<usize>,
) -> Transform<T> {
    let mut transform = Transform::<T>::identity();
    for j in joints {
        let origin = &geometry.origins[j];
        // An origin that does not turn (its three angles +0, differentiated by nothing) only
        // moves the frame along its axes: the translation of the product, without forming an
        // identity rotation and multiplying by it.
        let turns = origin[3..]
            .iter()
            .any(|angle| angle.re().to_bits() != 0 || !angle.is_constant());
        if turns {
            transform *= origin_transform(origin);
        } else {
            let shift = transform.rotation * Vector3::new(origin[0], origin[1], origin[2]);
            transform.translation.vector += shift;
        }
    }
    transform
}

/// The f64 value of a rotation in `T`.
pub fn rotation_value<T: Scalar>(transform: &Transform<T>) -> Matrix3<f64> {
    transform.rotation.matrix().map(|v| v.re())
}

/// The f64 value of a vector in `T`.
pub fn vector_value<T: Scalar>(v: &Vector3<T>) -> Vector3<f64> {
    v.map(|x| x.re())
}

#[cfg(test)]
mod tests {
    use num_dual::DualSVec64;

    use super::*;
    use crate::scalar::lift;

    /// The chain's origins multiplied out in full, every origin's rotation formed.
    fn multiplied<T: Scalar>(geometry: &LegGeometry<T>) -> Transform<T> {
        let mut transform = Transform::<T>::identity();
        for origin in &geometry.origins {
            transform *= origin_transform(origin);
        }
        transform
    }

    /// Origins that do not turn (angles +0, with no derivative) are composed as the full
    /// product composes them, bit for bit, in f64 and in dual numbers; an angle of 0 that is
    /// differentiated, or of −0, still turns the frame (its derivative) through the full product.
    #[test]
    fn origins_without_a_turn_compose_as_the_full_product() {
        let origins = [
            [0.1, -0.2, 0.3, 0.0, 0.0, 0.0],
            [0.0, 0.175, 0.0, 0.0, 0.0, -1.2],
            [0.3, 0.0, 0.0, 0.0, 0.0, 0.0],
            [-0.05, 0.02, 0.01, 0.2, -0.1, 0.3],
            [0.0, 0.0, 0.0, -0.0, 0.0, 0.0],
            [0.01, 0.0, -0.02, 0.0, 0.0, 0.0],
        ];
        let f64_geometry = LegGeometry {
            origins: origins.to_vec(),
            gain: 1.0,
            offset: 0.0,
            attachment: [0.0; 3],
        };
        let bits = |t: &Transform<f64>| -> Vec<u64> {
            let m = t.to_homogeneous();
            m.iter().map(|v| v.to_bits()).collect()
        };
        assert_eq!(
            bits(&composed(&f64_geometry, 0..origins.len())),
            bits(&multiplied(&f64_geometry))
        );
        // In duals: lane 0 on the first origin's x, lane 1 on the third origin's roll (0, but
        // differentiated: it turns), lane 2 on the second origin's yaw.
        type D = DualSVec64<3>;
        let mut dual: Vec<[D; 6]> = origins.iter().map(|o| o.map(lift::<D>)).collect();
        dual[0][0] = dual[0][0].derivative(0);
        dual[2][3] = dual[2][3].derivative(1);
        dual[1][5] = dual[1][5].derivative(2);
        let dual_geometry = LegGeometry {
            origins: dual,
            gain: lift::<D>(1.0),
            offset: lift::<D>(0.0),
            attachment: [lift::<D>(0.0); 3],
        };
        let (fast, full) = (
            composed(&dual_geometry, 0..origins.len()).to_homogeneous(),
            multiplied(&dual_geometry).to_homogeneous(),
        );
        for (a, b) in fast.iter().zip(full.iter()) {
            assert_eq!(a.re.to_bits(), b.re.to_bits());
            let (da, db) = (
                a.eps.unwrap_generic(nalgebra::Const::<3>, nalgebra::U1),
                b.eps.unwrap_generic(nalgebra::Const::<3>, nalgebra::U1),
            );
            for (x, y) in da.iter().zip(db.iter()) {
                assert_eq!(x.to_bits(), y.to_bits(), "{a} against {b}");
            }
        }
        // The differentiated roll turns the rod: its lane is not zero.
        assert!(full
            .iter()
            .any(|v| v.eps.unwrap_generic(nalgebra::Const::<3>, nalgebra::U1)[1] != 0.0));
    }
}
