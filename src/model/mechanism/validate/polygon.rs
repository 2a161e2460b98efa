//! A planar region's polygon must be simple and enclose an area: the candidate grid, random
//! poses and the MIW test containment against it, which a bow tie (crossing edges) or vertices
//! on one line make meaningless.

/// What is wrong with the polygon `vertices` (finite, at least three), or `None`.
pub(super) fn defect(vertices: &[[f64; 2]]) -> Option<String> {
    let n = vertices.len();
    let edge = |i: usize| (vertices[i], vertices[(i + 1) % n]);
    for i in 0..n {
        // Edges sharing a vertex with edge i meet there by construction.
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            let ((a, b), (c, d)) = (edge(i), edge(j));
            if segments_meet(a, b, c, d) {
                return Some(format!(
                    "its edges {}-{} and {}-{} (vertices counted from 1) cross or touch: expected \
                     the vertices in order around a simple polygon",
                    i + 1,
                    (i + 1) % n + 1,
                    j + 1,
                    (j + 1) % n + 1
                ));
            }
        }
    }
    let twice_area: f64 = (0..n)
        .map(|i| {
            let (a, b) = edge(i);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    let (mut low, mut high) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for v in vertices {
        for k in 0..2 {
            low[k] = low[k].min(v[k]);
            high[k] = high[k].max(v[k]);
        }
    }
    let extent = (high[0] - low[0]).hypot(high[1] - low[1]);
    (twice_area.abs() <= 1e-12 * extent * extent).then(|| {
        "the vertices enclose no area (they lie on one line): expected the corners of a region"
            .to_string()
    })
}

/// The sign of the turn a → b → c (positive: counter-clockwise).
fn turn(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// True when segments a–b and c–d share a point.
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let (d1, d2) = (turn(c, d, a), turn(c, d, b));
    let (d3, d4) = (turn(a, b, c), turn(a, b, d));
    let within = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        (0..2).all(|k| r[k] >= p[k].min(q[k]) && r[k] <= p[k].max(q[k]))
    };
    (d1 * d2 < 0.0 && d3 * d4 < 0.0)
        || (d1 == 0.0 && within(c, d, a))
        || (d2 == 0.0 && within(c, d, b))
        || (d3 == 0.0 && within(a, b, c))
        || (d4 == 0.0 && within(a, b, d))
}

#[cfg(test)]
mod tests {
    use super::defect;

    #[test]
    fn a_bow_tie_and_a_line_are_refused_a_square_is_not() {
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert_eq!(defect(&square), None);
        let bow_tie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(defect(&bow_tie).unwrap().contains("edges 1-2 and 3-4"));
        let line = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        assert!(defect(&line).is_some());
        let concave = [[0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(defect(&concave), None);
    }
}
