//! The usable workspace: a planar region for the end-effector point, a safety margin, and ranges
//! for the other measured coordinates.

use parry2d_f64::shape::{Ball, Cuboid};
use parry2d_f64::utils::point_in_poly2d;
use rand::Rng;

/// A planar region in x, y (metres). Read straight from the model file (`workspace.region`:
/// `{disc: {centre, radius}}`, `{box: {min, max}}` or `{polygon: {vertices}}`); its values are
/// checked when the mechanism is validated.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum Region {
    /// A disc.
    Disc {
        /// Centre, metres.
        centre: [f64; 2],
        /// Radius, metres.
        radius: f64,
    },
    /// An axis-aligned box.
    Box {
        /// Lower corner, metres.
        min: [f64; 2],
        /// Upper corner, metres.
        max: [f64; 2],
    },
    /// A simple polygon.
    Polygon {
        /// Vertices in order, metres.
        vertices: Vec<[f64; 2]>,
    },
}

impl Region {
    /// Signed distance from `point` to the boundary: positive inside, metres (parry queries).
    pub fn depth(&self, point: [f64; 2]) -> f64 {
        match self {
            Region::Disc { centre, radius } => {
                let local = geometry::vector(point) - geometry::vector(*centre);
                geometry::signed_depth(&Ball::new(*radius), local)
            }
            Region::Box { min, max } => {
                let half = [(max[0] - min[0]) / 2.0, (max[1] - min[1]) / 2.0];
                let centre = [min[0] + half[0], min[1] + half[1]];
                let local = geometry::vector(point) - geometry::vector(centre);
                geometry::signed_depth(&Cuboid::new(geometry::vector(half)), local)
            }
            Region::Polygon { vertices } => {
                let outline = geometry::closed_polyline(vertices);
                let distance = geometry::distance_to(&outline, point);
                let corners: Vec<_> = vertices.iter().map(|v| geometry::vector(*v)).collect();
                if point_in_poly2d(geometry::vector(point), &corners) {
                    distance
                } else {
                    -distance
                }
            }
        }
    }

    /// Bounding box `(min, max)`, metres.
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        match self {
            Region::Disc { centre, radius } => (
                [centre[0] - radius, centre[1] - radius],
                [centre[0] + radius, centre[1] + radius],
            ),
            Region::Box { min, max } => (*min, *max),
            Region::Polygon { vertices } => vertices.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |(lo, hi), v| {
                    (
                        [lo[0].min(v[0]), lo[1].min(v[1])],
                        [hi[0].max(v[0]), hi[1].max(v[1])],
                    )
                },
            ),
        }
    }
}

/// parry at the boundary: conversions between `[f64; 2]` and parry's glam vectors, and the
/// shape queries. The only place in legwise that touches parry types.
pub(crate) mod geometry {
    use parry2d_f64::math::Vector;
    use parry2d_f64::query::PointQuery;
    use parry2d_f64::shape::Polyline;

    /// `[x, y]` → parry vector.
    pub(crate) fn vector(p: [f64; 2]) -> Vector {
        Vector::new(p[0], p[1])
    }

    /// Distance to the boundary of a solid shape centred at the origin, positive inside.
    pub(crate) fn signed_depth(shape: &impl PointQuery, local: Vector) -> f64 {
        let distance = unsigned_distance(shape, local);
        if shape.contains_local_point(local) {
            distance
        } else {
            -distance
        }
    }

    /// A closed polyline through `points` (last joined to first).
    pub(crate) fn closed_polyline(points: &[[f64; 2]]) -> Polyline {
        let n = points.len() as u32;
        let indices = (0..n).map(|i| [i, (i + 1) % n]).collect();
        Polyline::new(points.iter().map(|p| vector(*p)).collect(), Some(indices))
    }

    /// Distance from `point` to the polyline, metres.
    pub(crate) fn distance_to(polyline: &Polyline, point: [f64; 2]) -> f64 {
        unsigned_distance(polyline, vector(point))
    }

    /// Distance to the shape's boundary (parry's `distance_to_local_point` is signed for some
    /// shapes when not solid: use the projection instead).
    ///
    /// At a disc's exact centre parry's projection divides by zero (NaN): then the signed
    /// distance's magnitude is used.
    fn unsigned_distance(shape: &impl PointQuery, local: Vector) -> f64 {
        let distance = (local - shape.project_local_point(local, false).point).length();
        if distance.is_finite() {
            distance
        } else {
            shape.distance_to_local_point(local, false).abs()
        }
    }
}

/// The usable workspace of a mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Workspace {
    /// Region of the end-effector point in x, y.
    pub region: Region,
    /// Inward safety margin, metres.
    pub margin: f64,
    /// `[min, max]` for coordinates 2..6 (z roll pitch yaw) that vary; `None` keeps the home value.
    pub ranges: [Option<[f64; 2]>; 6],
    /// Candidate grid spacing for pose selection, metres.
    pub grid: Option<f64>,
    /// Evenly spaced values of each ranged coordinate in the candidate grid.
    pub range_levels: usize,
    /// Smallest allowed serial (type I) measure of a candidate pose.
    pub serial_threshold: f64,
    /// Smallest allowed parallel (type II) measure of a candidate pose.
    pub parallel_threshold: f64,
}

/// Default smallest serial and parallel singularity measures of a candidate pose.
pub const DEFAULT_SINGULARITY_THRESHOLD: f64 = 0.05;
/// Default number of values of each ranged coordinate in the candidate grid.
pub const DEFAULT_RANGE_LEVELS: usize = 9;

impl Workspace {
    /// Is the pose inside the region, at least `margin` from its boundary, and within the ranges?
    pub fn contains(&self, pose: &[f64; 6]) -> bool {
        // 1e-12 m: grid points exactly on the usable boundary stay in despite round-off.
        self.region.depth([pose[0], pose[1]]) >= self.margin - 1e-12
            && self
                .ranges
                .iter()
                .zip(pose)
                .all(|(range, value)| range.is_none_or(|[lo, hi]| (lo..=hi).contains(value)))
    }

    /// A uniformly random pose of the usable workspace (x, y by rejection in the bounding box,
    /// the ranged coordinates uniform, the others at `home`); `None` if 100 000 draws all fell
    /// outside (an empty usable workspace).
    pub fn sample(&self, home: &[f64; 6], rng: &mut impl Rng) -> Option<[f64; 6]> {
        let (lo, hi) = self.region.bounds();
        for _ in 0..100_000 {
            let mut pose = *home;
            pose[0] = rng.random_range(lo[0]..=hi[0]);
            pose[1] = rng.random_range(lo[1]..=hi[1]);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_is_positive_inside_and_measures_the_distance_to_the_boundary() {
        let disc = Region::Disc {
            centre: [0.0, 1.0],
            radius: 0.5,
        };
        assert!((disc.depth([0.0, 1.2]) - 0.3).abs() < 1e-12);
        assert!(
            (disc.depth([0.0, 1.0]) - 0.5).abs() < 1e-12,
            "the exact centre"
        );
        assert!(disc.depth([0.0, 2.0]) < 0.0);
        let square = Region::Box {
            min: [0.0, 0.0],
            max: [1.0, 2.0],
        };
        assert!((square.depth([0.25, 1.0]) - 0.25).abs() < 1e-12);
        let triangle = Region::Polygon {
            vertices: vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]],
        };
        assert!((triangle.depth([0.5, 0.25]) - 0.25).abs() < 1e-12);
        assert!((triangle.depth([2.0, 2.0]) + 2.0f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn samples_respect_margin_and_ranges() {
        use rand::SeedableRng;
        let mut ranges = [None; 6];
        ranges[5] = Some([-0.5, 0.5]);
        let workspace = Workspace {
            region: Region::Disc {
                centre: [0.0, 0.0],
                radius: 0.2,
            },
            margin: 0.05,
            ranges,
            grid: None,
            range_levels: DEFAULT_RANGE_LEVELS,
            serial_threshold: DEFAULT_SINGULARITY_THRESHOLD,
            parallel_threshold: DEFAULT_SINGULARITY_THRESHOLD,
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..200 {
            let pose = workspace.sample(&[0.0; 6], &mut rng).unwrap();
            assert!(pose[0].hypot(pose[1]) <= 0.15 + 1e-12);
            assert!(pose[5].abs() <= 0.5);
        }
    }
}
