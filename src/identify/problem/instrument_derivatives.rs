//! The derivatives of what an instrument reports at a closed pose, with respect to the pose's
//! measured coordinates and to the identified shared parameters, by multi-lane dual numbers:
//! every column seeded on its own lane, up to [`LANES`] columns a pass (the residual-only
//! evaluation takes the f64 values alone).

use nalgebra::{Const, DMatrix, U1};
use num_dual::{DualSVec64, DualStruct};

use crate::identify::jacobian::LANES;
use crate::measure::targets::{observe_in, target_position};
use crate::model::instrument::Instrument;
use crate::scalar::Scalar;

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

    fn at<T: Scalar>(&self, shared: &[T], pose: &[T; 6]) -> Vec<T> {
        match *self {
            Self::Report(instrument) => observe_in(instrument, shared, pose),
            Self::Position(instrument, target) => {
                target_position(instrument, shared, target, pose).to_vec()
            }
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

/// The values of `f(θ, P)` at the shared parameters `shared` and the pose `pose` and, when
/// `columns`, `∂f/∂P` (rows of `f`, 6 columns; the `measured` ones filled) and `∂f/∂θ` over the
/// `identified` shared parameters (zero without `columns`: a residual-only evaluation needs
/// none).
pub(super) fn derivatives(
    f: PoseFunction<'_>,
    (shared, identified): (&[f64], &[usize]),
    pose: &[f64; 6],
    (measured, columns): (&[usize], bool),
) -> (Vec<f64>, DMatrix<f64>, DMatrix<f64>) {
    let total = if columns {
        measured.len() + identified.len()
    } else {
        0
    };
    if total == 0 {
        let values = f.at(shared, pose);
        let n = values.len();
        return (
            values,
            DMatrix::zeros(n, 6),
            DMatrix::zeros(n, identified.len()),
        );
    }
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
    let n = f.len();
    let mut values = Vec::with_capacity(n);
    let mut by_pose = DMatrix::zeros(n, 6);
    let mut by_shared = DMatrix::zeros(n, identified.len());
    for first in (0..total).step_by(LANES) {
        let count = (total - first).min(LANES);
        let mut seeds = [Seed::Pose(0); LANES];
        for (i, s) in seeds.iter_mut().enumerate().take(count) {
            *s = seed(first + i);
        }
        let seeds = &seeds[..count];
        // Every pass's values are the same f64 operations: the first one's are kept.
        let mut write = |o: usize, value: f64, lanes: &[f64]| {
            if first == 0 {
                values.push(value);
            }
            for (seed, &d) in seeds.iter().zip(lanes) {
                match *seed {
                    Seed::Pose(c) => by_pose[(o, c)] = d,
                    Seed::Shared { j, .. } => by_shared[(o, j)] = d,
                }
            }
        };
        let at = (shared, pose);
        match count {
            1 => pass::<1>(f, at, seeds, &mut write),
            2 => pass::<2>(f, at, seeds, &mut write),
            3 => pass::<3>(f, at, seeds, &mut write),
            4 => pass::<4>(f, at, seeds, &mut write),
            5 => pass::<5>(f, at, seeds, &mut write),
            6 => pass::<6>(f, at, seeds, &mut write),
            7 => pass::<7>(f, at, seeds, &mut write),
            _ => pass::<LANES>(f, at, seeds, &mut write),
        }
    }
    (values, by_pose, by_shared)
}

/// One pass of `f` with the columns `seeds` (at most `N`) on lanes `0..`: `write(o, value,
/// lanes)` for every output `o`, at most [`PoseFunction::len`] of them.
fn pass<const N: usize>(
    f: PoseFunction<'_>,
    (shared, pose): (&[f64], &[f64; 6]),
    seeds: &[Seed],
    write: &mut impl FnMut(usize, f64, &[f64]),
) {
    let mut lifted: Vec<DualSVec64<N>> = shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
    let mut seeded: [DualSVec64<N>; 6] = pose.map(DualSVec64::from_re);
    for (lane, seed) in seeds.iter().enumerate() {
        match *seed {
            Seed::Pose(c) => seeded[c] = seeded[c].derivative(lane),
            Seed::Shared { k, .. } => lifted[k] = lifted[k].derivative(lane),
        }
    }
    let n = f.len();
    for (o, value) in f.at(&lifted, &seeded).iter().enumerate().take(n) {
        let eps = value.eps.unwrap_generic(Const::<N>, U1);
        write(o, value.re(), eps.as_slice());
    }
}
