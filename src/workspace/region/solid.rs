//! parry3d at the boundary: the shape queries of the spatial regions. The only place in legwise
//! that touches parry3d types.

use parry3d_f64::math::Vector;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{Ball, ConvexPolyhedron, Cuboid, Cylinder};

/// `[x, y, z]` → parry vector.
fn vector(p: [f64; 3]) -> Vector {
    Vector::new(p[0], p[1], p[2])
}

/// Signed distance from `point` to a ball's boundary, positive inside, metres.
pub(super) fn ball_depth(centre: [f64; 3], radius: f64, point: [f64; 3]) -> f64 {
    signed_depth(&Ball::new(radius), vector(point) - vector(centre))
}

/// Signed distance from `point` to an axis-aligned cuboid's boundary, positive inside, metres.
pub(super) fn cuboid_depth(min: [f64; 3], max: [f64; 3], point: [f64; 3]) -> f64 {
    let half: [f64; 3] = std::array::from_fn(|i| (max[i] - min[i]) / 2.0);
    let centre: [f64; 3] = std::array::from_fn(|i| min[i] + half[i]);
    signed_depth(&Cuboid::new(vector(half)), vector(point) - vector(centre))
}

/// Signed distance from `point` to the boundary of a cylinder with a vertical (z) axis,
/// centred at `centre`, positive inside, metres.
pub(super) fn cylinder_depth(centre: [f64; 3], radius: f64, height: f64, point: [f64; 3]) -> f64 {
    // parry's cylinder axis is y: swap y and z (an isometry, and the cylinder is symmetric).
    let local = vector(point) - vector(centre);
    let local = Vector::new(local.x, local.z, local.y);
    signed_depth(&Cylinder::new(height / 2.0, radius), local)
}

/// The convex hull of `vertices`, or `None` when they span no volume.
pub(super) fn convex_hull(vertices: &[[f64; 3]]) -> Option<ConvexPolyhedron> {
    let points: Vec<Vector> = vertices.iter().map(|v| vector(*v)).collect();
    let hull = ConvexPolyhedron::from_convex_hull(&points)?;
    // Coplanar vertices give a flat hull: its centroid is on the boundary.
    let centroid = hull.points().iter().copied().sum::<Vector>() / hull.points().len() as f64;
    let size = hull
        .points()
        .iter()
        .map(|p| (*p - centroid).length())
        .fold(0.0, f64::max);
    (hull_depth(&hull, centroid) > 1e-9 * size).then_some(hull)
}

/// Signed distance from `point` to the boundary of the convex hull of `vertices`, positive
/// inside, metres; `-∞` when the vertices span no volume (refused when the model is loaded).
pub(super) fn polyhedron_depth(vertices: &[[f64; 3]], point: [f64; 3]) -> f64 {
    match convex_hull(vertices) {
        Some(hull) => hull_depth(&hull, vector(point)),
        None => f64::NEG_INFINITY,
    }
}

/// Signed distance to a convex polyhedron's boundary, positive inside. Inside, it is the
/// distance to the nearest face plane (exact for a convex solid); outside, the distance to
/// parry's projection on the solid.
fn hull_depth(hull: &ConvexPolyhedron, point: Vector) -> f64 {
    let inside = hull
        .faces()
        .iter()
        .map(|face| {
            let corner = hull.vertices_adj_to_face()[face.first_vertex_or_edge as usize];
            face.normal.dot(hull.points()[corner as usize] - point)
        })
        .fold(f64::INFINITY, f64::min);
    if inside >= 0.0 {
        inside
    } else {
        -(point - hull.project_local_point(point, true).point).length()
    }
}

/// Distance to the boundary of a solid shape, positive inside.
fn signed_depth(shape: &impl PointQuery, local: Vector) -> f64 {
    let projection = shape.project_local_point(local, false);
    let distance = (local - projection.point).length();
    let distance = if distance.is_finite() {
        distance
    } else {
        shape.distance_to_local_point(local, false).abs()
    };
    if shape.contains_local_point(local) {
        distance
    } else {
        -distance
    }
}
