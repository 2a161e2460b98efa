//! The workspace region as the model file declares it (`workspace.region`): a planar region of
//! the end-effector point in x, y (disc, box, polygon; z, when measured, comes from the ranges)
//! or a spatial one in x, y, z (ball, cuboid, cylinder, convex polyhedron). Queries go through
//! parry2d / parry3d.

mod planar;
mod solid;

pub(crate) use planar::{closed_polyline, distance_to};

/// A workspace region, metres. Read straight from the model file (`{disc: {centre, radius}}`,
/// `{box: {min, max}}`, `{polygon: {vertices}}`, `{ball: {centre, radius}}`,
/// `{cuboid: {min, max}}`, `{cylinder: {centre, radius, height}}` or
/// `{polyhedron: {vertices}}`); its values are checked when the mechanism is validated.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields, rename_all = "snake_case")]
pub enum Region {
    /// A disc in x, y.
    Disc {
        /// Centre `[x, y]`, metres.
        centre: [f64; 2],
        /// Radius, metres.
        radius: f64,
    },
    /// An axis-aligned box in x, y.
    Box {
        /// Lower corner `[x, y]`, metres.
        min: [f64; 2],
        /// Upper corner `[x, y]`, metres.
        max: [f64; 2],
    },
    /// A simple polygon in x, y.
    Polygon {
        /// Vertices `[x, y]` in order, metres.
        vertices: Vec<[f64; 2]>,
    },
    /// A ball in x, y, z.
    Ball {
        /// Centre `[x, y, z]`, metres.
        centre: [f64; 3],
        /// Radius, metres.
        radius: f64,
    },
    /// An axis-aligned cuboid in x, y, z.
    Cuboid {
        /// Lower corner `[x, y, z]`, metres.
        min: [f64; 3],
        /// Upper corner `[x, y, z]`, metres.
        max: [f64; 3],
    },
    /// A cylinder with a vertical (z) axis.
    Cylinder {
        /// Centre `[x, y, z]` (the middle of the axis), metres.
        centre: [f64; 3],
        /// Radius, metres.
        radius: f64,
        /// Height along z, metres.
        height: f64,
    },
    /// The convex hull of points in x, y, z.
    Polyhedron {
        /// Points `[x, y, z]`, metres (their order does not matter).
        vertices: Vec<[f64; 3]>,
    },
}

impl Region {
    /// Is the region spatial (in x, y, z) rather than planar (in x, y)?
    pub fn is_spatial(&self) -> bool {
        matches!(
            self,
            Region::Ball { .. }
                | Region::Cuboid { .. }
                | Region::Cylinder { .. }
                | Region::Polyhedron { .. }
        )
    }

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

    /// Bounding box `(min, max)` in x, y, metres.
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        let (lo, hi) = self.bounds_xyz();
        ([lo[0], lo[1]], [hi[0], hi[1]])
    }

    /// Extent `[min, max]` in z of a spatial region, metres (`None` for a planar one).
    pub fn z_bounds(&self) -> Option<[f64; 2]> {
        self.is_spatial().then(|| {
            let (lo, hi) = self.bounds_xyz();
            [lo[2], hi[2]]
        })
    }

    /// Bounding box in x, y, z (z is 0 for a planar region).
    fn bounds_xyz(&self) -> ([f64; 3], [f64; 3]) {
        let fold = |points: &mut dyn Iterator<Item = [f64; 3]>| {
            points.fold(
                ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
                |(lo, hi), p| {
                    (
                        std::array::from_fn(|i| lo[i].min(p[i])),
                        std::array::from_fn(|i| hi[i].max(p[i])),
                    )
                },
            )
        };
        match self {
            Region::Disc { centre, radius } => (
                [centre[0] - radius, centre[1] - radius, 0.0],
                [centre[0] + radius, centre[1] + radius, 0.0],
            ),
            Region::Box { min, max } => ([min[0], min[1], 0.0], [max[0], max[1], 0.0]),
            Region::Polygon { vertices } => fold(&mut vertices.iter().map(|v| [v[0], v[1], 0.0])),
            Region::Ball { centre, radius } => {
                (centre.map(|c| c - radius), centre.map(|c| c + radius))
            }
            Region::Cuboid { min, max } => (*min, *max),
            Region::Cylinder {
                centre,
                radius,
                height,
            } => (
                [
                    centre[0] - radius,
                    centre[1] - radius,
                    centre[2] - height / 2.0,
                ],
                [
                    centre[0] + radius,
                    centre[1] + radius,
                    centre[2] + height / 2.0,
                ],
            ),
            Region::Polyhedron { vertices } => fold(&mut vertices.iter().copied()),
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
