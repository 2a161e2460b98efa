//! The 3-D maximal inscribed workspace of a spatial mechanism at its home orientation: the
//! largest ball about the home position inside the singularity-free region of the home working
//! and assembly modes (every leg reaches the point on its home branch with its joints within
//! their URDF limits, every serial measure and the parallel measure keep their home sign; see
//! [`crate::kinematics::singularity`] and [`super::limits`]).
//!
//! Method, the ray idea of the planar MIW ([`super::miw`]): rays are cast from the home position
//! in directions spread evenly over the sphere (a Fibonacci lattice); along each the legs are
//! continued step by step until the margin vanishes, then the crossing is bisected to 1e-10 m. The
//! ball's radius is the nearest crossing, then shrunk until a denser set of points on its surface
//! (four times the rays) is inside: it never reaches between rays into a dent. Unlike the planar
//! MIW the centre is not optimised: it stays at the home position.
//! A ray that meets no boundary within [`REACH`] region sizes stops there. A model whose
//! instrument has a touch surface (a bed probe) bounds the ball by it too: the target cannot go
//! through the bed ([`super::touch_surface`]).

use rayon::prelude::*;

use super::miw::{crossing, SingularityMargin};
use super::touch_surface::{touch_surfaces, TouchSurface};
use crate::error::{Error, Result};
use crate::kinematics::inverse::LegSolution;
use crate::model::Mechanism;
use crate::progress::Work;

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
    /// The radius of the singularity-free ball alone, before the touch surfaces bound it.
    pub singularity_free_radius: f64,
    /// The instrument's touch surfaces, seen from the centre.
    pub surfaces: Vec<TouchSurface>,
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
    let directions = sphere_directions(options.rays);
    let work = Work {
        label: "workspace: casting rays",
        total: directions.len(),
        items: "rays",
        passes: 1,
    };
    let boundary: Vec<[f64; 3]> = work
        .map(|k| boundary_along_ray(&margin, centre, &start, directions[k], options.step, limit));
    let mut radius = boundary
        .iter()
        .map(|p| distance(p, &centre))
        .fold(f64::INFINITY, f64::min);
    let check = sphere_directions(4 * options.rays);
    for _ in 0..200 {
        let inside = check.par_iter().all(|d| {
            let p: [f64; 3] = std::array::from_fn(|k| centre[k] + radius * d[k]);
            margin.at(p) > 0.0
        });
        if inside {
            break;
        }
        radius *= 0.99;
    }
    let surfaces = touch_surfaces(mechanism, centre);
    let nearest = surfaces
        .iter()
        .map(TouchSurface::clearance)
        .fold(f64::INFINITY, f64::min);
    Ok(Miw3d {
        centre,
        radius: radius.min(nearest),
        boundary,
        singularity_free_radius: radius,
        surfaces,
    })
}

/// The margin, the home position and the legs solved there.
///
/// # Errors
/// The home position is not inside a singularity-free region.
fn home_start(
    mechanism: &Mechanism,
) -> Result<(SingularityMargin<'_>, [f64; 3], Vec<LegSolution>)> {
    let margin = SingularityMargin::new(mechanism)?;
    let centre = [
        mechanism.home_pose[0],
        mechanism.home_pose[1],
        mechanism.home_pose[2],
    ];
    let Some(start) = margin.continued(centre, None) else {
        return Err(Error::Invalid(format!(
            "{}: the home pose is not inside a singularity-free region",
            mechanism.model_path.display()
        )));
    };
    Ok((margin, centre, start))
}

/// The boundary of the singularity-free region in the plane through the home position spanned
/// by the position coordinates `axes` (`[0, 1]`: x–y, `[0, 2]`: x–z, `[1, 2]`: y–z; orientation
/// at home), along `rays` rays in that plane: the crossings in those two coordinates.
///
/// # Errors
/// As [`spatial_inscribed_workspace`].
pub fn slice(
    mechanism: &Mechanism,
    options: Miw3dOptions,
    axes: [usize; 2],
    rays: usize,
) -> Result<Vec<[f64; 2]>> {
    let (margin, centre, start) = home_start(mechanism)?;
    let limit = REACH * region_size(mechanism);
    Ok((0..rays)
        .into_par_iter()
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / rays as f64;
            let mut d = [0.0; 3];
            d[axes[0]] = angle.cos();
            d[axes[1]] = angle.sin();
            let p = boundary_along_ray(&margin, centre, &start, d, options.step, limit);
            [p[axes[0]], p[axes[1]]]
        })
        .collect())
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

/// The first boundary crossing along direction `d` from `centre` (legs solved there: `start`):
/// march by `step` up to `limit`, then bisect to 1e-10 m.
fn boundary_along_ray(
    margin: &SingularityMargin<'_>,
    centre: [f64; 3],
    start: &[LegSolution],
    d: [f64; 3],
    step: f64,
    limit: f64,
) -> [f64; 3] {
    let at = |t: f64| std::array::from_fn(|k| centre[k] + t * d[k]);
    crossing(margin, at, start, (step, limit, usize::MAX), 1e-10)
}
