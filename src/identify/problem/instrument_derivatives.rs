//! The derivatives of what an instrument reports at a closed pose, with respect to the pose's
//! measured coordinates and to the identified shared parameters, by multi-lane dual numbers:
//! every column seeded on its own lane, up to [`LANES`] columns a pass (the residual-only
//! evaluation takes the f64 values alone). A spatial instrument reporting target positions (a
//! tracker's reflectors, a probe's height) takes them in closed form instead, every column in
//! one pass (`instrument_derivatives/spatial_pass.rs`): the same derivatives to round-off.
//!
//! Everything that depends only on the shared parameters (their seeded dual values, a spatial
//! instrument's frame rotation) is prepared once per evaluation ([`PreparedFunction`]) and
//! reused at every row; a pass whose lanes carry no pose angle rotates the platform in f64.

use std::cell::RefCell;

use nalgebra::{Const, Matrix3, U1};
use num_dual::{DualSVec64, DualStruct};

use crate::identify::jacobian::LANES;
use crate::kinematics::chain::platform_transform_f64;
use crate::measure::targets::{
    observe_framed, observe_in, platform_rotation, target_position, SpatialFrame,
};
use crate::model::instrument::Instrument;
use crate::scalar::Scalar;

mod spatial_pass;

/// A function of the shared parameters and the platform pose, in any scalar: what the
/// instrument reports ([`observe_in`]), or one target's base-frame position
/// ([`target_position`]).
#[derive(Debug, Clone, Copy)]
pub(super) enum PoseFunction<'a> {
    /// The instrument's report at the pose.
    Report(&'a Instrument),
    /// Target `usize`'s position in the base frame.
    Position(&'a Instrument, usize),
}

impl PoseFunction<'_> {
    /// How many values [`Self::at`] gives.
    fn len(&self) -> usize {
        match *self {
            Self::Report(instrument) => instrument.observed_len(),
            Self::Position(..) => 3,
        }
    }

    /// The spatial instrument's report: computed through its prepared frame.
    fn spatial_report(&self) -> Option<&Instrument> {
        match *self {
            Self::Report(instrument) if instrument.spatial => Some(instrument),
            _ => None,
        }
    }

    fn at<T: Scalar>(&self, shared: &[T], pose: &[T; 6]) -> Vec<T> {
        match *self {
            Self::Report(instrument) => observe_in(instrument, shared, pose),
            Self::Position(instrument, target) => {
                target_position(instrument, shared, target, pose).to_vec()
            }
        }
    }

    /// The values at `pose` appended to `out`, through `frame` (the shared parameters') and
    /// the platform's rotation `platform` at `pose` for a spatial report.
    fn write<T: Scalar>(
        &self,
        (shared, frame): (&[T], Option<&SpatialFrame<T>>),
        (platform, pose): (&Matrix3<T>, &[T; 6]),
        out: &mut Vec<T>,
    ) {
        match (self.spatial_report(), frame) {
            (Some(instrument), Some(frame)) => {
                observe_framed(instrument, (shared, frame), (platform, pose), out);
            }
            _ => out.extend(self.at(shared, pose)),
        }
    }
}

/// A seeded column: a pose coordinate, or the `j`-th identified shared parameter (index `k`
/// among all the shared ones).
#[derive(Debug, Clone, Copy)]
enum Seed {
    Pose(usize),
    Shared { j: usize, k: usize },
}

/// The values of `f` at one pose and their derivatives ([`PreparedFunction::at`]).
#[derive(Debug, Clone, Default)]
pub(super) struct Derivatives {
    /// `f`'s values.
    pub(super) values: Vec<f64>,
    /// Per value, `∂f/∂P` over the six pose coordinates (the measured ones filled).
    pub(super) by_pose: Vec<[f64; 6]>,
    /// Per value, `∂f/∂θ` over the identified shared parameters, value after value.
    by_shared: Vec<f64>,
    /// How many identified shared parameters.
    width: usize,
}

impl Derivatives {
    /// Value `o`'s `∂f/∂θ` over the identified shared parameters.
    pub(super) fn by_shared(&self, o: usize) -> &[f64] {
        &self.by_shared[o * self.width..(o + 1) * self.width]
    }
}

/// `f` prepared at the shared parameters for many poses: their f64 values (and a spatial
/// report's frame) and, when the columns are asked for, one dual pass per [`LANES`] columns.
pub(super) struct PreparedFunction<'a> {
    f: PoseFunction<'a>,
    shared: Vec<f64>,
    frame: Option<SpatialFrame<f64>>,
    passes: Vec<Box<dyn Pass + 'a>>,
    width: usize,
}

impl<'a> PreparedFunction<'a> {
    /// `f` at the shared parameters `shared`, with (when `columns`) its derivatives with
    /// respect to the `measured` pose coordinates and the `identified` shared parameters.
    pub(super) fn new(
        f: PoseFunction<'a>,
        (shared, identified): (&[f64], &[usize]),
        (measured, columns): (&[usize], bool),
    ) -> Self {
        Self::with_passes(f, (shared, identified), (measured, columns), true)
    }

    /// As [`Self::new`]; `closed_form`: a spatial report of positions takes its derivatives in
    /// closed form (`instrument_derivatives/spatial_pass.rs`), else every function takes the
    /// dual-number passes.
    fn with_passes(
        f: PoseFunction<'a>,
        (shared, identified): (&[f64], &[usize]),
        (measured, columns): (&[usize], bool),
        closed_form: bool,
    ) -> Self {
        let total = if columns {
            measured.len() + identified.len()
        } else {
            0
        };
        let seed = |i: usize| match measured.get(i) {
            Some(&c) => Seed::Pose(c),
            None => {
                let j = i - measured.len();
                Seed::Shared {
                    j,
                    k: identified[j],
                }
            }
        };
        let every = || (0..total).map(seed).collect::<Vec<Seed>>();
        let closed = (closed_form && total > 0)
            .then(|| Self::closed_form_pass(f, shared, every()))
            .flatten();
        let passes = match closed {
            Some(closed) => vec![closed],
            None => (0..total)
                .step_by(LANES)
                .map(|first| {
                    let count = (total - first).min(LANES);
                    let seeds: Vec<Seed> = (first..first + count).map(seed).collect();
                    pass(f, shared, seeds)
                })
                .collect(),
        };
        Self {
            f,
            shared: shared.to_vec(),
            frame: f.spatial_report().map(|_| SpatialFrame::new(shared)),
            passes,
            width: identified.len(),
        }
    }

    /// The values at `pose` and their derivatives (zero without columns: a residual-only
    /// evaluation needs none), written into `out`.
    pub(super) fn at(&self, pose: &[f64; 6], out: &mut Derivatives) {
        let n = self.f.len();
        out.values.clear();
        out.by_pose.clear();
        out.by_pose.resize(n, [0.0; 6]);
        out.by_shared.clear();
        out.by_shared.resize(n * self.width, 0.0);
        out.width = self.width;
        // The platform's rotation: only a spatial report reads it.
        let platform = match self.frame {
            // The platform's rotation as the spatial report computes it, bit for bit, without
            // the trigonometry when the pose does not turn (a delta's).
            Some(_) => platform_transform_f64(pose).rotation.into_inner(),
            None => Matrix3::identity(),
        };
        if self.passes.is_empty() {
            let at = (&self.shared[..], self.frame.as_ref());
            self.f.write(at, (&platform, pose), &mut out.values);
            return;
        }
        for (p, pass) in self.passes.iter().enumerate() {
            pass.evaluate((pose, &platform), out, p == 0);
        }
    }
}

/// The values of `f(θ, P)` at the shared parameters `shared` and the pose `pose` and, when
/// `columns`, their derivatives ([`PreparedFunction`] for one pose).
pub(super) fn derivatives(
    f: PoseFunction<'_>,
    at: (&[f64], &[usize]),
    pose: &[f64; 6],
    columns: (&[usize], bool),
) -> Derivatives {
    let mut out = Derivatives::default();
    PreparedFunction::new(f, at, columns).at(pose, &mut out);
    out
}

/// One dual pass over some of the columns, prepared at the shared parameters.
trait Pass {
    /// Writes the derivatives of every value at `pose` (the platform's rotation `platform`)
    /// with respect to its columns into `out`, and the values too if `first`.
    fn evaluate(&self, at: (&[f64; 6], &Matrix3<f64>), out: &mut Derivatives, first: bool);
}

/// A pass of `N` lanes: the shared parameters lifted with their seeds, and a spatial report's
/// frame in duals.
struct DualPass<'a, const N: usize> {
    f: PoseFunction<'a>,
    seeds: Vec<Seed>,
    lifted: Vec<DualSVec64<N>>,
    frame: Option<SpatialFrame<DualSVec64<N>>>,
    /// Whether a lane carries a pose angle (else the platform's rotation is lifted from f64).
    angles: bool,
    /// The values of the last evaluation (reused storage).
    values: RefCell<Vec<DualSVec64<N>>>,
}

/// The pass over the columns `seeds` (`1 ≤ len ≤ LANES`).
fn pass<'a>(f: PoseFunction<'a>, shared: &[f64], seeds: Vec<Seed>) -> Box<dyn Pass + 'a> {
    match seeds.len() {
        1 => Box::new(DualPass::<1>::new(f, shared, seeds)),
        2 => Box::new(DualPass::<2>::new(f, shared, seeds)),
        3 => Box::new(DualPass::<3>::new(f, shared, seeds)),
        4 => Box::new(DualPass::<4>::new(f, shared, seeds)),
        5 => Box::new(DualPass::<5>::new(f, shared, seeds)),
        6 => Box::new(DualPass::<6>::new(f, shared, seeds)),
        7 => Box::new(DualPass::<7>::new(f, shared, seeds)),
        _ => Box::new(DualPass::<LANES>::new(f, shared, seeds)),
    }
}

impl<'a, const N: usize> DualPass<'a, N> {
    fn new(f: PoseFunction<'a>, shared: &[f64], seeds: Vec<Seed>) -> Self {
        let mut lifted: Vec<DualSVec64<N>> =
            shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
        for (lane, seed) in seeds.iter().enumerate() {
            if let Seed::Shared { k, .. } = *seed {
                lifted[k] = lifted[k].derivative(lane);
            }
        }
        let angles = seeds.iter().any(|s| matches!(s, Seed::Pose(c) if *c >= 3));
        Self {
            f,
            frame: f.spatial_report().map(|_| SpatialFrame::new(&lifted)),
            seeds,
            lifted,
            angles,
            values: RefCell::new(Vec::new()),
        }
    }
}

impl<const N: usize> Pass for DualPass<'_, N> {
    fn evaluate(
        &self,
        (pose, platform): (&[f64; 6], &Matrix3<f64>),
        out: &mut Derivatives,
        first: bool,
    ) {
        let mut seeded: [DualSVec64<N>; 6] = pose.map(DualSVec64::from_re);
        for (lane, seed) in self.seeds.iter().enumerate() {
            if let Seed::Pose(c) = *seed {
                seeded[c] = seeded[c].derivative(lane);
            }
        }
        let rotation = match self.angles {
            true => platform_rotation(&seeded),
            false => platform.map(DualSVec64::from_re),
        };
        let mut values = self.values.borrow_mut();
        values.clear();
        let at = (&self.lifted[..], self.frame.as_ref());
        self.f.write(at, (&rotation, &seeded), &mut values);
        let width = out.width;
        for (o, value) in values.iter().enumerate().take(out.by_pose.len()) {
            if first {
                out.values.push(value.re());
            }
            let eps = value.eps.unwrap_generic(Const::<N>, U1);
            for (seed, &d) in self.seeds.iter().zip(eps.as_slice()) {
                match *seed {
                    Seed::Pose(c) => out.by_pose[o][c] = d,
                    Seed::Shared { j, .. } => out.by_shared[o * width + j] = d,
                }
            }
        }
    }
}
