//! The 3-D maximal inscribed workspace of a spatial mechanism at its home orientation: the
//! largest ball about the home position inside the singularity-free region of the home working
//! and assembly modes (every leg reaches the point on its home branch, every serial measure and
//! the parallel measure keep their home sign; see [`crate::kinematics::singularity`]).
//!
//! Method, the ray idea of the planar MIW ([`super::miw`]): rays are cast from the home position
//! in directions spread evenly over the sphere (a Fibonacci lattice); along each the legs are
//! continued step by step until the margin vanishes, then the crossing is bisected to 1e-10 m. The
//! ball's radius is the nearest crossing, then shrunk until a denser set of points on its surface
//! (four times the rays) is inside: it never reaches between rays into a dent. Unlike the planar
//! MIW the centre is not optimised: it stays at the home position.
//! A ray that meets no boundary within [`REACH`] region sizes stops there.

use rayon::prelude::*;

use crate::error::{Error, KinematicsError, Result};
use crate::kinematics::inverse::{solve_leg, solve_leg_from, LegSolution};
use crate::kinematics::singularity::ParallelMeasure;
use crate::model::Mechanism;

/// How far a ray marches at most, in sizes of the usable region (its largest side).
pub const REACH: f64 = 20.0;

/// Options of the 3-D MIW computation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Miw3dOptions {
    /// Rays cast from the home position.
    pub rays: usize,
    /// Marching step along a ray, metres.
    pub step: f64,
}

impl Miw3dOptions {
    /// Defaults scaled to the mechanism: 400 rays, a step of 1/50 of the usable region's size.
    pub fn for_mechanism(mechanism: &Mechanism) -> Self {
        Self {
            rays: 400,
            step: region_size(mechanism) / 50.0,
        }
    }
}

/// The largest side of the usable region's bounding box (x, y, z), metres.
pub fn region_size(mechanism: &Mechanism) -> f64 {
    let region = &mechanism.workspace.region;
    let (lo, hi) = region.bounds();
    let z = region.z_bounds().map_or(0.0, |[low, high]| high - low);
    (hi[0] - lo[0]).max(hi[1] - lo[1]).max(z)
}

/// The 3-D MIW.
#[derive(Debug, Clone, PartialEq)]
pub struct Miw3d {
    /// Centre of the ball (the home position), metres.
    pub centre: [f64; 3],
    /// Its radius, metres.
    pub radius: f64,
    /// The boundary crossing along each ray, metres.
    pub boundary: Vec<[f64; 3]>,
}

/// The singularity margin of a spatial mechanism at points, orientation held at home.
#[derive(Debug, Clone)]
pub struct SpatialMargin<'a> {
    mechanism: &'a Mechanism,
    parallel: ParallelMeasure<'a>,
}

impl<'a> SpatialMargin<'a> {
    /// The margin for the nominal parameters.
    ///
    /// # Errors
    /// The parallel measure is undefined for the mechanism.
    pub fn new(mechanism: &'a Mechanism) -> Result<Self> {
        let parallel = ParallelMeasure::new(mechanism, mechanism.nominal_parameters())?;
        Ok(Self {
            mechanism,
            parallel,
        })
    }

    /// The pose at point `p` (orientation at home).
    pub fn pose(&self, p: [f64; 3]) -> [f64; 6] {
        let mut pose = self.mechanism.home_pose;
        pose[..3].copy_from_slice(&p);
        pose
    }

    /// The margin at `p` (smallest of the serial measures and the parallel measure, signed by
    /// the home modes) with the legs' solutions, each leg solved from `seeds` when given, else
    /// from home.
    ///
    /// # Errors
    /// A leg cannot reach `p` on its home branch.
    pub fn margin_from(
        &self,
        p: [f64; 3],
        seeds: Option<&[LegSolution]>,
    ) -> Result<(f64, Vec<LegSolution>), KinematicsError> {
        let pose = self.pose(p);
        let mechanism = self.mechanism;
        let mut solutions = Vec::with_capacity(mechanism.legs.len());
        let mut serial = f64::INFINITY;
        for (l, (leg, geometry)) in mechanism
            .legs
            .iter()
            .zip(self.parallel.geometries())
            .enumerate()
        {
            let solution = match seeds {
                Some(seeds) => solve_leg_from(leg, geometry, &pose, &seeds[l].q)?,
                None => solve_leg(leg, geometry, &pose, &mechanism.home_pose)?,
            };
            serial = serial.min(solution.normalised_determinant * leg.branch_sign);
            solutions.push(solution);
        }
        let parallel = self.parallel.at_solutions(&pose, &solutions)?;
        Ok((serial.min(parallel), solutions))
    }

    /// The margin at `p` solved from home: positive inside the singularity-free region, −1
    /// where a leg cannot reach.
    pub fn at(&self, p: [f64; 3]) -> f64 {
        self.margin_from(p, None).map_or(-1.0, |(m, _)| m)
    }

    fn continued(&self, p: [f64; 3], seeds: &[LegSolution]) -> Option<Vec<LegSolution>> {
        match self.margin_from(p, Some(seeds)) {
            Ok((margin, solutions)) if margin > 0.0 => Some(solutions),
            _ => None,
        }
    }
}

/// `count` unit directions spread evenly over the sphere (Fibonacci lattice).
pub fn sphere_directions(count: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5.0_f64.sqrt());
    (0..count)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let angle = golden * k as f64;
            [r * angle.cos(), r * angle.sin(), z]
        })
        .collect()
}

/// Computes the 3-D MIW of a spatial mechanism at its home orientation.
///
/// # Errors
/// The home position is not inside a singularity-free region, or the measures are undefined.
pub fn spatial_inscribed_workspace(mechanism: &Mechanism, options: Miw3dOptions) -> Result<Miw3d> {
    let (margin, centre, start) = home_start(mechanism)?;
    let limit = REACH * region_size(mechanism);
    let boundary: Vec<[f64; 3]> = sphere_directions(options.rays)
        .into_par_iter()
        .map(|d| boundary_along_ray(&margin, centre, &start, d, options.step, limit))
        .collect();
    let mut radius = boundary
        .iter()
        .map(|p| distance(p, &centre))
        .fold(f64::INFINITY, f64::min);
    let check = sphere_directions(4 * options.rays);
    for _ in 0..200 {
        let inside = check.par_iter().all(|d| {
            let p = std::array::from_fn(|k| centre[k] + radius * d[k]);
            margin.at(p) > 0.0
        });
        if inside {
            break;
        }
        radius *= 0.99;
    }
    Ok(Miw3d {
        centre,
        radius,
        boundary,
    })
}

/// The margin, the home position and the legs solved there.
///
/// # Errors
/// The home position is not inside a singularity-free region.
fn home_start(mechanism: &Mechanism) -> Result<(SpatialMargin<'_>, [f64; 3], Vec<LegSolution>)> {
    let margin = SpatialMargin::new(mechanism)?;
    let centre = [
        mechanism.home_pose[0],
        mechanism.home_pose[1],
        mechanism.home_pose[2],
    ];
    let start = match margin.margin_from(centre, None) {
        Ok((m, solutions)) if m > 0.0 => solutions,
        _ => {
            return Err(Error::Invalid(format!(
                "{}: the home pose is not inside a singularity-free region",
                mechanism.model_path.display()
            )))
        }
    };
    Ok((margin, centre, start))
}

/// The boundary of the singularity-free region in the horizontal plane through the home
/// position (orientation at home), along `rays` rays in that plane: the `(x, y)` crossings.
///
/// # Errors
/// As [`spatial_inscribed_workspace`].
pub fn horizontal_slice(
    mechanism: &Mechanism,
    options: Miw3dOptions,
    rays: usize,
) -> Result<Vec<[f64; 2]>> {
    let (margin, centre, start) = home_start(mechanism)?;
    let limit = REACH * region_size(mechanism);
    Ok((0..rays)
        .into_par_iter()
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / rays as f64;
            let d = [angle.cos(), angle.sin(), 0.0];
            let p = boundary_along_ray(&margin, centre, &start, d, options.step, limit);
            [p[0], p[1]]
        })
        .collect())
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The first boundary crossing along direction `d` from `centre` (legs solved there: `start`):
/// march by `step` up to `limit`, then bisect to 1e-10 m.
fn boundary_along_ray(
    margin: &SpatialMargin<'_>,
    centre: [f64; 3],
    start: &[LegSolution],
    d: [f64; 3],
    step: f64,
    limit: f64,
) -> [f64; 3] {
    let at = |t: f64| std::array::from_fn(|k| centre[k] + t * d[k]);
    let (mut inside, mut outside) = (0.0, step);
    let mut seeds = start.to_vec();
    loop {
        if inside >= limit {
            return at(inside);
        }
        match margin.continued(at(outside), &seeds) {
            Some(solutions) => seeds = solutions,
            None => break,
        }
        inside = outside;
        outside += step;
    }
    while outside - inside > 1e-10 {
        let middle = 0.5 * (inside + outside);
        match margin.continued(at(middle), &seeds) {
            Some(solutions) => {
                seeds = solutions;
                inside = middle;
            }
            None => outside = middle,
        }
    }
    at(inside)
}
