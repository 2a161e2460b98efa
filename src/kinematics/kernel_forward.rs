//! Forward kinematics through the legs' closed-form kernels: for a mechanism whose every leg
//! has one ([`LegKernel::recognise`]) and as many measured pose coordinates as legs, Newton's
//! method on the pose alone, each leg's actuated joint from its closed form and its pose
//! gradient from the kernel's closure Jacobian (implicit function theorem). The passive joints
//! are eliminated: a 2 × 2 solve per iteration for a planar two-leg mechanism instead of the
//! stacked closures over every joint. Recognised from the legs' chains and the measured
//! coordinates, never from a mechanism's name.
//!
//! It solves the same equations as the stacked Newton ([`super::platform`]): every leg's
//! actuated joint at `gain·reading + offset`, every passive joint on its leg's working mode.
//! The assembly mode is read from the reduced Jacobian's determinant: with every leg on its
//! home working mode (the kernel's own check) the stacked Jacobian's determinant is this one's
//! times the legs' closure determinants (of fixed signs) and a constant sign, so comparing it
//! with its sign at home is the stacked check. Whatever the kernel cannot settle cleanly (a
//! leg out of reach, a large step, a near-singular or unconverged pose) is left to the stacked
//! Newton: `None`.

use nalgebra::Vector3;

use super::chain::{attachment_on, platform_transform_f64};
use super::circle_intersection::nearest_intersection;
use super::inverse::{joints, wrap_angle, Joints};
use super::kernel::PreparedKernel;
#[cfg(test)]
use super::kernel::{prepare_each, LegKernel};
use super::newton_stop::beyond_round_off;
use super::pose_derivative::{pose_derivatives, PoseDerivative};
use super::small_solve::solve_small;
use super::sphere_intersection;
use crate::model::joint::JointKind;
use crate::model::leg::LegGeometry;
use crate::model::Mechanism;

/// What a Newton solve of the pose starts from: the readings, the pose (the start, then the
/// solution), where the legs' joints are handed back, and the mechanism's size with whether the
/// configuration is handed back exactly ([`KernelForward::newton`]).
type NewtonAt<'a> = (
    &'a [f64],
    &'a mut [f64; 6],
    Option<&'a mut [Joints]>,
    (f64, bool),
);

/// Newton iterations before the pose is left to the stacked solve.
const MAX_ITERATIONS: usize = 30;

/// A reduced Jacobian whose column-normalised determinant is below this in magnitude is left
/// to the stacked solve (which decides a parallel singularity itself).
const NEAR_SINGULAR: f64 = 1e-6;

/// Largest step accepted: angles within this many radians, lengths within this fraction of the
/// mechanism's size; a larger step is left to the stacked solve's limited steps.
const MAX_STEP: f64 = 0.5;

/// A step of at most this (in the mechanism's size, or radians) may have landed …
const LANDING: f64 = 1e-6;

/// … when the next step it predicts is at most this: round-off in the pose.
const LANDED: f64 = 1e-16;

/// One leg as the reduced forward kinematics sees it.
#[derive(Debug, Clone)]
struct KernelLeg {
    kernel: PreparedKernel<f64>,
    /// The platform attachment point (platform coordinates).
    attachment: [f64; 3],
    /// `gain` and `offset` of the actuator: the actuated joint is `gain·reading + offset`.
    actuator: (f64, f64),
    /// Index of the actuated joint among the moving joints, and whether it turns.
    actuated: (usize, bool),
    /// The home joints: the 2π window of every passive revolute is centred on them, as the
    /// stacked Newton wraps them.
    home: Joints,
}

/// Every leg's actuated joint and the actuated row of its closure inverse at one pose (what
/// [`KernelForward::newton`] evaluates first when it starts there), `None` for a leg the
/// kernel leaves to the stacked solve there. Evaluated once, it serves every Newton solve
/// started at that pose (e.g. one accuracy-map point commanded by several models).
#[derive(Debug, Clone, Copy)]
pub struct KernelRows {
    /// The pose they were evaluated at.
    pose: [f64; 6],
    rows: [Option<(f64, [f64; 3])>; 6],
}

impl KernelRows {
    /// Leg `leg`'s actuated joint and actuated row, if these rows were evaluated at exactly
    /// `pose` (its bits) and the leg's kernel reaches it there.
    pub(crate) fn leg_at(&self, pose: &[f64; 6], leg: usize) -> Option<(f64, [f64; 3])> {
        self.evaluated_at(pose)
            .then(|| self.rows.get(leg).copied().flatten())
            .flatten()
    }

    /// Whether these rows were evaluated at exactly `pose` (its bits).
    fn evaluated_at(&self, pose: &[f64; 6]) -> bool {
        (self.pose.iter().zip(pose)).all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

/// The reduced forward kinematics of a mechanism at one parameter vector.
#[derive(Debug, Clone)]
pub(crate) struct KernelForward {
    legs: Vec<KernelLeg>,
    /// The measured pose coordinates: the unknowns.
    measured: Vec<usize>,
    /// The platform transform's derivatives with respect to them when they are all positions
    /// (the same at every pose).
    derivatives: Option<[PoseDerivative; 6]>,
    /// With those constant derivatives, each leg's attachment point moved by each of them (the
    /// same at every pose and iteration): computed once.
    moved: Vec<[[f64; 3]; 6]>,
    /// Whether the solve starts from the closed form ([`Self::circle_start`]): two legs whose
    /// tips lie on circles once their actuators are set, the platform's `x` and `y` measured.
    circles: bool,
    /// Whether the solve starts from the closed form ([`Self::sphere_start`]): three legs whose
    /// tips lie on spheres once their actuators are set, the platform's `x`, `y` and `z`
    /// measured (it translates only).
    spheres: bool,
}

impl KernelForward {
    /// The reduced forward kinematics of `mechanism` at `geometries` (one per leg), if every
    /// leg's chain has a closed-form kernel (`kernels`, one per leg: [`LegKernel::recognise`]
    /// of it) and the measured coordinates are as many as the legs (at most six).
    #[cfg(test)]
    pub(crate) fn new(
        mechanism: &Mechanism,
        geometries: &[LegGeometry<f64>],
        kernels: &[Option<LegKernel>],
    ) -> Option<Self> {
        if geometries.len() < kernels.len() {
            return None;
        }
        Self::with_prepared(mechanism, geometries, &prepare_each(kernels, geometries))
    }

    /// As [`Self::new`], with every leg's kernel already prepared at its geometry (`prepared`,
    /// one per leg).
    pub(crate) fn with_prepared(
        mechanism: &Mechanism,
        geometries: &[LegGeometry<f64>],
        prepared: &[Option<PreparedKernel<f64>>],
    ) -> Option<Self> {
        let measured = mechanism.measured.clone();
        let legs = mechanism.legs.len();
        if measured.len() != legs || measured.len() > 6 || prepared.len() != legs {
            return None;
        }
        let legs = mechanism
            .legs
            .iter()
            .zip(geometries)
            .zip(prepared)
            .map(|((leg, geometry), kernel)| {
                let kernel = (*kernel)?;
                let revolute = leg.joints[leg.moving[leg.actuated]].kind == JointKind::Revolute;
                Some(KernelLeg {
                    kernel,
                    attachment: geometry.attachment,
                    actuator: (geometry.gain, geometry.offset),
                    actuated: (leg.actuated, revolute),
                    home: joints(&leg.home_joints),
                })
            })
            .collect::<Option<Vec<_>>>()?;
        let derivatives = measured
            .iter()
            .all(|&c| c < 3)
            .then(|| pose_derivatives(&[0.0; 6], &measured));
        let moved = match &derivatives {
            Some(constant) => legs
                .iter()
                .map(|leg| {
                    let point = Vector3::from(leg.attachment);
                    std::array::from_fn(|k| constant[k].of(&point).into())
                })
                .collect(),
            None => Vec::new(),
        };
        let circles = measured == [0, 1]
            && legs.len() == 2
            && legs.iter().all(|leg| leg.kernel.tip_circle(0.0).is_some());
        let spheres = measured == [0, 1, 2]
            && legs.len() == 3
            && legs.iter().all(|leg| leg.kernel.tip_sphere(0.0).is_some());
        Some(Self {
            legs,
            measured,
            derivatives,
            moved,
            circles,
            spheres,
        })
    }

    /// Whether [`Self::newton`] starts from the closed form (two circles' intersection) where
    /// it has one, rather than from the pose it is given.
    pub(crate) fn starts_in_closed_form(&self) -> bool {
        self.circles || self.spheres
    }

    /// The platform's `(x, y)` reaching `readings` in closed form, for two legs each actuated
    /// at its base elbow's joint: each leg's tip is on the circle about its elbow, the platform
    /// point on that circle moved by the attachment's offset (the platform's angles are not
    /// measured: fixed at `pose`'s). The intersection nearest `pose`, where it is clearly the
    /// nearer (Newton's method from `pose` would go there) and within a Newton step's limit of
    /// it; `None` otherwise.
    fn circle_start(&self, readings: &[f64], pose: &[f64; 6], size: f64) -> Option<[f64; 2]> {
        let (centres, radii) =
            self.tip_surfaces(readings, pose, |kernel, wanted| kernel.tip_circle(wanted))?;
        let reached = nearest_intersection(centres, radii, [pose[0], pose[1]])?;
        let moved = (reached[0] - pose[0]).hypot(reached[1] - pose[1]);
        (moved <= MAX_STEP * size).then_some(reached)
    }

    /// The platform's `(x, y, z)` reaching `readings` in closed form, for three carriage legs:
    /// each leg's tip is on the sphere about its universal joint, the platform point on that
    /// sphere moved by the attachment's offset (the platform's angles are not measured: fixed
    /// at `pose`'s). The intersection nearest `pose`, where it is clearly the nearer (Newton's
    /// method from `pose` would go there) and within a Newton step's limit of it; `None`
    /// otherwise.
    fn sphere_start(&self, readings: &[f64], pose: &[f64; 6], size: f64) -> Option<[f64; 3]> {
        let (centres, radii) =
            self.tip_surfaces(readings, pose, |kernel, wanted| kernel.tip_sphere(wanted))?;
        let near = [pose[0], pose[1], pose[2]];
        let reached = sphere_intersection::nearest_intersection(centres, radii, near)?;
        let moved = (0..3).map(|k| (reached[k] - near[k]).powi(2)).sum::<f64>();
        (moved.sqrt() <= MAX_STEP * size).then_some(reached)
    }

    /// The first `N` legs' tip surfaces once their actuators reach `readings` (a circle or a
    /// sphere, `surface` of the leg's kernel and its actuated joint's value: centre and
    /// radius), each centre moved by the leg's attachment offset from the platform point at
    /// `pose` (the platform's angles held at `pose`'s): the surfaces the platform point is on.
    /// `None` if a leg's kernel gives no surface.
    fn tip_surfaces<const N: usize>(
        &self,
        readings: &[f64],
        pose: &[f64; 6],
        surface: impl Fn(&PreparedKernel<f64>, f64) -> Option<([f64; N], f64)>,
    ) -> Option<([[f64; N]; N], [f64; N])> {
        let platform = platform_transform_f64(pose);
        let mut centres = [[0.0; N]; N];
        let mut radii = [0.0; N];
        for (l, leg) in self.legs.iter().enumerate().take(N) {
            let wanted = leg.actuator.0 * readings[l] + leg.actuator.1;
            let (centre, radius) = surface(&leg.kernel, wanted)?;
            let tip = attachment_on(&platform, &leg.attachment);
            centres[l] = std::array::from_fn(|k| centre[k] - (tip[k] - pose[k]));
            radii[l] = radius;
        }
        Some((centres, radii))
    }

    /// Every leg's actuated joint and actuated row at `pose` ([`KernelRows`]).
    pub(crate) fn rows_at(&self, pose: &[f64; 6]) -> KernelRows {
        let platform = platform_transform_f64(pose);
        let mut rows = [None; 6];
        for (row, leg) in rows.iter_mut().zip(&self.legs) {
            *row = leg
                .kernel
                .actuated_row(&attachment_on(&platform, &leg.attachment));
        }
        KernelRows { pose: *pose, rows }
    }

    /// Newton on the measured coordinates of `pose` (updated in place, the others kept) for
    /// `readings` (one per leg), every leg's joints written into `joints` when given (else
    /// only the actuated joints are solved: one arc tangent a leg); `size` is the mechanism's
    /// size (the step limit's length scale). Returns the column-normalised determinant of the
    /// reduced Jacobian at the solution (its sign is the assembly mode, see the module), or
    /// `None` where the stacked solve must decide; `pose` and `joints` are then partly moved
    /// and must not be used. `first`: the legs' rows at the start (the same numbers
    /// [`Self::rows_at`] gives there), used for the first iteration when they were evaluated
    /// at exactly `pose` and the joints are not asked for. `exact`: without the joints too,
    /// closed as when they are (no landing on the first step: a forward row's pose, whose
    /// derivatives are taken there).
    pub(crate) fn newton(
        &self,
        readings: &[f64],
        pose: &mut [f64; 6],
        joints: Option<&mut [Joints]>,
        (size, exact): (f64, bool),
        first: Option<&KernelRows>,
    ) -> Option<f64> {
        self.newton_rows(readings, pose, joints, (size, exact), (first, None))
    }

    /// [`Self::newton`], with the legs' rows of its last evaluation written into `last` (when
    /// given) if that was at the pose it returns (a step at round-off, not taken): what the
    /// pose's derivatives need of the legs there, without evaluating the kernels again. `last`
    /// is `None` otherwise (after a landing step the last evaluation is a round-off step away;
    /// without a solution).
    pub(crate) fn newton_rows(
        &self,
        readings: &[f64],
        pose: &mut [f64; 6],
        joints: Option<&mut [Joints]>,
        (size, exact): (f64, bool),
        (first, last): (Option<&KernelRows>, Option<&mut Option<KernelRows>>),
    ) -> Option<f64> {
        let at = (readings, pose, joints, (size, exact));
        let Some(slot) = last else {
            return self
                .newton_kept(at, (first, None))
                .map(|(determinant, _)| determinant);
        };
        // The rows are written where they are kept, as they are evaluated.
        let kept = slot.insert(KernelRows {
            pose: *at.1,
            rows: [None; 6],
        });
        match self.newton_kept(at, (first, Some(kept))) {
            Some((determinant, true)) => Some(determinant),
            solved => {
                *slot = None;
                solved.map(|(determinant, _)| determinant)
            }
        }
    }

    /// [`Self::newton_rows`] writing each evaluation's rows into `kept` (when given), and
    /// whether they are at the pose returned (else they are not to be read).
    fn newton_kept(
        &self,
        (readings, pose, joints, (size, exact)): NewtonAt<'_>,
        (first, mut kept): (Option<&KernelRows>, Option<&mut KernelRows>),
    ) -> Option<(f64, bool)> {
        let m = self.measured.len();
        if readings.len() != m || joints.as_ref().is_some_and(|j| j.len() != m) {
            return None;
        }
        // Newton from a closed-form start lands at once: the kernels' rows at the reached pose
        // confirm it (and give the assembly mode), as at the end of the iterations.
        if self.circles {
            if let Some(reached) = self.circle_start(readings, pose, size) {
                (pose[0], pose[1]) = (reached[0], reached[1]);
            }
        } else if self.spheres {
            if let Some(reached) = self.sphere_start(readings, pose, size) {
                pose[..3].copy_from_slice(&reached);
            }
        }
        let same_start = |rows: &&KernelRows| joints.is_none() && rows.evaluated_at(pose);
        let mut first = first.filter(same_start);
        let mut previous = f64::INFINITY;
        // The legs' attachment points at the last evaluation: where the joints handed back
        // are solved (a round-off step from the pose returned).
        let mut targets = [Vector3::zeros(); 6];
        for _ in 0..MAX_ITERATIONS {
            let platform = platform_transform_f64(pose);
            // The platform's derivatives: constant unless an angle is measured.
            let varying;
            let derivatives = match &self.derivatives {
                Some(constant) => constant,
                None => {
                    varying = pose_derivatives(pose, &self.measured);
                    &varying
                }
            };
            let mut jacobian = [[0.0; 6]; 6];
            let mut residual = [0.0; 6];
            for (l, leg) in self.legs.iter().enumerate() {
                let target = attachment_on(&platform, &leg.attachment);
                let (_, revolute) = leg.actuated;
                let wanted = leg.actuator.0 * readings[l] + leg.actuator.1;
                let (actuated, row) = match first {
                    Some(rows) => rows.rows[l]?,
                    None => leg.kernel.actuated_row(&target)?,
                };
                targets[l] = target;
                if let Some(kept) = kept.as_deref_mut() {
                    kept.rows[l] = Some((actuated, row));
                }
                let difference = actuated - wanted;
                residual[l] = if revolute {
                    wrap_angle(difference)
                } else {
                    difference
                };
                for (k, derivative) in derivatives.iter().take(m).enumerate() {
                    // A position moves every point by its unit translation exactly.
                    let c = self.measured[k];
                    let moved: [f64; 3] = match self.moved.get(l) {
                        Some(moved) => moved[k],
                        None if c < 3 => std::array::from_fn(|d| if d == c { 1.0 } else { 0.0 }),
                        None => derivative.of(&Vector3::from(leg.attachment)).into(),
                    };
                    jacobian[l][k] = (0..3).map(|d| row[d] * moved[d]).sum();
                }
            }
            first = None;
            let (step, determinant) = solve_small(jacobian, residual, m)?;
            // The step in units of the mechanism's size (lengths) and radians (angles).
            let mut unknowns = [0.0; 6];
            let mut largest = 0.0f64;
            for (k, &c) in self.measured.iter().enumerate() {
                unknowns[k] = pose[c];
                let unit = if c < 3 { size } else { 1.0 };
                largest = largest.max(step[k].abs() / unit);
            }
            if largest > MAX_STEP {
                return None;
            }
            let accepted = (determinant.abs() > NEAR_SINGULAR).then_some(determinant);
            if !beyond_round_off(&unknowns[..m], &step[..m]) {
                let determinant = self.with_joints(accepted?, readings, &targets, joints)?;
                if let Some(kept) = kept {
                    kept.pose = *pose;
                }
                return Some((determinant, true));
            }
            for (k, &c) in self.measured.iter().enumerate() {
                pose[c] -= step[k];
            }
            // Converging quadratically, the next step would be about (this / previous²) ×
            // this²: at round-off, this step has landed (the joints and the determinant are
            // the last evaluation's, a round-off step away). The first step has no previous
            // one to predict from: it may land only in the lean evaluation (an accuracy map's,
            // started at the pose itself); a configuration handed back (a forward row's, whose
            // derivatives are taken there) is closed until a step is at round-off.
            let next = largest * largest * (largest / (previous * previous));
            let predicted = previous.is_finite() || (joints.is_none() && !exact);
            if largest <= LANDING && next <= LANDED && predicted {
                let determinant = self.with_joints(accepted?, readings, &targets, joints)?;
                return Some((determinant, false));
            }
            previous = largest;
        }
        None
    }
}

impl KernelForward {
    /// `determinant`, with every leg's joints solved at its attachment point `targets[l]`
    /// written into `joints` when asked for (the actuated joint at its reading's value);
    /// `None` if a leg's kernel leaves its target to the generic solve.
    fn with_joints(
        &self,
        determinant: f64,
        readings: &[f64],
        targets: &[Vector3<f64>; 6],
        joints: Option<&mut [Joints]>,
    ) -> Option<f64> {
        if let Some(joints) = joints {
            for (l, leg) in self.legs.iter().enumerate() {
                let solution = leg.kernel.solve(&targets[l], &leg.home)?;
                joints[l] = solution.q;
                joints[l][leg.actuated.0] = leg.actuator.0 * readings[l] + leg.actuator.1;
            }
        }
        Some(determinant)
    }
}

#[cfg(test)]
mod tests;
