//! The maximal inscribed workspace (MIW): the largest disc inside the singularity-free region
//! of the home working and assembly modes (Liu, Wang & Pritschow 2006), for a mechanism whose
//! end-effector point is measured in x, y (other coordinates held at their home values).
//!
//! Method: the region is `{P : every leg reaches P on its home branch with its joints within
//! their URDF limits, every serial measure > 0, the parallel measure > 0}` (signed by the home modes, see
//! [`crate::kinematics::singularity`]). Its boundary is found along rays cast from a centre
//! (march, then bisection to 1e-12 m), joined into a closed parry polyline; the radius of the
//! disc about `c` is the distance from `c` to that polyline. Nelder–Mead (argmin) maximises it;
//! the rays are re-cast from the new centre until the centre settles.

use argmin::core::{CostFunction, Error as ArgminError, Executor, State};
use argmin::solver::neldermead::NelderMead;
use nalgebra::Vector2;

use super::limits::check_limits;
use super::region::geometry;
use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::inverse::{solve_leg, solve_leg_from, LegSolution};
use crate::kinematics::singularity::ParallelMeasure;
use crate::model::Mechanism;
use crate::progress::Work;

/// Options of the MIW computation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MiwOptions {
    /// Rays cast per pass.
    pub rays: usize,
    /// Marching step along a ray, metres (the bisection then refines to 1e-12 m).
    pub step: f64,
}

impl MiwOptions {
    /// Defaults scaled to the mechanism: 1440 rays, a step of 1/200 of the usable region's size.
    pub fn for_mechanism(mechanism: &Mechanism) -> Self {
        let (lo, hi) = mechanism.workspace.region.bounds();
        Self {
            rays: 1440,
            step: (hi[0] - lo[0]).max(hi[1] - lo[1]) / 200.0,
        }
    }
}

/// The singularity-free region, sampled.
#[derive(Debug, Clone, PartialEq)]
pub struct Miw {
    /// Centre of the maximal inscribed circle, metres.
    pub centre: [f64; 2],
    /// Its radius, metres.
    pub radius: f64,
    /// Boundary points of the singularity-free region seen from the centre, metres.
    pub boundary: Vec<[f64; 2]>,
}

/// How far inside the singularity-free region a point is, as a scale-free measure: the smallest
/// of the legs' serial measures and the parallel measure; −1 where a leg cannot reach.
#[derive(Debug, Clone)]
pub struct SingularityMargin<'a> {
    mechanism: &'a Mechanism,
    parallel: ParallelMeasure<'a>,
    plane: [usize; 2],
}

impl<'a> SingularityMargin<'a> {
    /// The margin function for the nominal parameters.
    ///
    /// # Errors
    /// The home pose is singular or unreachable, or the parallel measure is undefined.
    pub fn new(mechanism: &'a Mechanism) -> Result<Self> {
        let parallel = ParallelMeasure::new(mechanism, mechanism.nominal_parameters())?;
        Ok(Self {
            mechanism,
            parallel,
            plane: [0, 1],
        })
    }

    /// The mechanism.
    pub fn mechanism(&self) -> &'a Mechanism {
        self.mechanism
    }

    /// The same margin on the plane through the home pose spanned by the pose coordinates
    /// `axes` (e.g. `[0, 2]`: x and z), which 2-D points then address; `[0, 1]` (x, y) is the
    /// default.
    #[must_use]
    pub fn in_plane(mut self, axes: [usize; 2]) -> Self {
        self.plane = axes;
        self
    }

    /// The pose at point `p`: a 2-D point on the margin's plane ([`Self::in_plane`]; x, y by
    /// default), or x, y, z for a 3-D point; the other coordinates at home.
    pub fn pose<const D: usize>(&self, p: [f64; D]) -> [f64; 6] {
        let mut pose = self.mechanism.home_pose;
        if D == 2 {
            pose[self.plane[0]] = p[0];
            pose[self.plane[1]] = p[1];
        } else {
            pose[..D].copy_from_slice(&p);
        }
        pose
    }

    /// `(smallest serial measure, parallel measure)` at `p`, or an error where a leg fails.
    ///
    /// # Errors
    /// A leg cannot reach `p` on its home branch.
    pub fn measures<const D: usize>(&self, p: [f64; D]) -> Result<(f64, f64), KinematicsError> {
        self.measures_from(p, None).map(|(measures, _)| measures)
    }

    /// As [`Self::measures`], solving each leg by Newton from `seeds` (the legs' joints at a
    /// nearby point: a continuation step) when given, else from home; also returns the
    /// solutions, to seed the next step.
    ///
    /// # Errors
    /// A leg cannot reach `p` on its home branch, or only with a joint beyond its limits.
    pub fn measures_from<const D: usize>(
        &self,
        p: [f64; D],
        seeds: Option<&[LegSolution]>,
    ) -> Result<((f64, f64), Vec<LegSolution>), KinematicsError> {
        let pose = self.pose(p);
        let mechanism = self.mechanism;
        let mut solutions = Vec::with_capacity(mechanism.legs.len());
        let mut serial = f64::INFINITY;
        let geometries = self.parallel.geometries();
        for (l, (leg, geometry)) in mechanism.legs.iter().zip(geometries).enumerate() {
            let solution = match seeds {
                Some(seeds) => solve_leg_from(leg, geometry, &pose, &seeds[l].q)?,
                None => solve_leg(leg, geometry, &pose, &mechanism.home_pose)?,
            };
            check_limits(leg, &solution.q)?;
            serial = serial.min(leg.home_branch_measure(solution.normalised_determinant));
            solutions.push(solution);
        }
        let parallel = self.parallel.at_solutions(&pose, &solutions)?;
        Ok(((serial, parallel), solutions))
    }

    /// The margin at `p`: positive inside the singularity-free region.
    pub fn at<const D: usize>(&self, p: [f64; D]) -> f64 {
        self.measures(p)
            .map_or(-1.0, |(serial, parallel)| serial.min(parallel))
    }

    /// The legs' solutions at `p` solved from `seeds` (from home for none), if `p` is strictly
    /// inside the singularity-free region.
    pub(super) fn continued<const D: usize>(
        &self,
        p: [f64; D],
        seeds: Option<&[LegSolution]>,
    ) -> Option<Vec<LegSolution>> {
        match self.measures_from(p, seeds) {
            Ok(((serial, parallel), solutions)) if serial.min(parallel) > 0.0 => Some(solutions),
            _ => None,
        }
    }
}

/// At most this many passes of rays, each from the last pass's best centre.
const MIW_PASSES: usize = 4;

/// Computes the MIW of a mechanism measured in x and y.
///
/// # Errors
/// The home point is not inside a singularity-free region, or the measures are undefined.
pub fn maximal_inscribed_workspace(mechanism: &Mechanism, options: MiwOptions) -> Result<Miw> {
    let margin = SingularityMargin::new(mechanism)?;
    let mut centre = [mechanism.home_pose[0], mechanism.home_pose[1]];
    if margin.at(centre) <= 0.0 {
        return Err(Error::Invalid(format!(
            "{}: the home pose is not inside a singularity-free region",
            mechanism.model_path.display()
        )));
    }
    let mut result = None;
    for pass in 0..MIW_PASSES {
        let boundary = cast_rays(&margin, centre, options, MIW_PASSES - pass)?;
        let polyline = geometry::closed_polyline(&boundary);
        let radius_at = |c: [f64; 2]| {
            if margin.at(c) > 0.0 {
                geometry::distance_to(&polyline, c)
            } else {
                0.0
            }
        };
        let best = maximise(&radius_at, centre, options.step)?;
        let moved = ((best[0] - centre[0]).powi(2) + (best[1] - centre[1]).powi(2)).sqrt();
        centre = best;
        let radius = radius_at(best);
        result = Some(Miw {
            centre,
            radius,
            boundary,
        });
        if moved < 1e-9 {
            break;
        }
    }
    result.ok_or_else(|| Error::Invalid("MIW: no pass ran".into()))
}

/// The first boundary crossing along each of `options.rays` rays from `centre`, continuing the
/// legs' solutions step by step along the ray: march by `options.step`, then bisect to 1e-12 m.
/// The rays are independent: they are cast in parallel (rayon), collected in ray order.
fn cast_rays(
    margin: &SingularityMargin<'_>,
    centre: [f64; 2],
    options: MiwOptions,
    passes: usize,
) -> Result<Vec<[f64; 2]>> {
    let Ok((_, start)) = margin.measures_from(centre, None) else {
        return Err(Error::Invalid("MIW: a leg cannot reach the centre".into()));
    };
    let work = Work {
        label: "workspace: casting rays",
        total: options.rays,
        items: "rays",
        passes,
    };
    Ok(work.map(|k| {
        let angle = std::f64::consts::TAU * k as f64 / options.rays as f64;
        let direction = [angle.cos(), angle.sin()];
        let at = |t: f64| [centre[0] + t * direction[0], centre[1] + t * direction[1]];
        let march = (options.step, f64::INFINITY, 200_000);
        crossing(margin, at, &start, march, 1e-12)
    }))
}

/// The first boundary crossing along the ray `at(t)`, t ≥ 0, continuing the legs' solutions
/// from `start` (at `at(0)`): march by `step` until the margin vanishes (at most `max_steps`
/// steps; a ray still inside at `t` = `limit` stops there), then bisect to `tolerance`.
pub(super) fn crossing<const D: usize>(
    margin: &SingularityMargin<'_>,
    at: impl Fn(f64) -> [f64; D],
    start: &[LegSolution],
    (step, limit, max_steps): (f64, f64, usize),
    tolerance: f64,
) -> [f64; D] {
    let (mut inside, mut outside) = (0.0, step);
    let mut seeds = start.to_vec();
    for _ in 0..max_steps {
        if inside >= limit {
            return at(inside);
        }
        match margin.continued(at(outside), Some(&seeds)) {
            Some(solutions) => seeds = solutions,
            None => break,
        }
        inside = outside;
        outside += step;
    }
    while outside - inside > tolerance {
        let middle = 0.5 * (inside + outside);
        match margin.continued(at(middle), Some(&seeds)) {
            Some(solutions) => {
                seeds = solutions;
                inside = middle;
            }
            None => outside = middle,
        }
    }
    at(inside)
}

struct NegativeRadius<'f> {
    radius: &'f dyn Fn([f64; 2]) -> f64,
}

impl CostFunction for NegativeRadius<'_> {
    type Param = Vector2<f64>;
    type Output = f64;

    fn cost(&self, c: &Self::Param) -> Result<f64, ArgminError> {
        Ok(-(self.radius)([c[0], c[1]]))
    }
}

fn maximise(radius: &dyn Fn([f64; 2]) -> f64, start: [f64; 2], scale: f64) -> Result<[f64; 2]> {
    let simplex = vec![
        Vector2::new(start[0], start[1]),
        Vector2::new(start[0] + 5.0 * scale, start[1]),
        Vector2::new(start[0], start[1] + 5.0 * scale),
    ];
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(1e-15)
        .map_err(|e| Error::Invalid(format!("MIW: {e}")))?;
    let result = Executor::new(NegativeRadius { radius }, solver)
        .configure(|state| state.max_iters(2000))
        .run()
        .map_err(|e| Error::Invalid(format!("MIW: {e}")))?;
    let best = result
        .state()
        .get_best_param()
        .copied()
        .unwrap_or(Vector2::new(start[0], start[1]));
    Ok([best[0], best[1]])
}
