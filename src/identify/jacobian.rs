//! The identification Jacobian of a leg, by dual numbers through the implicit function theorem.
//!
//! One forward pass in num-dual's static-size vector duals (`DualSVec64<N>`), every identified
//! parameter seeded on its own lane, through one Newton step from the f64 solution
//! ([`reading_at_tip`]) gives the reading and its exact gradient `∂ψ/∂φ` at once. The Newton
//! iterations themselves are never differentiated. Up to [`LANES`] parameters go in one pass;
//! more are split into passes of at most [`LANES`] (the kinematics' scalars are `Copy`, which
//! the heap-backed dynamic duals are not).
//!
//! Everything that depends only on the parameter vector (the f64 geometry and its chain frames,
//! the seeded dual geometry and its [`TipChain`]) is built once in [`PreparedLeg`] and reused at
//! every pose, so evaluating a pose allocates nothing. The dual pass accumulates the tip
//! position backwards along the chain (matrix–vector products), with the joints' motions, the
//! platform's transform and every origin rotation that no seeded parameter moves as f64
//! constants: most of its products are f64 × dual, not dual × dual.

use std::sync::{Arc, OnceLock};

use nalgebra::{Const, U1};
use num_dual::{DualSVec64, DualStruct};

use crate::error::KinematicsError;
use crate::kinematics::chain::{
    attachment_on, attachment_on_constant, attachment_world, platform_transform, LazyChainFrames,
    TipChain, Transform,
};
use crate::kinematics::inverse::{
    joints, reading_at_tip, reading_value, Joints, LegSolution, Solution,
};
use crate::kinematics::kernel::{solve_warm_through, LegKernel, PreparedKernel};
use crate::model::leg::{LegGeometry, LegModel};
use crate::model::params::ParamTarget;

mod actuated;

/// Most parameters carried by one dual pass.
pub const LANES: usize = 8;

/// A leg ready to be evaluated at many poses for one parameter vector.
#[derive(Debug, Clone)]
pub struct PreparedLeg<'a> {
    leg: &'a LegModel,
    geometry: LegGeometry<f64>,
    frames: LazyChainFrames,
    /// The leg's closed-form kernel at the parameters, if its chain has one.
    kernel: Option<PreparedKernel<f64>>,
    passes: Vec<Arc<dyn GradientPass>>,
    columns: usize,
}

/// One dual pass over some of the prepared columns.
trait GradientPass: std::fmt::Debug + Send + Sync {
    /// Writes the derivatives of the reading with respect to its columns into their places in
    /// `gradient`, and returns the reading.
    fn evaluate(
        &self,
        leg: &LegModel,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> f64;

    /// As [`Self::evaluate`], from the kernel's f64 partials alone (`solution`: only its
    /// joints' turn is read); `None` without a kernel or where its closed form fails.
    fn closed_form(
        &self,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> Option<f64>;
}

/// A pass seeding `N` consecutive prepared columns, from `first` on.
#[derive(Debug)]
struct DualPass<const N: usize> {
    first: usize,
    /// The chain for the generic derivative step, built on first use: a leg whose kernel
    /// gives every row's derivatives never needs it.
    chain: OnceLock<TipChain<DualSVec64<N>>>,
    /// Which joints' origin angles carry derivatives (for the chain).
    variable_angles: Vec<bool>,
    geometry: LegGeometry<DualSVec64<N>>,
    /// The leg's closed-form pattern, if it has one.
    pattern: Option<LegKernel>,
    /// The closed-form kernel in duals (the reading's derivatives from its closed form where
    /// its f64 partials fail), built on first use.
    kernel: OnceLock<Option<PreparedKernel<DualSVec64<N>>>>,
    /// The kernel's inputs split into values and lanes: the reading's derivatives by the
    /// chain rule on the kernel's f64 partials ([`LegKernel::actuated_partials`]).
    lanes: Option<KernelLanes<N>>,
}

/// A value and its `N` derivative lanes.
type Lanes<const N: usize> = (f64, [f64; N]);

/// What a kernel's reading depends on, each as a value and its derivatives with respect to the
/// pass's columns (fixed for the pass's parameter vector).
#[derive(Debug)]
struct KernelLanes<const N: usize> {
    /// The kernel frame's numbers ([`PreparedKernel::frame_scalars`]).
    frame: [Lanes<N>; 8],
    /// The platform attachment point (platform coordinates).
    attachment: [Lanes<N>; 3],
    gain: Lanes<N>,
    offset: Lanes<N>,
    /// Which of the frame's numbers, and whether the attachment, carry a non-zero lane: a
    /// term of zero lanes adds nothing to a sum that starts at `+0` (its partial finite).
    moving: ([bool; 8], bool),
}

/// `x`'s value and its `N` derivative lanes.
fn split<const N: usize>(x: &DualSVec64<N>) -> Lanes<N> {
    let lanes = x.eps.unwrap_generic(Const::<N>, U1);
    (x.re(), std::array::from_fn(|j| lanes[j]))
}

impl<const N: usize> KernelLanes<N> {
    /// The lanes of `kernel`'s frame at the dual `geometry`.
    fn new(kernel: &LegKernel, geometry: &LegGeometry<DualSVec64<N>>) -> Self {
        Self::with_frame(kernel.frame_scalars(geometry).map(|x| split(&x)), geometry)
    }

    /// The lanes of a pass that moves no joint origin: the kernel frame's numbers are
    /// `frame`'s (the f64 kernel's at the same parameters, the frame the f64 solve reads) and
    /// carry no derivative. They are the dual frame's values bit for bit where the frame does
    /// not divide (the carriage and distance legs), to round-off where it does (the dyad's:
    /// num-dual divides by multiplying with the reciprocal).
    fn fixed_frame(frame: &PreparedKernel<f64>, geometry: &LegGeometry<DualSVec64<N>>) -> Self {
        Self::with_frame(frame.frame_scalars().map(|x| (x, [0.0; N])), geometry)
    }

    fn with_frame(frame: [Lanes<N>; 8], geometry: &LegGeometry<DualSVec64<N>>) -> Self {
        let attachment = geometry.attachment.map(|x| split(&x));
        let moves = |(_, lanes): &Lanes<N>| lanes.iter().any(|&lane| lane != 0.0);
        Self {
            moving: (frame.each_ref().map(moves), attachment.iter().any(moves)),
            frame,
            attachment,
            gain: split(&geometry.gain),
            offset: split(&geometry.offset),
        }
    }

    /// The reading `(q_a − offset) / gain` at the platform transform `platform` and its
    /// derivatives (written into `gradient`): the kernel's f64 partials chained with the
    /// inputs' lanes. The target's value is [`attachment_on_constant`]'s, bit for bit; `None`
    /// where the closed form fails.
    fn reading(
        &self,
        kernel: &LegKernel,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> Option<f64> {
        let m = platform.rotation.matrix();
        let t = &platform.translation.vector;
        let a: [f64; 3] = std::array::from_fn(|k| self.attachment[k].0);
        let row = |i: usize| a[0] * m[(i, 0)] + a[1] * m[(i, 1)] + a[2] * m[(i, 2)] + t[i];
        let frame: [f64; 8] = std::array::from_fn(|k| self.frame[k].0);
        let target = [row(0), row(1), row(2)];
        let (actuated, partials) = kernel.actuated_partials(&frame, target, solution)?;
        let ((gain, d_gain), (offset, d_offset)) = (&self.gain, &self.offset);
        // The quotient as the duals' division forms it (times the reciprocal; an overflowing
        // gain gives a non-finite derivative, as it did there).
        let (difference, inverse) = (actuated - offset, gain.recip());
        let reading = difference * inverse;
        // Every lane at once, each lane's sum in the same order as one lane alone: the frame's
        // terms, then the target's three.
        let mut d = [0.0; N];
        let (frame_moving, attachment_moving) = self.moving;
        for (((_, lanes), p), moving) in self.frame.iter().zip(&partials).zip(frame_moving) {
            if !moving && p.is_finite() {
                continue;
            }
            for (d, lane) in d.iter_mut().zip(lanes) {
                *d += p * lane;
            }
        }
        let [(_, a0), (_, a1), (_, a2)] = &self.attachment;
        for (i, p) in partials[8..].iter().enumerate() {
            if !attachment_moving && p.is_finite() {
                continue;
            }
            let (m0, m1, m2) = (m[(i, 0)], m[(i, 1)], m[(i, 2)]);
            for j in 0..N {
                d[j] += p * (a0[j] * m0 + a1[j] * m1 + a2[j] * m2);
            }
        }
        for (j, out) in gradient.iter_mut().enumerate().take(N) {
            *out = ((d[j] - d_offset[j]) * gain - d_gain[j] * difference) * inverse * inverse;
        }
        Some(reading)
    }
}

impl<const N: usize> DualPass<N> {
    /// Lane `k` carries ∂/∂φ[columns[first + k]]; `kernel` the leg's closed-form kernel
    /// prepared at `phi` in f64, if it has one.
    fn new(
        leg: &LegModel,
        (phi, columns, first): (&[f64], &[usize], usize),
        kernel: Option<&PreparedKernel<f64>>,
    ) -> Self {
        let mut phi_dual: Vec<DualSVec64<N>> =
            phi.iter().map(|&v| DualSVec64::<N>::from_re(v)).collect();
        let mut variable_angles = vec![false; leg.joints.len()];
        let mut moves_origins = false;
        for (lane, &column) in columns[first..first + N].iter().enumerate() {
            phi_dual[column] = DualSVec64::<N>::from_re(phi[column]).derivative(lane);
            if let ParamTarget::JointOrigin { joint, component } = leg.params[column].target {
                variable_angles[joint] |= component >= 3;
                moves_origins = true;
            }
        }
        let geometry = leg.geometry(&phi_dual);
        let pattern = kernel.map(PreparedKernel::kernel);
        // The kernel's frame is built from the joint origins alone: where the pass seeds none,
        // its lanes are zero and its numbers the f64 kernel's, so the frame is not composed in
        // duals.
        let lanes = match (kernel, pattern) {
            (Some(kernel), _) if !moves_origins => {
                Some(KernelLanes::fixed_frame(kernel, &geometry))
            }
            (_, Some(pattern)) => Some(KernelLanes::new(&pattern, &geometry)),
            _ => None,
        };
        Self {
            first,
            chain: OnceLock::new(),
            variable_angles,
            pattern,
            lanes,
            kernel: OnceLock::new(),
            geometry,
        }
    }

    /// The closed-form kernel in duals, if the leg has one.
    fn dual_kernel(&self) -> Option<&PreparedKernel<DualSVec64<N>>> {
        let prepare = || self.pattern.map(|pattern| pattern.prepare(&self.geometry));
        self.kernel.get_or_init(prepare).as_ref()
    }
}

impl<const N: usize> GradientPass for DualPass<N> {
    fn evaluate(
        &self,
        leg: &LegModel,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> f64 {
        if let Some(reading) = self.closed_form(platform, solution, gradient) {
            return reading;
        }
        let target = attachment_on_constant(platform, &self.geometry.attachment);
        let closed_form = self.dual_kernel();
        let reading = match closed_form.and_then(|k| k.reading(&self.geometry, &target, solution)) {
            Some(reading) => reading,
            None => {
                let chain = self
                    .chain
                    .get_or_init(|| TipChain::new(&self.geometry, &self.variable_angles));
                let tip = chain.tip(leg, &solution.q[..leg.moving.len()]);
                reading_at_tip(leg, &tip, &self.geometry, &target, solution)
            }
        };
        let lanes = reading.eps.unwrap_generic(Const::<N>, U1);
        gradient[self.first..self.first + N].copy_from_slice(lanes.as_slice());
        reading.re()
    }

    fn closed_form(
        &self,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> Option<f64> {
        let (pattern, lanes) = (self.pattern.as_ref()?, self.lanes.as_ref()?);
        let own = &mut gradient[self.first..self.first + N];
        lanes.reading(pattern, platform, solution, own)
    }
}

/// The pass for `count` columns from `first` on (`1 ≤ count ≤ LANES`).
fn pass(
    leg: &LegModel,
    (phi, columns, first): (&[f64], &[usize], usize),
    count: usize,
    kernel: Option<&PreparedKernel<f64>>,
) -> Arc<dyn GradientPass> {
    let at = (phi, columns, first);
    match count {
        1 => Arc::new(DualPass::<1>::new(leg, at, kernel)),
        2 => Arc::new(DualPass::<2>::new(leg, at, kernel)),
        3 => Arc::new(DualPass::<3>::new(leg, at, kernel)),
        4 => Arc::new(DualPass::<4>::new(leg, at, kernel)),
        5 => Arc::new(DualPass::<5>::new(leg, at, kernel)),
        6 => Arc::new(DualPass::<6>::new(leg, at, kernel)),
        7 => Arc::new(DualPass::<7>::new(leg, at, kernel)),
        _ => Arc::new(DualPass::<LANES>::new(leg, at, kernel)),
    }
}

impl<'a> PreparedLeg<'a> {
    /// Prepares `leg` at full parameter vector `phi`, for derivatives with respect to the
    /// parameters listed in `columns` (indices into the leg's parameters).
    /// The leg's inverse kinematics and derivatives take its closed-form kernel
    /// ([`LegKernel::recognise`]) if its chain has one.
    pub fn new(leg: &'a LegModel, phi: &[f64], columns: &[usize]) -> Self {
        Self::with_kernel(leg, phi, columns, LegKernel::recognise(leg))
    }

    /// As [`Self::new`], always on the generic chain (Newton's method and the derivative step
    /// through the chain): the reference the closed-form kernels are tested against.
    pub fn generic(leg: &'a LegModel, phi: &[f64], columns: &[usize]) -> Self {
        Self::with_kernel(leg, phi, columns, None)
    }

    /// As [`Self::new`], with the closed-form `kernel` recognised for `leg` (or none).
    pub fn with_kernel(
        leg: &'a LegModel,
        phi: &[f64],
        columns: &[usize],
        kernel: Option<LegKernel>,
    ) -> Self {
        let geometry = leg.geometry(phi);
        let mut prepared = Self {
            leg,
            frames: LazyChainFrames::new(),
            kernel: kernel.map(|kernel| kernel.prepare(&geometry)),
            geometry,
            passes: Vec::new(),
            columns: 0,
        };
        if !columns.is_empty() {
            prepared.derive(phi, columns);
        }
        prepared
    }

    /// Adds the derivative passes with respect to the parameters listed in `columns` to a leg
    /// prepared without any ([`Self::columns`] zero) at the same full parameter vector `phi`:
    /// the f64 geometry, its chain frames and kernel are kept, only the dual-number passes are
    /// built. A leg prepared for residuals is thus reused for the Jacobian at the same
    /// parameters.
    pub fn derive(&mut self, phi: &[f64], columns: &[usize]) {
        debug_assert!(
            self.passes.is_empty(),
            "the leg already has derivative passes"
        );
        let kernel = self.kernel.as_ref();
        self.passes = (0..columns.len())
            .step_by(LANES)
            .map(|first| {
                let count = LANES.min(columns.len() - first);
                pass(self.leg, (phi, columns, first), count, kernel)
            })
            .collect();
        self.columns = columns.len();
    }

    /// Whether the leg is solved by a closed-form kernel.
    pub fn closed_form(&self) -> bool {
        self.kernel.is_some()
    }

    /// Number of prepared derivative columns.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// The leg.
    pub fn leg(&self) -> &'a LegModel {
        self.leg
    }

    /// The leg's geometry at the prepared parameters.
    pub fn geometry(&self) -> &LegGeometry<f64> {
        &self.geometry
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
        let solution = self.solve_warm(pose, home_pose, None)?;
        Ok(self.reading_and_gradient_of(pose, &solution, gradient))
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
        Ok(self
            .solve_warm(pose, home_pose, None)?
            .to_leg_solution(self.leg))
    }

    /// The leg's inverse kinematics at `pose`, warm-started from `seed` (the joints of a
    /// previous solution of the same pose) when given; see
    /// [`crate::kinematics::inverse::solve_warm`]. Allocates nothing.
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn solve_warm(
        &self,
        pose: &[f64; 6],
        home_pose: &[f64; 6],
        seed: Option<&Joints>,
    ) -> Result<Solution, KinematicsError> {
        self.solve_warm_on(&platform_transform(pose), pose, home_pose, seed)
    }

    /// As [`Self::solve_warm`], with the pose's platform transform `platform`
    /// ([`platform_transform`] of `pose`) already computed.
    ///
    /// # Errors
    /// The leg cannot reach the pose on its home branch.
    pub fn solve_warm_on(
        &self,
        platform: &Transform<f64>,
        pose: &[f64; 6],
        home_pose: &[f64; 6],
        seed: Option<&Joints>,
    ) -> Result<Solution, KinematicsError> {
        let target = attachment_on(platform, &self.geometry.attachment);
        let leg = (self.leg, &self.geometry, &self.frames);
        solve_warm_through(self.kernel.as_ref(), leg, (pose, &target), home_pose, seed)
    }

    /// The predicted reading (f64) at an already solved pose (no chain pass: from the closure
    /// error the solution carries).
    pub fn reading_of(&self, solution: &Solution) -> f64 {
        reading_value(self.leg, &self.geometry, solution)
    }

    /// The predicted reading at an already solved pose, writing its gradient with respect to
    /// the prepared columns into `gradient` (one value per column): one dual pass per
    /// [`LANES`] columns. Allocates nothing.
    pub fn reading_and_gradient_of(
        &self,
        pose: &[f64; 6],
        solution: &Solution,
        gradient: &mut [f64],
    ) -> f64 {
        if self.passes.is_empty() {
            return self.reading_of(solution);
        }
        self.reading_and_gradient_on(&platform_transform(pose), solution, gradient)
    }

    /// As [`Self::reading_and_gradient_of`], with the pose's platform transform `platform`
    /// ([`platform_transform`] of the pose) already computed.
    pub fn reading_and_gradient_on(
        &self,
        platform: &Transform<f64>,
        solution: &Solution,
        gradient: &mut [f64],
    ) -> f64 {
        if self.passes.is_empty() {
            return self.reading_of(solution);
        }
        let mut reading = 0.0;
        for pass in &self.passes {
            reading = pass.evaluate(self.leg, platform, solution, gradient);
        }
        reading
    }

    /// `∂ψ/∂P`: the gradient of the predicted reading with respect to the pose coordinates
    /// `measured` (zero for the others) at an already solved `pose`, through the implicit
    /// function theorem: only the attachment point's world position moves with the pose (the
    /// chain's tip does not), so `∂ψ/∂P_c = Σ_k (F_q⁻¹)_{a,k} ∂target_k/∂P_c / gain`, with the
    /// target's derivatives from one pass in vector duals seeded on the six coordinates.
    pub fn pose_gradient_of(
        &self,
        pose: &[f64; 6],
        solution: &Solution,
        measured: &[usize],
    ) -> [f64; 6] {
        // The target's derivatives with respect to the position coordinates are the unit
        // vectors (exactly the dual pass's values): the pass is needed for an angle only.
        let lanes: [[f64; 6]; 3] = if measured.iter().all(|&c| c < 3) {
            std::array::from_fn(|k| std::array::from_fn(|c| if c == k { 1.0 } else { 0.0 }))
        } else {
            let seeded: [DualSVec64<6>; 6] =
                std::array::from_fn(|c| DualSVec64::<6>::from_re(pose[c]).derivative(c));
            let attachment = self.geometry.attachment.map(DualSVec64::<6>::from_re);
            let target = attachment_world(&seeded, &attachment);
            std::array::from_fn(|k| {
                let eps = target[k].eps.unwrap_generic(Const::<6>, U1);
                std::array::from_fn(|c| eps[c])
            })
        };
        let mut gradient = [0.0; 6];
        for &c in measured {
            let mut actuated = 0.0;
            for (k, lane) in lanes.iter().enumerate().take(self.leg.closure_dims) {
                actuated += solution.closure_inverse[(self.leg.actuated, k)] * lane[c];
            }
            gradient[c] = actuated / self.geometry.gain;
        }
        gradient
    }

    /// As [`Self::reading_and_gradient`], at an already solved pose.
    pub fn reading_and_gradient_at(
        &self,
        pose: &[f64; 6],
        solution: &LegSolution,
        gradient: &mut [f64],
    ) -> f64 {
        let q = joints(&solution.q);
        let tip = self.frames.get(&self.geometry).tip(self.leg, &solution.q);
        let target = attachment_on(&platform_transform(pose), &self.geometry.attachment);
        let mut closure = tip - target;
        for k in self.leg.closure_dims..3 {
            closure[k] = 0.0;
        }
        let solution = Solution {
            q,
            closure,
            closure_inverse: solution.closure_inverse,
            normalised_determinant: solution.normalised_determinant,
        };
        self.reading_and_gradient_of(pose, &solution, gradient)
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
