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
    let seeds: Vec<Seed> = match columns {
        true => measured
            .iter()
            .map(|&c| Seed::Pose(c))
            .chain(
                identified
                    .iter()
                    .enumerate()
                    .map(|(j, &k)| Seed::Shared { j, k }),
            )
            .collect(),
        false => Vec::new(),
    };
    if seeds.is_empty() {
        let values = f.at(shared, pose);
        let n = values.len();
        return (
            values,
            DMatrix::zeros(n, 6),
            DMatrix::zeros(n, identified.len()),
        );
    }
    let passes: Vec<_> = seeds
        .chunks(LANES)
        .map(|chunk| {
            let at = (shared, pose);
            let read = match chunk.len() {
                1 => pass::<1>(f, at, chunk),
                2 => pass::<2>(f, at, chunk),
                3 => pass::<3>(f, at, chunk),
                4 => pass::<4>(f, at, chunk),
                5 => pass::<5>(f, at, chunk),
                6 => pass::<6>(f, at, chunk),
                7 => pass::<7>(f, at, chunk),
                _ => pass::<LANES>(f, at, chunk),
            };
            (chunk, read)
        })
        .collect();
    // Every pass's values are the same f64 operations: the first one's.
    let values: Vec<f64> = passes[0].1.iter().map(|(value, _)| *value).collect();
    let mut by_pose = DMatrix::zeros(values.len(), 6);
    let mut by_shared = DMatrix::zeros(values.len(), identified.len());
    for (chunk, read) in &passes {
        for (o, (_, lanes)) in read.iter().enumerate() {
            for (seed, &d) in chunk.iter().zip(lanes) {
                match *seed {
                    Seed::Pose(c) => by_pose[(o, c)] = d,
                    Seed::Shared { j, .. } => by_shared[(o, j)] = d,
                }
            }
        }
    }
    (values, by_pose, by_shared)
}

/// One pass of `f` with the columns `seeds` (at most `N`) on lanes `0..`: every output's value
/// and its lanes.
fn pass<const N: usize>(
    f: PoseFunction<'_>,
    (shared, pose): (&[f64], &[f64; 6]),
    seeds: &[Seed],
) -> Vec<(f64, [f64; LANES])> {
    let mut lifted: Vec<DualSVec64<N>> = shared.iter().map(|&v| DualSVec64::from_re(v)).collect();
    let mut seeded: [DualSVec64<N>; 6] = pose.map(DualSVec64::from_re);
    for (lane, seed) in seeds.iter().enumerate() {
        match *seed {
            Seed::Pose(c) => seeded[c] = seeded[c].derivative(lane),
            Seed::Shared { k, .. } => lifted[k] = lifted[k].derivative(lane),
        }
    }
    f.at(&lifted, &seeded)
        .iter()
        .map(|value| {
            let eps = value.eps.unwrap_generic(Const::<N>, U1);
            let mut lanes = [0.0; LANES];
            lanes[..N].copy_from_slice(eps.as_slice());
            (value.re(), lanes)
        })
        .collect()
}
