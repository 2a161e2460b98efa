//! The intersection of two circles in the plane nearest a given point: the closed-form forward
//! kinematics of a planar platform point held by two legs whose tips each lie on a known
//! circle once their actuators are set (a dyad actuated at its base: the elbow is fixed, the
//! distal link turns about it).

/// The intersection of the circles about `centres` with `radii` nearest `near`, when it is
/// clearly the nearer of the two: the far one at least twice as far from `near`. `None` where
/// the circles do not meet (or barely: the two intersections within `1e-9` of the centres'
/// distance of each other, a reach limit) or `near` is about as far from both (Newton's method
/// from `near` could go either way there).
pub(crate) fn nearest_intersection(
    centres: [[f64; 2]; 2],
    radii: [f64; 2],
    near: [f64; 2],
) -> Option<[f64; 2]> {
    let e = [centres[1][0] - centres[0][0], centres[1][1] - centres[0][1]];
    // Concentric or non-finite centres make `across2` below NaN.
    let d2 = e[0] * e[0] + e[1] * e[1];
    // The intersections' projection on the line of the centres and their distance from it,
    // both over the centres' distance d.
    let along = (radii[0] * radii[0] - radii[1] * radii[1] + d2) / (2.0 * d2);
    let across2 = radii[0] * radii[0] / d2 - along * along;
    // (A NaN fails the test too.)
    if across2.is_nan() || across2 <= 1e-18 {
        return None;
    }
    let across = across2.sqrt();
    let foot = [centres[0][0] + along * e[0], centres[0][1] + along * e[1]];
    let pair = [across, -across].map(|h| [foot[0] - h * e[1], foot[1] + h * e[0]]);
    clearly_nearer(pair, near)
}

/// Of two intersections `pair`, the one nearer `near` when it is clearly the nearer: the
/// other at least twice as far (its squared distance four times); `None` otherwise (Newton's
/// method from `near` could go either way). The circles' rule and the spheres'
/// ([`super::sphere_intersection`]).
pub(super) fn clearly_nearer<const N: usize>(
    pair: [[f64; N]; 2],
    near: [f64; N],
) -> Option<[f64; N]> {
    let squared = |p: &[f64; N]| {
        p.iter()
            .zip(&near)
            .fold(0.0, |sum, (a, b)| sum + (a - b) * (a - b))
    };
    let [first, second] = pair;
    let (nearer, nearest, farthest) = if squared(&first) <= squared(&second) {
        (first, squared(&first), squared(&second))
    } else {
        (second, squared(&second), squared(&first))
    };
    (farthest >= 4.0 * nearest).then_some(nearer)
}

#[cfg(test)]
mod tests {
    use super::nearest_intersection;

    #[test]
    fn the_nearer_intersection_of_two_circles_is_found() {
        // Circles of radius 5 about (0, 0) and (8, 0) meet at (4, ±3).
        let centres = [[0.0, 0.0], [8.0, 0.0]];
        let up = nearest_intersection(centres, [5.0, 5.0], [4.1, 2.5]).unwrap();
        assert!(
            (up[0] - 4.0).abs() < 1e-15 && (up[1] - 3.0).abs() < 1e-15,
            "{up:?}"
        );
        let down = nearest_intersection(centres, [5.0, 5.0], [3.9, -2.0]).unwrap();
        assert!(
            (down[0] - 4.0).abs() < 1e-15 && (down[1] + 3.0).abs() < 1e-15,
            "{down:?}"
        );
        // Unequal radii: 3 about (0, 0) and 4 about (5, 0) meet at (1.8, ±2.4).
        let p = nearest_intersection([[0.0, 0.0], [5.0, 0.0]], [3.0, 4.0], [2.0, 2.0]).unwrap();
        assert!(
            (p[0] - 1.8).abs() < 1e-15 && (p[1] - 2.4).abs() < 1e-15,
            "{p:?}"
        );
    }

    #[test]
    fn no_intersection_or_an_ambiguous_one_is_refused() {
        let centres = [[0.0, 0.0], [8.0, 0.0]];
        // Too far apart, tangent, concentric.
        assert!(nearest_intersection(centres, [3.0, 3.0], [4.0, 0.0]).is_none());
        assert!(nearest_intersection(centres, [4.0, 4.0], [4.0, 0.0]).is_none());
        assert!(nearest_intersection([[1.0, 1.0]; 2], [1.0, 1.0], [0.0, 0.0]).is_none());
        assert!(nearest_intersection([[1.0, 1.0]; 2], [1.0, 2.0], [0.0, 0.0]).is_none());
        // A centre not finite.
        let far = [[0.0, 0.0], [f64::INFINITY, 0.0]];
        assert!(nearest_intersection(far, [5.0, 5.0], [4.0, 1.0]).is_none());
        let nan = [[0.0, 0.0], [f64::NAN, 0.0]];
        assert!(nearest_intersection(nan, [5.0, 5.0], [4.0, 1.0]).is_none());
        // On the line of the centres, both intersections are as far.
        assert!(nearest_intersection(centres, [5.0, 5.0], [4.0, 0.0]).is_none());
        // Nearer to one, but not twice as near to it.
        assert!(nearest_intersection(centres, [5.0, 5.0], [4.0, 0.5]).is_none());
        assert!(nearest_intersection(centres, [5.0, 5.0], [4.0, 1.5]).is_some());
    }
}
