//! The workspace region as the model file declares it (`workspace.region`): a planar region of
//! the end-effector point in x, y (disc, box, polygon; z, when measured, comes from the ranges)
//! or a spatial one in x, y, z (ball, cuboid, cylinder, convex polyhedron): the data and its
//! bounds. Its geometry (depths, containment, the polyhedron's hull) is
//! [`crate::workspace::region`]'s.

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
}
