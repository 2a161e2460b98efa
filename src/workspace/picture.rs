//! The data of the workspace picture: the singularity-free region, its singular curves traced
//! smoothly (marching squares on the singularity measures with sub-cell crossings, bisected
//! on the real measures where a leg loses reach) and the MIW. Drawn by
//! [`crate::report::plots::workspace`].

use std::collections::VecDeque;

use super::contour::{zero_contours, Polyline, Samples, Undefined};
use super::limits::has_limits;
use super::miw::{Miw, SingularityMargin};
use super::miw3d::Miw3d;
use crate::kinematics::inverse::LegSolution;
use crate::model::Mechanism;
use crate::report::plots::workspace::{
    PoseGroup, WorkspaceFigure, SERIAL_LABEL, SERIAL_OR_LIMIT_LABEL,
};

/// Grid cells per side sampled to trace the singular curves of the picture.
pub const GRID: usize = 120;

/// Bisection steps on an edge between a reachable and an unreachable node (2⁻²⁰ of a cell, then extrapolated).
const BISECTIONS: usize = 20;

/// The workspace picture of `miw`, with the singular curves of `margin` over the region around
/// it, and `poses` drawn on top.
pub fn workspace_figure(
    margin: &SingularityMargin<'_>,
    miw: &Miw,
    title: &str,
    poses: Vec<PoseGroup>,
) -> WorkspaceFigure {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let points = miw
        .boundary
        .iter()
        .chain(poses.iter().flat_map(|g| g.points.iter()));
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let pad = 0.25 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (lo, hi) = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    let SingularCurves { serial, parallel } = singular_curves(margin, (lo, hi), miw.centre, GRID);
    WorkspaceFigure {
        title: title.to_string(),
        region: miw.boundary.clone(),
        serial,
        parallel,
        miw_centre: miw.centre,
        miw_radius: miw.radius,
        poses,
        bounds: (lo, hi),
        axes: ["x".into(), "y".into()],
        region_label:
            "singularity-free region of the home working and assembly modes, seen from the MIW centre"
                .into(),
        serial_label: serial_label(margin.mechanism()),
        miw_label: format!(
            "MIW: centre ({}, {}) m, radius {:.4} m",
            crate::report::tidy(miw.centre[0], 4),
            crate::report::tidy(miw.centre[1], 4),
            miw.radius
        ),
    }
}

/// The serial curves' legend entry: they include the joint limits where the mechanism has any.
fn serial_label(mechanism: &Mechanism) -> String {
    if mechanism.legs.iter().any(has_limits) {
        SERIAL_OR_LIMIT_LABEL.into()
    } else {
        SERIAL_LABEL.into()
    }
}

/// Grid cells per side of a spatial slice's singular curves (three slices are drawn).
pub const SLICE_GRID: usize = 80;

/// The picture of one slice of a spatial mechanism's workspace through the home position, in
/// the plane of the position coordinates `axes` (`margin` set on that plane with
/// [`SingularityMargin::in_plane`]): the region's `boundary` there (from
/// [`crate::workspace::miw3d::slice`]), its singular curves, the 3-D MIW's cross-section and the
/// `poses` (projected on the plane).
pub fn slice_figure(
    margin: &SingularityMargin<'_>,
    boundary: Vec<[f64; 2]>,
    axes: [usize; 2],
    miw: &Miw3d,
    poses: Vec<PoseGroup>,
) -> WorkspaceFigure {
    const NAMES: [&str; 3] = ["x", "y", "z"];
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in boundary
        .iter()
        .chain(poses.iter().flat_map(|g| g.points.iter()))
    {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let pad = 0.25 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
    let (lo, hi) = ([lo[0] - pad, lo[1] - pad], [hi[0] + pad, hi[1] + pad]);
    let centre = [miw.centre[axes[0]], miw.centre[axes[1]]];
    let SingularCurves { serial, parallel } = singular_curves(margin, (lo, hi), centre, SLICE_GRID);
    let fixed = 3 - axes[0] - axes[1];
    let c = miw.centre.map(|v| crate::report::tidy(v, 4));
    WorkspaceFigure {
        title: format!(
            "slice {} = {} m",
            NAMES[fixed],
            crate::report::tidy(miw.centre[fixed], 4)
        ),
        region: boundary,
        serial,
        parallel,
        miw_centre: centre,
        miw_radius: miw.radius,
        poses,
        bounds: (lo, hi),
        axes: [NAMES[axes[0]].into(), NAMES[axes[1]].into()],
        region_label: "singularity-free region of the home working and assembly modes at the home orientation, seen from the home position".into(),
        serial_label: serial_label(margin.mechanism()),
        miw_label: format!(
            "3-D MIW: a ball about ({}, {}, {}) m, radius {:.4} m (its cross-section)",
            c[0], c[1], c[2], miw.radius
        ),
    }
}

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
    let serial: Vec<Vec<Option<f64>>> = sampled
        .iter()
        .map(|column| {
            column
                .iter()
                .map(|m| m.as_ref().map(|n| n.serial))
                .collect()
        })
        .collect();
    let parallel: Vec<Vec<Option<f64>>> = sampled
        .iter()
        .map(|column| {
            column
                .iter()
                .map(|m| m.as_ref().map(|n| n.parallel))
                .collect()
        })
        .collect();
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
    let serial = zero_contours(
        Samples {
            values: &serial,
            lo,
            step,
        },
        Undefined::Outside,
        &reach,
    );
    let parallel = zero_contours(
        Samples {
            values: &parallel,
            lo,
            step,
        },
        Undefined::Skip,
        &|a, _| a,
    );
    SingularCurves { serial, parallel }
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
    let Ok(((serial, parallel), solutions)) = margin.measures_from(point(start.0, start.1), None)
    else {
        return nodes;
    };
    nodes[start.0][start.1] = Some(Node {
        serial,
        parallel,
        solutions,
    });
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
            if let Ok(((serial, parallel), solutions)) =
                margin.measures_from(point(a, b), Some(seeds))
            {
                nodes[a][b] = Some(Node {
                    serial,
                    parallel,
                    solutions,
                });
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
