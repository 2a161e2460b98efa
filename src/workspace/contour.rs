//! Zero contours of a sampled function by marching squares: each cell edge whose ends lie on
//! opposite sides is crossed at a sub-cell point (linear interpolation, or a caller-supplied
//! refinement where the function is undefined on one side), and the segments are joined into
//! polylines, so that curves are smooth instead of following the grid.

use std::collections::HashMap;

/// A curve: its points in order (the last equal to the first for a closed curve).
pub type Polyline = Vec<[f64; 2]>;

/// A cell edge: the lower-left grid node `(i, j)` and the direction (0: +x, 1: +y).
type Edge = (usize, usize, u8);

/// Samples of a function on a regular grid: `values[i][j]` at `lo + (i·step_x, j·step_y)`;
/// `None` where it is undefined.
#[derive(Debug, Clone, Copy)]
pub struct Samples<'a> {
    /// The values, indexed `[i][j]` (x then y); every column has the same length.
    pub values: &'a [Vec<Option<f64>>],
    /// Position of node (0, 0).
    pub lo: [f64; 2],
    /// Grid spacing in x and y.
    pub step: [f64; 2],
}

impl Samples<'_> {
    fn point(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.lo[0] + i as f64 * self.step[0],
            self.lo[1] + j as f64 * self.step[1],
        ]
    }
}

/// How to treat nodes where the function is undefined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Undefined {
    /// Outside (negative): the contour also separates defined positive nodes from undefined
    /// ones, crossing at the point the refinement returns.
    Outside,
    /// Unknown: cells with an undefined corner are skipped.
    Skip,
}

/// The polylines where the sampled function crosses zero (positive = inside).
///
/// `refine(inside, outside)` returns the crossing point on an edge from a defined inside node
/// to an undefined one (used with [`Undefined::Outside`] only); a bisection on the real
/// function makes the curve exact there.
pub fn zero_contours(
    samples: Samples<'_>,
    undefined: Undefined,
    refine: &dyn Fn([f64; 2], [f64; 2]) -> [f64; 2],
) -> Vec<Polyline> {
    let nx = samples.values.len();
    let ny = samples.values.first().map_or(0, Vec::len);
    if nx < 2 || ny < 2 {
        return Vec::new();
    }
    let value = |i: usize, j: usize| samples.values[i][j];
    let inside = |v: Option<f64>| v.is_some_and(|v| v > 0.0);
    let mut points: HashMap<Edge, [f64; 2]> = HashMap::new();
    let mut crossing = |edge: Edge| -> [f64; 2] {
        *points.entry(edge).or_insert_with(|| {
            // From node (i, j) to node (k, l).
            let (i, j, d) = edge;
            let (k, l) = if d == 0 { (i + 1, j) } else { (i, j + 1) };
            let (pa, pb) = (samples.point(i, j), samples.point(k, l));
            match (value(i, j), value(k, l)) {
                (Some(va), Some(vb)) => {
                    // The ends lie on opposite sides, so the difference is not zero.
                    let difference = va - vb;
                    let t = if difference.abs() > f64::MIN_POSITIVE {
                        (va / difference).clamp(0.0, 1.0)
                    } else {
                        0.5
                    };
                    [pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1])]
                }
                (Some(_), None) => refine(pa, pb),
                (None, Some(_)) => refine(pb, pa),
                (None, None) => [0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])],
            }
        })
    };
    let mut segments: Vec<(Edge, Edge)> = Vec::new();
    for i in 0..nx - 1 {
        for j in 0..ny - 1 {
            let corners = [
                value(i, j),
                value(i + 1, j),
                value(i + 1, j + 1),
                value(i, j + 1),
            ];
            if undefined == Undefined::Skip && corners.iter().any(Option::is_none) {
                continue;
            }
            // Edges in corner order: bottom (0→1), right (1→2), top (3→2), left (0→3).
            let edges: [Edge; 4] = [(i, j, 0), (i + 1, j, 1), (i, j + 1, 0), (i, j, 1)];
            let flags = corners.map(inside);
            let crossed: Vec<usize> = (0..4).filter(|&k| flags[k] != flags[(k + 1) % 4]).collect();
            match crossed.len() {
                2 => segments.push((edges[crossed[0]], edges[crossed[1]])),
                4 => {
                    // Saddle: the mean of the corners decides which diagonal pair joins.
                    let defined: Vec<f64> = corners.iter().flatten().copied().collect();
                    let centre_inside = defined.len() == 4 && defined.iter().sum::<f64>() > 0.0;
                    if centre_inside == flags[0] {
                        segments.push((edges[0], edges[1]));
                        segments.push((edges[2], edges[3]));
                    } else {
                        segments.push((edges[0], edges[3]));
                        segments.push((edges[1], edges[2]));
                    }
                }
                _ => {}
            }
        }
    }
    let chains = join(&segments);
    chains
        .into_iter()
        .map(|chain| chain.into_iter().map(&mut crossing).collect())
        .collect()
}

/// Joins segments sharing an edge into chains of edges (open or closed).
fn join(segments: &[(Edge, Edge)]) -> Vec<Vec<Edge>> {
    let mut at: HashMap<Edge, Vec<usize>> = HashMap::new();
    for (s, &(a, b)) in segments.iter().enumerate() {
        at.entry(a).or_default().push(s);
        at.entry(b).or_default().push(s);
    }
    let mut used = vec![false; segments.len()];
    let mut chains = Vec::new();
    // Start at chain ends (edges with one segment) first, then close the remaining loops.
    let mut starts: Vec<usize> = (0..segments.len())
        .filter(|&s| at[&segments[s].0].len() == 1 || at[&segments[s].1].len() == 1)
        .collect();
    starts.extend(0..segments.len());
    for start in starts {
        if used[start] {
            continue;
        }
        used[start] = true;
        let (a, b) = segments[start];
        let (first, mut last) = if at[&a].len() == 1 { (a, b) } else { (b, a) };
        let mut chain = vec![first, last];
        while let Some(&next) = at[&last].iter().find(|&&s| !used[s]) {
            used[next] = true;
            let (c, d) = segments[next];
            last = if c == last { d } else { c };
            chain.push(last);
        }
        chains.push(chain);
    }
    chains
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit circle sampled on a coarse grid (step 0.2): every contour point is on the circle
    /// to the accuracy of linear interpolation along an edge (h²/8 · |f''|/|f'| ≤ 0.005), far
    /// closer than the grid nodes (a staircase would be off by up to 0.2), and the points form
    /// one closed chain.
    #[test]
    fn a_circle_is_traced_as_one_closed_smooth_curve() {
        let n = 21;
        let (lo, step) = ([-2.0, -2.0], [0.2, 0.2]);
        let values: Vec<Vec<Option<f64>>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        let (x, y) = (lo[0] + i as f64 * step[0], lo[1] + j as f64 * step[1]);
                        Some(1.0 - (x * x + y * y).sqrt())
                    })
                    .collect()
            })
            .collect();
        let samples = Samples {
            values: &values,
            lo,
            step,
        };
        let curves = zero_contours(samples, Undefined::Skip, &|a, _| a);
        assert_eq!(curves.len(), 1);
        let curve = &curves[0];
        assert!(curve.len() > 30, "{} points", curve.len());
        assert_eq!(curve.first(), curve.last(), "closed");
        for p in curve {
            let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
            assert!((r - 1.0).abs() < 5.1e-3, "radius {r}");
        }
    }

    /// An undefined half-plane x > 0.55 treated as outside: the refinement places the crossing
    /// where the caller says, and undefined cells are skipped in the other mode.
    #[test]
    fn undefined_nodes_are_outside_or_skipped() {
        let n = 11;
        let values: Vec<Vec<Option<f64>>> = (0..n)
            .map(|i| {
                let x = i as f64 * 0.1;
                (0..n).map(|_| (x < 0.55).then_some(1.0)).collect()
            })
            .collect();
        let samples = Samples {
            values: &values,
            lo: [0.0, 0.0],
            step: [0.1, 0.1],
        };
        let refine = |_inside: [f64; 2], outside: [f64; 2]| [0.55, outside[1]];
        let curves = zero_contours(samples, Undefined::Outside, &refine);
        assert_eq!(curves.len(), 1);
        assert_eq!(curves[0].len(), n);
        assert!(curves[0].iter().all(|p| (p[0] - 0.55).abs() < 1e-15));
        assert!(zero_contours(samples, Undefined::Skip, &refine).is_empty());
    }
}
