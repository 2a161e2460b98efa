//! The singular curves of the workspace around the singularity-free region, traced smoothly
//! (marching squares on the singularity measures with sub-cell crossings, bisected on the real
//! measures where a leg loses reach). Pictured by the report module's workspace plot.

use std::collections::VecDeque;

use super::contour::{zero_contours, Polyline, Samples, Undefined};
use super::miw::SingularityMargin;
use crate::kinematics::inverse::LegSolution;

/// Bisection steps on an edge between a reachable and an unreachable node (2⁻²⁰ of a cell, then extrapolated).
const BISECTIONS: usize = 20;

/// The singular curves of a region.
#[derive(Debug, Clone, PartialEq)]
pub struct SingularCurves {
    /// Zero crossings of the smallest serial measure (a leg stretched, folded, out of reach).
    pub serial: Vec<Polyline>,
    /// Zero crossings of the parallel measure.
    pub parallel: Vec<Polyline>,
}

/// Polylines of the serial (smallest leg measure) and parallel zero crossings over the
/// rectangle `lo`–`hi`, continuing the legs' solutions from `start` (a point inside the
/// singularity-free region, such as the MIW centre), on a grid of `cells × cells` cells.
pub fn singular_curves(
    margin: &SingularityMargin<'_>,
    (lo, hi): ([f64; 2], [f64; 2]),
    start: [f64; 2],
    cells: usize,
) -> SingularCurves {
    let cells = cells.max(1);
    let step = [
        (hi[0] - lo[0]) / cells as f64,
        (hi[1] - lo[1]) / cells as f64,
    ];
    let sampled = sample_from_home(margin, lo, step, cells + 1, start);
    // The zero contours of one measure at the nodes.
    let contours = |measure: fn(&Node) -> f64,
                    undefined: Undefined,
                    refine: &dyn Fn([f64; 2], [f64; 2]) -> [f64; 2]| {
        let values: Vec<Vec<Option<f64>>> = sampled
            .iter()
            .map(|column| column.iter().map(|m| m.as_ref().map(measure)).collect())
            .collect();
        zero_contours(
            Samples {
                values: &values,
                lo,
                step,
            },
            undefined,
            refine,
        )
    };
    let node = |p: [f64; 2]| {
        let i = ((p[0] - lo[0]) / step[0]).round();
        let j = ((p[1] - lo[1]) / step[1]).round();
        sampled
            .get(i as usize)
            .and_then(|column| column.get(j as usize))
            .and_then(Option::as_ref)
    };
    let reach = |inside: [f64; 2], outside: [f64; 2]| match node(inside) {
        Some(sample) => reach_limit(margin, (&sample.solutions, sample.serial), inside, outside),
        None => [
            0.5 * (inside[0] + outside[0]),
            0.5 * (inside[1] + outside[1]),
        ],
    };
    SingularCurves {
        serial: contours(|n| n.serial, Undefined::Outside, &reach),
        parallel: contours(|n| n.parallel, Undefined::Skip, &|a, _| a),
    }
}

/// The measures and the legs' solutions at one grid node.
struct Node {
    serial: f64,
    parallel: f64,
    solutions: Vec<LegSolution>,
}

/// The measures on the `count × count` grid from `lo`, by continuation from the node nearest
/// `home` (solved from the mechanism's home joints) to its neighbours, breadth first: a node is defined
/// when every leg reaches it on its home branch continuing from a defined neighbour, so the
/// undefined nodes are exactly those beyond a serial singularity or out of reach.
fn sample_from_home(
    margin: &SingularityMargin<'_>,
    lo: [f64; 2],
    step: [f64; 2],
    count: usize,
    home: [f64; 2],
) -> Vec<Vec<Option<Node>>> {
    let point = |i: usize, j: usize| [lo[0] + i as f64 * step[0], lo[1] + j as f64 * step[1]];
    let mut nodes: Vec<Vec<Option<Node>>> = (0..count)
        .map(|_| (0..count).map(|_| None).collect())
        .collect();
    let index = |v: f64, lo: f64, step: f64| {
        ((v - lo) / step).round().clamp(0.0, (count - 1) as f64) as usize
    };
    let start = (
        index(home[0], lo[0], step[0]),
        index(home[1], lo[1], step[1]),
    );
    // The node at (i, j), its legs solved from `seeds` (from home for none), if they reach it.
    let solve = |(i, j): (usize, usize), seeds: Option<&[LegSolution]>| {
        let ((serial, parallel), solutions) = margin.measures_from(point(i, j), seeds).ok()?;
        Some(Node {
            serial,
            parallel,
            solutions,
        })
    };
    // Nothing is continued from a start the legs do not reach.
    nodes[start.0][start.1] = solve(start, None);
    let mut queue = VecDeque::from([start]);
    while let Some((i, j)) = queue.pop_front() {
        let neighbours = [
            (i.wrapping_sub(1), j),
            (i + 1, j),
            (i, j.wrapping_sub(1)),
            (i, j + 1),
        ];
        for (a, b) in neighbours {
            if a >= count || b >= count || nodes[a][b].is_some() {
                continue;
            }
            let seeds = &nodes[i][j].as_ref().map(|n| n.solutions.clone());
            let Some(seeds) = seeds else { continue };
            nodes[a][b] = solve((a, b), Some(seeds));
            if nodes[a][b].is_some() {
                queue.push_back((a, b));
            }
        }
    }
    nodes
}

/// Where the legs stop reaching on their home branch between `inside` (a node, its legs
/// solved: `seeds`, its serial measure `serial`) and `outside`: the last point bisection
/// reaches continuing the legs' solutions, then extrapolated to the zero of the serial
/// measure, whose square falls linearly to a stretch or fold (Newton stalls just before it).
fn reach_limit(
    margin: &SingularityMargin<'_>,
    (seeds, serial): (&[LegSolution], f64),
    inside: [f64; 2],
    outside: [f64; 2],
) -> [f64; 2] {
    let at = |t: f64| {
        [
            inside[0] + t * (outside[0] - inside[0]),
            inside[1] + t * (outside[1] - inside[1]),
        ]
    };
    let mut seeds = seeds.to_vec();
    let (mut good, mut bad, mut at_good) = (0.0, 1.0, serial);
    for _ in 0..BISECTIONS {
        let middle = 0.5 * (good + bad);
        match margin.measures_from(at(middle), Some(&seeds)) {
            Ok(((s, _), solutions)) => {
                seeds = solutions;
                good = middle;
                at_good = s;
            }
            Err(_) => bad = middle,
        }
    }
    let drop = serial * serial - at_good * at_good;
    let zero = if good > 0.0 && drop > 0.0 {
        good + at_good * at_good * good / drop
    } else {
        good
    };
    at(zero.clamp(good, bad))
}
