//! The intersection of three spheres nearest a given point (trilateration): the closed-form
//! forward kinematics of a translating platform held by three legs whose tips each lie on a
//! known sphere once their actuators are set (a carriage leg: the rod turns about the
//! carriage's universal joint).

use super::circle_intersection::clearly_nearer;

/// The intersection of the spheres about `centres` with `radii` nearest `near`, when it is
/// clearly the nearer of the two: the far one at least twice as far from `near`. `None` where
/// the spheres do not meet in two points (or barely: the two within `1e-9` of the first two
/// centres' distance of each other, a reach limit), the centres are (nearly) on one line, or
/// `near` is about as far from both (Newton's method from `near` could go either way there).
pub(crate) fn nearest_intersection(
    centres: [[f64; 3]; 3],
    radii: [f64; 3],
    near: [f64; 3],
) -> Option<[f64; 3]> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let scaled = |a: [f64; 3], s: f64| [a[0] * s, a[1] * s, a[2] * s];
    // An orthonormal frame at the first centre: x towards the second, y in the centres' plane.
    let (to_second, to_third) = (sub(centres[1], centres[0]), sub(centres[2], centres[0]));
    let d = dot(to_second, to_second).sqrt();
    let ex = scaled(to_second, 1.0 / d);
    let i = dot(ex, to_third);
    let off_line = sub(to_third, scaled(ex, i));
    let j = dot(off_line, off_line).sqrt();
    // Centres on one line (or coincident, or not finite): no unique circle of intersection.
    if !(j > 1e-9 * d && d.is_finite() && d > 0.0) {
        return None;
    }
    let ey = scaled(off_line, 1.0 / j);
    let ez = [
        ex[1] * ey[2] - ex[2] * ey[1],
        ex[2] * ey[0] - ex[0] * ey[2],
        ex[0] * ey[1] - ex[1] * ey[0],
    ];
    let r2 = radii.map(|r| r * r);
    let x = (r2[0] - r2[1] + d * d) / (2.0 * d);
    let y = (r2[0] - r2[2] + i * i + j * j) / (2.0 * j) - i * x / j;
    let z2 = r2[0] - x * x - y * y;
    // (A NaN fails the test too.)
    if z2.is_nan() || z2 <= 1e-18 * d * d {
        return None;
    }
    let z = z2.sqrt();
    let foot: [f64; 3] = std::array::from_fn(|k| centres[0][k] + x * ex[k] + y * ey[k]);
    let at = |h: f64| -> [f64; 3] { std::array::from_fn(|k| foot[k] + h * ez[k]) };
    clearly_nearer([at(z), at(-z)], near)
}

#[cfg(test)]
mod tests {
    use super::nearest_intersection;

    fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    #[test]
    fn the_nearer_intersection_of_three_spheres_is_found() {
        // Three spheres through (1, 2, 3) and its mirror image in their centres' plane z = 0.
        let point = [1.0, 2.0, 3.0];
        let centres = [[0.0, 0.0, 0.0], [4.0, 0.5, 0.0], [-1.0, 3.5, 0.0]];
        let radii = centres.map(|c| distance(c, point));
        let up = nearest_intersection(centres, radii, [1.1, 1.9, 2.0]).unwrap();
        assert!(distance(up, point) < 1e-14, "{up:?}");
        let down = nearest_intersection(centres, radii, [0.9, 2.2, -2.5]).unwrap();
        assert!(distance(down, [1.0, 2.0, -3.0]) < 1e-14, "{down:?}");
        // Centres in a tilted plane, unequal radii: the point is found from near it.
        let point = [0.3, -0.2, 0.1];
        let centres = [[0.1, 0.2, 0.5], [0.6, -0.1, 0.45], [0.0, -0.5, 0.6]];
        let radii = centres.map(|c| distance(c, point));
        let found = nearest_intersection(centres, radii, [0.31, -0.19, 0.09]).unwrap();
        assert!(distance(found, point) < 1e-14, "{found:?}");
        for (c, r) in centres.iter().zip(radii) {
            assert!((distance(*c, found) - r).abs() < 1e-14);
        }
    }

    #[test]
    fn no_intersection_or_an_ambiguous_one_is_refused() {
        let centres = [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        // Too small to meet; touching (a reach limit).
        assert!(nearest_intersection(centres, [1.0, 1.0, 1.0], [0.0, 0.0, 1.0]).is_none());
        let touching = 8f64.sqrt();
        let radii = [touching; 3];
        assert!(nearest_intersection(centres, radii, [2.0, 2.0, 0.1]).is_none());
        // Centres on one line, coincident, or not finite.
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert!(nearest_intersection(line, [3.0, 3.0, 3.0], [1.0, 2.0, 0.0]).is_none());
        assert!(nearest_intersection([[1.0; 3]; 3], [1.0; 3], [0.0; 3]).is_none());
        let mut far = centres;
        far[1][0] = f64::INFINITY;
        assert!(nearest_intersection(far, [5.0; 3], [1.0, 1.0, 3.0]).is_none());
        let mut nan = centres;
        nan[2][1] = f64::NAN;
        assert!(nearest_intersection(nan, [5.0; 3], [1.0, 1.0, 3.0]).is_none());
        // In the centres' plane both intersections are as far; nearer to one, but not twice
        // as near.
        assert!(nearest_intersection(centres, [5.0; 3], [2.0, 2.0, 0.0]).is_none());
        assert!(nearest_intersection(centres, [5.0; 3], [2.0, 2.0, 0.5]).is_none());
        assert!(nearest_intersection(centres, [5.0; 3], [2.0, 2.0, 3.0]).is_some());
    }
}
