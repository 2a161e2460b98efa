//! The geometry of the workspace region and of the usable workspace, which
//! [`crate::model`] declares as data: signed depths and containment (through parry2d /
//! parry3d, called nowhere else in legwise), sampling, and the checks of a loaded model that
//! need them (a polyhedron encloses a volume, the margin leaves a usable region).

mod planar;
mod solid;

use std::path::Path;

use rand::Rng;

use crate::error::{Error, Result};
pub use crate::model::region::Region;
pub use crate::model::workspace::{Workspace, DEFAULT_RANGE_LEVELS, DEFAULT_SINGULARITY_THRESHOLD};

/// The planar parry queries the MIW uses.
pub(crate) mod geometry {
    pub(crate) use super::planar::{closed_polyline, distance_to};
}

impl Region {
    /// Signed distance from `point` `[x, y, z]` to the boundary: positive inside, metres. A
    /// planar region ignores z (it is a prism along z).
    pub fn depth(&self, point: [f64; 3]) -> f64 {
        let planar = [point[0], point[1]];
        match self {
            Region::Disc { centre, radius } => planar::disc_depth(*centre, *radius, planar),
            Region::Box { min, max } => planar::box_depth(*min, *max, planar),
            Region::Polygon { vertices } => planar::polygon_depth(vertices, planar),
            Region::Ball { centre, radius } => solid::ball_depth(*centre, *radius, point),
            Region::Cuboid { min, max } => solid::cuboid_depth(*min, *max, point),
            Region::Cylinder {
                centre,
                radius,
                height,
            } => solid::cylinder_depth(*centre, *radius, *height, point),
            Region::Polyhedron { vertices } => solid::polyhedron_depth(vertices, point),
        }
    }

    /// Do the polyhedron's vertices span a volume? (True for the other regions.)
    pub fn encloses_volume(&self) -> bool {
        match self {
            Region::Polyhedron { vertices } => solid::convex_hull(vertices).is_some(),
            _ => true,
        }
    }
}

impl Workspace {
    /// Is the pose inside the region, at least `margin` from its boundary, and within the ranges?
    pub fn contains(&self, pose: &[f64; 6]) -> bool {
        // 1e-12 m: grid points exactly on the usable boundary stay in despite round-off.
        self.region.depth([pose[0], pose[1], pose[2]]) >= self.margin - 1e-12
            && self
                .ranges
                .iter()
                .zip(pose)
                .all(|(range, value)| range.is_none_or(|[lo, hi]| (lo..=hi).contains(value)))
    }

    /// A uniformly random pose of the usable workspace (x, y — and z for a spatial region — by
    /// rejection in the bounding box, the ranged coordinates uniform, the others at `home`);
    /// `None` if 100 000 draws all fell outside (an empty usable workspace).
    pub fn sample(&self, home: &[f64; 6], rng: &mut impl Rng) -> Option<[f64; 6]> {
        let (lo, hi) = self.region.bounds();
        let z_bounds = self.region.z_bounds();
        for _ in 0..100_000 {
            let mut pose = *home;
            pose[0] = rng.random_range(lo[0]..=hi[0]);
            pose[1] = rng.random_range(lo[1]..=hi[1]);
            if let Some([low, high]) = z_bounds {
                pose[2] = rng.random_range(low..=high);
            }
            for (value, range) in pose.iter_mut().zip(&self.ranges).skip(2) {
                if let Some([min, max]) = range {
                    *value = rng.random_range(*min..=*max);
                }
            }
            if self.contains(&pose) {
                return Some(pose);
            }
        }
        None
    }
}

/// The checks of a validated workspace that need its geometry: a polyhedron's vertices must
/// enclose a volume, and the margin must leave a usable region. Errors name `model_path` and
/// the field.
///
/// # Errors
/// [`Error::Model`] on `workspace.region.polyhedron` or `workspace.margin`.
pub fn check_usable(workspace: &Workspace, model_path: &Path) -> Result<()> {
    let error = |field: &str, message: String| Error::Model {
        path: model_path.to_path_buf(),
        field: field.into(),
        message,
    };
    let region = &workspace.region;
    if matches!(region, Region::Polyhedron { .. }) && !region.encloses_volume() {
        return Err(error(
            "workspace.region.polyhedron",
            "the vertices enclose no volume (they are coplanar): expected the corners of a solid"
                .into(),
        ));
    }
    let margin = workspace.margin;
    let (lo, hi) = region.bounds();
    let [z_lo, z_hi] = region.z_bounds().unwrap_or([0.0, f64::INFINITY]);
    let smallest = (hi[0] - lo[0]).min(hi[1] - lo[1]).min(z_hi - z_lo);
    let centre = [
        (lo[0] + hi[0]) / 2.0,
        (lo[1] + hi[1]) / 2.0,
        if z_hi.is_finite() {
            (z_lo + z_hi) / 2.0
        } else {
            0.0
        },
    ];
    let usable = margin * 2.0 < smallest
        && (region.depth(centre) >= margin || {
            // A non-convex polygon may not contain its bounding box's centre: try a few points.
            use rand::SeedableRng;
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
            workspace.sample(&[0.0; 6], &mut rng).is_some()
        });
    if !usable {
        return Err(error(
            "workspace.margin",
            format!(
                "the margin ({} m) leaves no usable region",
                if margin < 1e6 {
                    margin.to_string()
                } else {
                    format!("{margin:e}")
                }
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::workspace::{DEFAULT_RANGE_LEVELS, DEFAULT_SINGULARITY_THRESHOLD};

    #[test]
    fn depth_is_positive_inside_and_measures_the_distance_to_the_boundary() {
        let disc = Region::Disc {
            centre: [0.0, 1.0],
            radius: 0.5,
        };
        assert!((disc.depth([0.0, 1.2, 7.0]) - 0.3).abs() < 1e-12);
        assert!(
            (disc.depth([0.0, 1.0, 0.0]) - 0.5).abs() < 1e-12,
            "the exact centre"
        );
        assert!(disc.depth([0.0, 2.0, 0.0]) < 0.0);
        let square = Region::Box {
            min: [0.0, 0.0],
            max: [1.0, 2.0],
        };
        assert!((square.depth([0.25, 1.0, 0.0]) - 0.25).abs() < 1e-12);
        let triangle = Region::Polygon {
            vertices: vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]],
        };
        assert!((triangle.depth([0.5, 0.25, 0.0]) - 0.25).abs() < 1e-12);
        assert!((triangle.depth([2.0, 2.0, 0.0]) + 2.0f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn degenerate_polyhedra_enclose_no_volume_and_never_panic() {
        let cases: Vec<Vec<[f64; 3]>> = vec![
            vec![[0.0; 3]; 4],
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
            vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.5, 0.5, 0.0],
            ],
            vec![
                [0.0; 3],
                [1e300, 0.0, 0.0],
                [0.0, 1e300, 0.0],
                [0.0, 0.0, 1e300],
            ],
            vec![
                [0.0; 3],
                [1e-300, 0.0, 0.0],
                [0.0, 1e-300, 0.0],
                [0.0, 0.0, 1e-300],
            ],
            vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1e-15],
            ],
        ];
        for (k, vertices) in cases.into_iter().enumerate() {
            let region = Region::Polyhedron { vertices };
            if k < 3 {
                assert!(!region.encloses_volume(), "case {k}");
            }
            let depth = region.depth([0.1, 0.1, 0.1]);
            assert!(!depth.is_nan(), "case {k}: {depth}");
        }
    }

    #[test]
    fn spatial_depths_match_closed_forms() {
        let ball = Region::Ball {
            centre: [0.0, 0.0, 1.0],
            radius: 0.5,
        };
        assert!((ball.depth([0.1, 0.2, 1.2]) - (0.5 - 0.09f64.sqrt())).abs() < 1e-12);
        assert!((ball.depth([0.0, 0.0, 2.0]) + 0.5).abs() < 1e-12);
        let cuboid = Region::Cuboid {
            min: [0.0, 0.0, 0.0],
            max: [1.0, 2.0, 3.0],
        };
        assert!((cuboid.depth([0.5, 1.0, 2.9]) - 0.1).abs() < 1e-12);
        assert!((cuboid.depth([0.5, 1.0, 3.5]) + 0.5).abs() < 1e-12);
        // Vertical axis through (1, 0), z from 0 to 2.
        let cylinder = Region::Cylinder {
            centre: [1.0, 0.0, 1.0],
            radius: 0.5,
            height: 2.0,
        };
        assert!(
            (cylinder.depth([1.3, 0.0, 1.0]) - 0.2).abs() < 1e-12,
            "side"
        );
        assert!((cylinder.depth([1.0, 0.0, 1.9]) - 0.1).abs() < 1e-12, "top");
        assert!(
            (cylinder.depth([1.0, 0.0, -0.25]) + 0.25).abs() < 1e-12,
            "below"
        );
        assert!(
            (cylinder.depth([1.0, 1.0, 1.0]) + 0.5).abs() < 1e-12,
            "beside"
        );
        // The unit cube as a polyhedron (with an inner point that is not a vertex of the hull).
        let mut corners: Vec<[f64; 3]> = (0..8)
            .map(|k| [(k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64])
            .collect();
        corners.push([0.5, 0.5, 0.5]);
        let cube = Region::Polyhedron { vertices: corners };
        assert!((cube.depth([0.5, 0.5, 0.8]) - 0.2).abs() < 1e-9);
        assert!((cube.depth([0.1, 0.5, 0.5]) - 0.1).abs() < 1e-9);
        assert!((cube.depth([0.5, 0.5, 1.3]) + 0.3).abs() < 1e-9);
        assert_eq!(cube.bounds(), ([0.0, 0.0], [1.0, 1.0]));
        assert_eq!(cube.z_bounds(), Some([0.0, 1.0]));
        assert!(cube.encloses_volume());
        // A small box far from the origin (parry's inside projection, EPA, failed on it).
        let (lo, hi) = ([-0.05, -0.05, 0.55], [0.05, 0.05, 0.65]);
        let corners = (0..8)
            .map(|k| std::array::from_fn(|i| if k >> i & 1 == 0 { lo[i] } else { hi[i] }))
            .collect();
        let as_polyhedron = Region::Polyhedron { vertices: corners };
        let as_cuboid = Region::Cuboid { min: lo, max: hi };
        assert!(as_polyhedron.encloses_volume());
        for point in [
            [0.0, 0.0, 0.6],
            [0.04, -0.01, 0.56],
            [0.0, 0.2, 0.6],
            [0.1, 0.1, 0.7],
        ] {
            let (a, b) = (as_polyhedron.depth(point), as_cuboid.depth(point));
            assert!((a - b).abs() < 1e-12, "{point:?}: {a} vs {b}");
        }
        let flat = Region::Polyhedron {
            vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
        };
        assert!(!flat.encloses_volume());
        assert_eq!(cylinder.bounds(), ([0.5, -0.5], [1.5, 0.5]));
        assert_eq!(cylinder.z_bounds(), Some([0.0, 2.0]));
        let disc = Region::Disc {
            centre: [0.0, 0.0],
            radius: 1.0,
        };
        assert_eq!(disc.z_bounds(), None);
        assert!(!disc.is_spatial() && cube.is_spatial());
    }

    fn workspace(region: Region, margin: f64, ranges: [Option<[f64; 2]>; 6]) -> Workspace {
        Workspace {
            region,
            margin,
            ranges,
            grid: None,
            range_levels: DEFAULT_RANGE_LEVELS,
            serial_threshold: DEFAULT_SINGULARITY_THRESHOLD,
            parallel_threshold: DEFAULT_SINGULARITY_THRESHOLD,
        }
    }

    #[test]
    fn samples_respect_margin_and_ranges() {
        use rand::SeedableRng;
        let mut ranges = [None; 6];
        ranges[5] = Some([-0.5, 0.5]);
        let region = Region::Disc {
            centre: [0.0, 0.0],
            radius: 0.2,
        };
        let workspace = workspace(region, 0.05, ranges);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let pose = workspace.sample(&[0.0; 6], &mut rng).unwrap();
            assert!(pose[0].hypot(pose[1]) <= 0.15 + 1e-12);
            assert!(pose[5].abs() <= 0.5);
        }
    }

    #[test]
    fn spatial_samples_fill_the_solid_and_leave_unranged_coordinates_at_home() {
        use rand::SeedableRng;
        let mut ranges = [None; 6];
        ranges[3] = Some([-0.1, 0.1]);
        let region = Region::Ball {
            centre: [0.0, 0.0, 1.0],
            radius: 0.2,
        };
        let workspace = workspace(region, 0.02, ranges);
        let home = [0.0, 0.0, 1.0, 0.0, 0.3, 0.0];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let (mut below, mut above) = (false, false);
        for _ in 0..200 {
            let pose = workspace.sample(&home, &mut rng).unwrap();
            let distance = (pose[0].powi(2) + pose[1].powi(2) + (pose[2] - 1.0).powi(2)).sqrt();
            assert!(distance <= 0.18 + 1e-12);
            assert!(pose[3].abs() <= 0.1);
            assert_eq!((pose[4], pose[5]), (0.3, 0.0));
            below |= pose[2] < 0.95;
            above |= pose[2] > 1.05;
        }
        assert!(below && above, "z varies over the ball");
    }
}
