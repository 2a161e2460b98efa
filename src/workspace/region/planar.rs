//! parry2d at the boundary: conversions between `[f64; 2]` and parry's vectors, and the shape
//! queries of the planar regions. The only place in legwise that touches parry2d types.

use parry2d_f64::math::Vector;
use parry2d_f64::query::PointQuery;
use parry2d_f64::shape::{Ball, Cuboid, Polyline};
use parry2d_f64::utils::point_in_poly2d;

/// `[x, y]` → parry vector.
pub(crate) fn vector(p: [f64; 2]) -> Vector {
    Vector::new(p[0], p[1])
}

/// Signed distance from `point` to a disc's boundary, positive inside, metres.
pub(super) fn disc_depth(centre: [f64; 2], radius: f64, point: [f64; 2]) -> f64 {
    signed_depth(&Ball::new(radius), vector(point) - vector(centre))
}

/// Signed distance from `point` to an axis-aligned box's boundary, positive inside, metres.
pub(super) fn box_depth(min: [f64; 2], max: [f64; 2], point: [f64; 2]) -> f64 {
    let half = [(max[0] - min[0]) / 2.0, (max[1] - min[1]) / 2.0];
    let centre = [min[0] + half[0], min[1] + half[1]];
    signed_depth(&Cuboid::new(vector(half)), vector(point) - vector(centre))
}

/// Signed distance from `point` to a polygon's outline, positive inside, metres.
pub(super) fn polygon_depth(vertices: &[[f64; 2]], point: [f64; 2]) -> f64 {
    let distance = distance_to(&closed_polyline(vertices), point);
    let corners: Vec<_> = vertices.iter().map(|v| vector(*v)).collect();
    if point_in_poly2d(vector(point), &corners) {
        distance
    } else {
        -distance
    }
}

/// Distance to the boundary of a solid shape centred at the origin, positive inside.
fn signed_depth(shape: &impl PointQuery, local: Vector) -> f64 {
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
