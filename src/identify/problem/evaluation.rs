//! The evaluations of an [`IdentificationProblem`]: each block's platform pose (measured, or
//! fitted from its targets), inverse-kinematics solution and predicted reading at one unknowns
//! vector, and (once asked for) the reading's gradients; the latest two kept, keyed by the
//! exact bits of the unknowns, and every block's last solution kept as the warm start of its
//! next solve.

use std::sync::MutexGuard;

use nalgebra::DVector;
use rayon::prelude::*;

use super::state::{
    release_older_gradients, seed_joints, seed_solution, store_seed, Evaluation, Evaluations,
    KEPT_SOLUTION_ROWS,
};
use super::{BlockError, IdentificationProblem, Placed};
use crate::error::KinematicsError;
use crate::identify::jacobian::PreparedLeg;
use crate::kinematics::inverse::Solution;

/// Rows per task: a problem with more rows is evaluated in parallel (rayon), in chunks of this
/// many rows. The chunks do not depend on the number of threads, and every row's warm start
/// only on that row's own history, so neither do the results.
pub(super) const ROWS_PER_TASK: usize = 512;

/// Latest evaluations kept (the solvers evaluate the Jacobian where they last evaluated the
/// residuals; the refinement may end on a rejected point after the estimate).
const KEPT_EVALUATIONS: usize = 2;

/// One task's rows: the chunk's index, its seeds, predicted readings and gradients.
type ChunkOfRows<'c> = (usize, ((&'c mut [f64], &'c mut [f64]), &'c mut [f64]));

/// The bits of `x`: evaluations are reused only at exactly the same unknowns.
fn key(x: &DVector<f64>) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

/// Whether `key` is the bits of `x` ([`key`], without building it).
fn same(key: &[u64], x: &DVector<f64>) -> bool {
    key.len() == x.len() && key.iter().zip(x.iter()).all(|(&k, v)| k == v.to_bits())
}

impl<'a> IdentificationProblem<'a> {
    /// The evaluation state (shared with the problem's clones).
    fn lock(&self) -> MutexGuard<'_, Evaluations<'a>> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Each slot's leg prepared at the unknowns `x` (built once, reused at every pose), for
    /// the derivatives with respect to its identified parameters if `derivatives`.
    fn prepare(&self, x: &DVector<f64>, derivatives: bool) -> Vec<PreparedLeg<'a>> {
        let kernels = self.kernels.iter().copied();
        self.slots
            .iter()
            .zip(kernels)
            .map(|(slot, kernel)| {
                let leg = &self.mechanism.legs[slot.leg];
                let columns: &[usize] = if derivatives { &slot.columns } else { &[] };
                PreparedLeg::with_kernel(leg, &self.leg_parameters(slot, x), columns, kernel)
            })
            .collect()
    }

    /// Block `index`'s prepared leg among `prepared` (one per slot).
    fn prepared_leg<'p>(
        &self,
        prepared: &'p [PreparedLeg<'a>],
        index: usize,
    ) -> &'p PreparedLeg<'a> {
        &prepared[self.slot_of_leg[self.blocks[index].leg].unwrap_or_default()]
    }

    /// Block `index`'s reading at its solved pose `placed`, its gradient written into
    /// `gradient` ([`Self::gradient_stride`] values): with respect to its leg's identified
    /// parameters by the leg's dual passes, then to the identified shared parameters `shared`
    /// by the chain rule through the pose fit (problem/sighted.rs).
    fn reading_and_gradient(
        &self,
        (leg, index): (&PreparedLeg<'a>, usize),
        (placed, solution): (&Placed, &Solution),
        shared: &[f64],
        gradient: &mut [f64],
    ) -> f64 {
        let own = self.own_width();
        let reading =
            leg.reading_and_gradient_on(&placed.platform, solution, &mut gradient[..leg.columns()]);
        if let Some(sighted) = self.sighting().filter(|s| !s.shared.is_empty()) {
            let row = (sighted.rows[index].observed.as_slice(), &placed.pose);
            let home = &self.mechanism.home_pose;
            sighted.shared_gradient(leg, row, solution, (shared, home), &mut gradient[own..]);
        }
        // Through an instrument the reading is the solution's own, the value a residual-only
        // evaluation gives (its fitted poses' results are those recorded with it); with
        // measured poses, the dual pass's (the same to round-off).
        if self.sighting().is_some() {
            return leg.reading_of(solution);
        }
        reading
    }

    /// Calls `read` with the evaluation at the unknowns `x` (with the gradients if
    /// `derivatives`): a kept one if there is one at exactly `x`, else a new one, which is
    /// then kept. Solving a block's inverse kinematics is warm-started from its last solution.
    /// Only the newest gradients are kept: an older evaluation's are freed before new ones
    /// are computed (a large problem's are as large as its Jacobian; the solvers never ask
    /// for a Jacobian at a point before the last one they took a Jacobian at).
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    pub(super) fn evaluated<R>(
        &self,
        x: &DVector<f64>,
        derivatives: bool,
        read: impl FnOnce(&Evaluation<'a>) -> R,
    ) -> Result<R, BlockError> {
        let mut state = self.lock();
        let kept = state.recent.iter().position(|e| same(&e.x, x));
        let mut evaluation = match kept {
            Some(i) => state.recent.remove(i),
            None => {
                // The oldest kept evaluation would go once this one is kept: it goes first
                // (a large problem's evaluations are tens of megabytes).
                state.recent.truncate(KEPT_EVALUATIONS - 1);
                if derivatives {
                    release_older_gradients(&mut state);
                }
                self.solve_rows(x, key(x), derivatives, &mut state)?
            }
        };
        if derivatives && evaluation.gradients.is_empty() && !self.blocks.is_empty() {
            release_older_gradients(&mut state);
            if !evaluation.solutions.is_empty() {
                self.derive(&mut evaluation.prepared, x);
                let (solutions, poses) = (&evaluation.solutions, &evaluation.poses);
                let pose = |i: usize| poses.get(i).copied();
                let gradients =
                    self.gradients(x, &evaluation.prepared, |i| (solutions[i], pose(i)));
                evaluation.gradients = gradients;
            } else if state.solved == evaluation.x {
                // The seeds are this evaluation's solutions.
                self.derive(&mut evaluation.prepared, x);
                let seeds = &state.seeds;
                let leg = |i: usize| &self.mechanism.legs[self.blocks[i].leg];
                let gradients = self.gradients(x, &evaluation.prepared, |i| {
                    (
                        seed_solution(&seeds.values[i * seeds.stride..], leg(i)),
                        None,
                    )
                });
                evaluation.gradients = gradients;
            } else {
                let key = std::mem::take(&mut evaluation.x);
                evaluation = self.solve_rows(x, key, true, &mut state)?;
            }
        }
        let value = read(&evaluation);
        state.recent.insert(0, evaluation);
        state.recent.truncate(KEPT_EVALUATIONS);
        Ok(value)
    }

    /// Adds to each slot's leg of `prepared` (prepared at the unknowns `x`) its derivative
    /// passes, where it has none yet.
    fn derive(&self, prepared: &mut [PreparedLeg<'a>], x: &DVector<f64>) {
        for (leg, slot) in prepared.iter_mut().zip(&self.slots) {
            if leg.columns() == 0 && !slot.columns.is_empty() {
                leg.derive(&self.leg_parameters(slot, x), &slot.columns);
            }
        }
    }

    /// Solves every block's inverse kinematics at the unknowns `x` (warm-started from the
    /// state's seeds, which then hold the new solutions) and evaluates the predicted readings
    /// (and their gradients if `derivatives`). Large problems are evaluated in parallel chunks
    /// of [`ROWS_PER_TASK`] rows; a problem of one chunk on the calling thread.
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    fn solve_rows(
        &self,
        x: &DVector<f64>,
        key: Vec<u64>,
        derivatives: bool,
        state: &mut Evaluations<'a>,
    ) -> Result<Evaluation<'a>, BlockError> {
        state.solved.clear();
        let seed_stride = state.seeds.stride;
        let seeds = &mut state.seeds.values[..];
        let m = self.blocks.len();
        let width = if derivatives {
            self.gradient_stride()
        } else {
            0
        };
        let prepared = self.prepare(x, derivatives);
        let shared = self.shared_values(x);
        let home = &self.mechanism.home_pose;
        let keep = m <= KEPT_SOLUTION_ROWS;
        let keep_poses = keep && self.sighting().is_some();
        let mut predicted = vec![0.0; m];
        let mut gradients = vec![0.0; m * width];
        let task = |(chunk, ((seeds, predicted), gradients)): ChunkOfRows<'_>| {
            let mut solutions = Vec::with_capacity(if keep { predicted.len() } else { 0 });
            let mut poses = Vec::with_capacity(if keep_poses { predicted.len() } else { 0 });
            let rows = seeds.chunks_mut(seed_stride).zip(predicted.iter_mut());
            for (k, (seed, value)) in rows.enumerate() {
                let index = chunk * ROWS_PER_TASK + k;
                let leg = self.prepared_leg(&prepared, index);
                let placed = self.placed(index, &shared);
                let warm = seed_joints(seed, leg.leg());
                let solution = leg
                    .solve_warm_on(&placed.platform, &placed.pose, home, warm.as_ref())
                    .map_err(|source| (index, source))?;
                store_seed(seed, leg.leg(), &solution);
                *value = if derivatives {
                    let gradient = &mut gradients[k * width..(k + 1) * width];
                    self.reading_and_gradient((leg, index), (&placed, &solution), &shared, gradient)
                } else {
                    leg.reading_of(&solution)
                };
                if keep {
                    solutions.push(solution);
                }
                if keep_poses {
                    poses.push(placed.pose);
                }
            }
            Ok::<_, (usize, KinematicsError)>((solutions, poses))
        };
        let (solutions, poses) = if m <= ROWS_PER_TASK {
            // One chunk: its rows' vectors are the evaluation's own.
            let rows = (seeds, &mut predicted[..]);
            task((0, (rows, &mut gradients[..])))
                .map_err(|(index, source)| self.block_error(index, source, x))?
        } else {
            // Without derivatives, a placeholder column (the chunks of all three slices
            // must pair).
            let stride = width.max(1);
            let mut placeholder = Vec::new();
            let columns = if width == 0 {
                placeholder.resize(m, 0.0);
                &mut placeholder[..]
            } else {
                &mut gradients[..]
            };
            // One task a chunk of rows.
            let results: Vec<_> = seeds
                .par_chunks_mut(ROWS_PER_TASK * seed_stride)
                .zip(predicted.par_chunks_mut(ROWS_PER_TASK))
                .zip(columns.par_chunks_mut(ROWS_PER_TASK * stride))
                .enumerate()
                .map(task)
                .collect();
            let mut solutions = Vec::with_capacity(if keep { m } else { 0 });
            let mut poses = Vec::with_capacity(if keep_poses { m } else { 0 });
            for result in results {
                match result {
                    Ok((mut chunk, mut chunk_poses)) => {
                        solutions.append(&mut chunk);
                        poses.append(&mut chunk_poses);
                    }
                    Err((index, source)) => return Err(self.block_error(index, source, x)),
                }
            }
            (solutions, poses)
        };
        state.row_solves += m as u64;
        state.solved.clone_from(&key);
        Ok(Evaluation {
            x: key,
            prepared,
            solutions,
            poses,
            predicted,
            gradients,
        })
    }

    /// The gradients of an evaluation at the unknowns `x` whose solutions are known
    /// (`solution(i)` of block `i`, with its fitted pose when kept), each slot's leg prepared
    /// at `x` with its derivative passes in `prepared`: the derivative passes only, no inverse
    /// kinematics; in parallel chunks of [`ROWS_PER_TASK`] rows for a large problem.
    fn gradients(
        &self,
        x: &DVector<f64>,
        prepared: &[PreparedLeg<'a>],
        solution: impl Fn(usize) -> (Solution, Option<[f64; 6]>) + Sync,
    ) -> Vec<f64> {
        let width = self.gradient_stride();
        let shared = self.shared_values(x);
        let mut gradients = vec![0.0; self.blocks.len() * width];
        let task = |(chunk, rows): (usize, &mut [f64])| {
            for (k, gradient) in rows.chunks_mut(width).enumerate() {
                let index = chunk * ROWS_PER_TASK + k;
                let leg = self.prepared_leg(prepared, index);
                let (solution, pose) = solution(index);
                let placed = match pose {
                    Some(pose) => Placed::at(pose),
                    None => self.placed(index, &shared),
                };
                self.reading_and_gradient((leg, index), (&placed, &solution), &shared, gradient);
            }
        };
        if self.blocks.len() <= ROWS_PER_TASK {
            task((0, &mut gradients[..]));
        } else {
            gradients
                .par_chunks_mut(ROWS_PER_TASK * width)
                .enumerate()
                .for_each(task);
        }
        gradients
    }

    /// How many rows' inverse kinematics this problem and its clones have solved so far (a
    /// row solved at several evaluations counts each time): the cost of its evaluations, which
    /// reuse what they can. An evaluation at unknowns where one is kept solves no row; a
    /// Jacobian where the residuals were last evaluated needs the derivative passes only.
    pub fn row_solves(&self) -> u64 {
        self.lock().row_solves
    }

    /// The evaluations kept for reuse (at most two) and how many of them hold their gradients
    /// (at most one: an older evaluation's are freed before another's are computed): what the
    /// problem holds in memory besides its blocks and its seeds.
    pub fn kept_evaluations(&self) -> (usize, usize) {
        let state = self.lock();
        let with_gradients = state.recent.iter().filter(|e| !e.gradients.is_empty());
        (state.recent.len(), with_gradients.count())
    }

    /// Forgets the kept evaluations but the newest, and that one's gradients (kept: its
    /// solutions and predicted readings): after a fit, once the residuals and the Jacobian at
    /// the estimate are taken, the statistics need no more (a large problem's gradients are
    /// as large as its Jacobian).
    pub fn release_gradients(&self) {
        let mut state = self.lock();
        state.recent.truncate(1);
        if let Some(newest) = state.recent.first_mut() {
            newest.gradients = Vec::new();
        }
    }

    /// As [`Self::map_solved`], for a `row` that reads of a solution only its joints and the
    /// actuated joint's row of its closure inverse (a pose gradient): where the problem's last
    /// solve was at exactly `x` and it keeps no full solutions (a large problem), they are its
    /// seeds ([`seed_solution`]), and no row is solved again.
    ///
    /// # Errors
    /// As [`Self::map_solved`].
    pub fn map_seeded<R: Send>(
        &self,
        x: &DVector<f64>,
        row: impl Fn(usize, &PreparedLeg<'a>, &Solution) -> R + Sync,
    ) -> Result<Vec<R>, BlockError> {
        let key = key(x);
        let seeded = {
            let state = self.lock();
            let kept = state
                .recent
                .iter()
                .any(|e| e.x == key && !e.solutions.is_empty());
            !kept && !self.blocks.is_empty() && state.solved == key
        };
        if !seeded {
            return self.map_solved(x, |index, leg, _, solution| row(index, leg, solution));
        }
        let state = self.lock();
        let prepared = self.prepare(x, false);
        let seeds = &state.seeds;
        let task = |rows: std::ops::Range<usize>| {
            rows.map(|index| {
                let leg = self.prepared_leg(&prepared, index);
                let seed = &seeds.values[index * seeds.stride..];
                row(index, leg, &seed_solution(seed, leg.leg()))
            })
            .collect::<Vec<R>>()
        };
        let results: Vec<Vec<R>> = self.row_chunks().map(task).collect();
        Ok(results.into_iter().flatten().collect())
    }

    /// The blocks' indices in chunks of [`ROWS_PER_TASK`], in parallel.
    fn row_chunks(&self) -> impl IndexedParallelIterator<Item = std::ops::Range<usize>> + '_ {
        let rows = self.blocks.len();
        (0..rows.div_ceil(ROWS_PER_TASK))
            .into_par_iter()
            .map(move |chunk| chunk * ROWS_PER_TASK..((chunk + 1) * ROWS_PER_TASK).min(rows))
    }

    /// Calls `row` with every block's index, its slot's leg prepared at the unknowns `x`
    /// (without derivative columns), its platform pose and transform and its
    /// inverse-kinematics solution at `x`, in row order: the kept solutions of an evaluation at
    /// `x`, or solved again warm-started from the last ones (at `x` itself after a solve there:
    /// one Newton check per row). In parallel chunks of 512 rows for a large problem.
    ///
    /// # Errors
    /// The first block (in row order) whose leg cannot reach its pose.
    pub fn map_solved<R: Send>(
        &self,
        x: &DVector<f64>,
        row: impl Fn(usize, &PreparedLeg<'a>, &Placed, &Solution) -> R + Sync,
    ) -> Result<Vec<R>, BlockError> {
        let key = key(x);
        let mut state = self.lock();
        let kept = state
            .recent
            .iter()
            .find(|e| e.x == key && !e.solutions.is_empty());
        let solves = if kept.is_some() { 0 } else { self.blocks.len() };
        let prepared = self.prepare(x, false);
        let shared = self.shared_values(x);
        let home = &self.mechanism.home_pose;
        let seeds = &state.seeds;
        let task = |rows: std::ops::Range<usize>| {
            rows.map(|index| {
                let leg = self.prepared_leg(&prepared, index);
                let placed = match kept.and_then(|e| e.poses.get(index)) {
                    Some(&pose) => Placed::at(pose),
                    None => self.placed(index, &shared),
                };
                let solution = match kept {
                    Some(evaluation) => evaluation.solutions[index],
                    None => leg
                        .solve_warm_on(
                            &placed.platform,
                            &placed.pose,
                            home,
                            seed_joints(&seeds.values[index * seeds.stride..], leg.leg()).as_ref(),
                        )
                        .map_err(|source| (index, source))?,
                };
                Ok(row(index, leg, &placed, &solution))
            })
            .collect::<Result<Vec<R>, (usize, KinematicsError)>>()
        };
        let results: Vec<_> = self.row_chunks().map(task).collect();
        let mut values = Vec::with_capacity(self.blocks.len());
        for result in results {
            match result {
                Ok(mut chunk) => values.append(&mut chunk),
                Err((index, source)) => return Err(self.block_error(index, source, x)),
            }
        }
        state.row_solves += solves as u64;
        Ok(values)
    }
}
