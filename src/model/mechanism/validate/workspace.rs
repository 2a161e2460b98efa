//! The usable workspace: region, margin, ranges, grid and singularity thresholds.

use super::Builder;
use crate::error::Result;
use crate::model::file::ModelFile;
use crate::model::mechanism::COORDINATES;
use crate::model::region::Region;
use crate::model::workspace::{
    Workspace, DEFAULT_RANGE_LEVELS, DEFAULT_SINGULARITY_THRESHOLD, MAX_RANGE_LEVELS,
};

impl Builder<'_> {
    pub(super) fn workspace(&self, file: &ModelFile, measured: &[usize]) -> Result<Workspace> {
        let entry = &file.workspace;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let region = entry.region.clone();
        match &region {
            Region::Disc { centre, radius } => {
                if !positive(*radius) || centre.iter().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.disc",
                        "expected a finite centre and a positive radius (metres)",
                    ));
                }
            }
            Region::Box { min, max } => {
                if !(0..2).all(|i| min[i].is_finite() && max[i].is_finite() && min[i] < max[i]) {
                    return Err(self.error(
                        "workspace.region.box",
                        "expected finite corners with min < max (metres)",
                    ));
                }
            }
            Region::Polygon { vertices } => {
                if vertices.len() < 3 || vertices.iter().flatten().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.polygon",
                        "expected at least three finite vertices (metres)",
                    ));
                }
                if let Some(defect) = super::polygon::defect(vertices) {
                    return Err(self.error("workspace.region.polygon", defect));
                }
            }
            Region::Ball { centre, radius } => {
                if !positive(*radius) || centre.iter().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.ball",
                        "expected a finite centre [x, y, z] and a positive radius (metres)",
                    ));
                }
            }
            Region::Cuboid { min, max } => {
                if !(0..3).all(|i| min[i].is_finite() && max[i].is_finite() && min[i] < max[i]) {
                    return Err(self.error(
                        "workspace.region.cuboid",
                        "expected finite corners [x, y, z] with min < max (metres)",
                    ));
                }
            }
            Region::Cylinder {
                centre,
                radius,
                height,
            } => {
                if !(positive(*radius) && positive(*height))
                    || centre.iter().any(|v| !v.is_finite())
                {
                    return Err(self.error(
                        "workspace.region.cylinder",
                        "expected a finite centre [x, y, z], a positive radius and a positive height (metres)",
                    ));
                }
            }
            Region::Polyhedron { vertices } => {
                if vertices.len() < 4 || vertices.iter().flatten().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.polyhedron",
                        "expected at least four finite vertices [x, y, z] (metres)",
                    ));
                }
            }
        }
        if region.is_spatial() && !measured.contains(&2) {
            return Err(self.error(
                "workspace.region",
                "a spatial region (ball, cuboid, cylinder, polyhedron) needs `z` among the measured coordinates; use a disc, box or polygon for a planar mechanism",
            ));
        }
        if !(entry.margin.is_finite() && entry.margin >= 0.0) {
            return Err(self.error(
                "workspace.margin",
                "expected a non-negative distance (metres)",
            ));
        }
        let mut ranges = [None; 6];
        for (name, range) in &entry.ranges {
            let field = format!("workspace.ranges.{name}");
            match COORDINATES.iter().position(|c| c == name) {
                Some(2) if region.is_spatial() => {
                    return Err(self.error(
                        field,
                        "z is given by the spatial region; a range would contradict it",
                    ))
                }
                Some(i) if i >= 2 && measured.contains(&i) => {
                    if !(range[0].is_finite() && range[1].is_finite() && range[0] <= range[1]) {
                        return Err(self.error(field, "expected [min, max] with min <= max"));
                    }
                    ranges[i] = Some(*range);
                }
                _ => {
                    return Err(
                        self.error(field, "expected a measured coordinate other than x and y")
                    )
                }
            }
        }
        if let Some(grid) = entry.grid {
            if !positive(grid) {
                return Err(self.error("workspace.grid", "expected a positive spacing (metres)"));
            }
        }
        let levels = entry.range_levels.unwrap_or(DEFAULT_RANGE_LEVELS);
        if !(1..=MAX_RANGE_LEVELS).contains(&levels) {
            return Err(self.error(
                "workspace.range_levels",
                format!("expected between 1 and {MAX_RANGE_LEVELS}, found {levels}"),
            ));
        }
        let thresholds = entry.singularity.as_ref();
        let threshold = |value: Option<f64>, name: &str| match value {
            None => Ok(DEFAULT_SINGULARITY_THRESHOLD),
            Some(v) if v.is_finite() && (0.0..1.0).contains(&v) => Ok(v),
            Some(_) => Err(self.error(
                format!("workspace.singularity.{name}"),
                "expected a number in [0, 1)",
            )),
        };
        // The geometric checks (a polyhedron's volume, a usable region within the margin)
        // are `crate::workspace::region::check_usable`'s, run when the mechanism is loaded.
        Ok(Workspace {
            region,
            margin: entry.margin,
            ranges,
            grid: entry.grid,
            range_levels: levels,
            serial_threshold: threshold(thresholds.and_then(|t| t.serial), "serial")?,
            parallel_threshold: threshold(thresholds.and_then(|t| t.parallel), "parallel")?,
        })
    }
}
