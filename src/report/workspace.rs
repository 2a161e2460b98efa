//! The report of `legwise workspace`: the maximal inscribed workspace (planar: a disc in the
//! singularity-free region; spatial: a ball at the home orientation) as terminal text, and its
//! picture (planar: the region, its singular curves and the MIW; spatial: three slices through
//! the home position), with the poses of a pose file drawn on it.

use std::fmt::Write as _;

use super::plots::slices::SlicesFigure;
use super::plots::workspace::{slice_figure, workspace_figure, PoseGroup};
use super::plots::{render, Format};
use crate::error::Result;
use crate::measure::MeasurementSet;
use crate::model::mechanism::COORDINATES;
use crate::model::Mechanism;
use crate::workspace::miw::{maximal_inscribed_workspace, MiwOptions, SingularityMargin};
use crate::workspace::miw3d::{self, slice, spatial_inscribed_workspace, Miw3dOptions, REACH};

/// The workspace report of `mechanism` with `rays` rays cast to trace the region's boundary:
/// the text, and the picture in `format` with the poses of `poses` (if given) drawn on it.
///
/// # Errors
/// The MIW cannot be computed (no singularity-free home, a region the rays cannot trace), or
/// the picture cannot be drawn.
pub fn workspace_report(
    mechanism: &Mechanism,
    rays: usize,
    poses: Option<&MeasurementSet>,
    format: Format,
) -> Result<(String, Vec<u8>)> {
    let groups =
        |axes: [usize; 2]| poses.map_or(Vec::new(), |set| pose_groups(mechanism, set, axes));
    if !mechanism.is_planar() {
        let (text, figure) = spatial(mechanism, rays, &groups)?;
        return Ok((text, render(&figure, format)?));
    }
    let options = MiwOptions {
        rays,
        ..MiwOptions::for_mechanism(mechanism)
    };
    let miw = maximal_inscribed_workspace(mechanism, options)?;
    let held: Vec<String> = mechanism
        .measured
        .iter()
        .filter(|&&c| c >= 2)
        .map(|&c| format!("{} = {}", COORDINATES[c], mechanism.home_pose[c]))
        .collect();
    let mut text = super::title("workspace", mechanism);
    if let Some(mode) = &mechanism.mode {
        let _ = writeln!(text, "mode: {mode}");
    }
    if !held.is_empty() {
        let _ = writeln!(
            text,
            "constant-orientation region at the home values: {}",
            held.join(", ")
        );
    }
    let _ = writeln!(text, "maximal inscribed workspace (MIW):");
    let _ = writeln!(
        text,
        "  centre  x = {:.7} m, y = {:.7} m",
        crate::report::tidy(miw.centre[0], 7),
        crate::report::tidy(miw.centre[1], 7)
    );
    let _ = writeln!(text, "  radius  {:.7} m", miw.radius);
    let margin = SingularityMargin::new(mechanism)?;
    let title = format!("{}: singularity-free region and MIW", mechanism.name);
    let figure = workspace_figure(&margin, &miw, &title, groups([0, 1]));
    Ok((text, render(&figure, format)?))
}

/// The slices of a spatial workspace drawn, by their position coordinates: x–y, x–z, y–z.
const SLICES: [[usize; 2]; 3] = [[0, 1], [0, 2], [1, 2]];

/// Rays cast in each slice's plane.
const SLICE_RAYS: usize = 360;

/// A spatial mechanism: the 3-D MIW at the home orientation as text, and the picture of three
/// slices through the home position (x–y, x–z, y–z: the region's boundary, its singular
/// curves, the ball's cross-section and the poses `groups` gives for each plane).
fn spatial(
    mechanism: &Mechanism,
    rays: usize,
    groups: &dyn Fn([usize; 2]) -> Vec<PoseGroup>,
) -> Result<(String, SlicesFigure)> {
    let options = Miw3dOptions {
        rays,
        ..Miw3dOptions::for_mechanism(mechanism)
    };
    let miw = spatial_inscribed_workspace(mechanism, options)?;
    let slices = SLICES
        .iter()
        .map(|&axes| slice(mechanism, options, axes, SLICE_RAYS))
        .collect::<Result<Vec<_>>>()?;
    let orientation: Vec<String> = (3..6)
        .filter(|c| mechanism.measured.contains(c))
        .map(|c| format!("{} = {}", COORDINATES[c], mechanism.home_pose[c]))
        .collect();
    let mut text = super::title("workspace", mechanism);
    if !orientation.is_empty() {
        let _ = writeln!(
            text,
            "constant-orientation region at the home values: {}",
            orientation.join(", ")
        );
    }
    let _ = writeln!(
        text,
        "maximal inscribed workspace (3-D MIW, a ball about the home position, {rays} rays):"
    );
    let [x, y, z] = miw.centre.map(|v| crate::report::tidy(v, 7));
    let _ = writeln!(text, "  centre  x = {x:.7} m, y = {y:.7} m, z = {z:.7} m");
    let _ = writeln!(text, "  radius  {:.7} m", miw.radius);
    for surface in &miw.surfaces {
        let clearance = surface.clearance();
        let _ = writeln!(
            text,
            "  the touch surface of target `{}` is {clearance:.7} m from the home position{}",
            surface.target,
            if clearance < miw.singularity_free_radius {
                format!(
                    " and bounds the ball (singularity-free radius {:.7} m)",
                    miw.singularity_free_radius
                )
            } else {
                String::new()
            }
        );
    }
    let reach = REACH * miw3d::region_size(mechanism);
    let far = |points: &mut dyn Iterator<Item = f64>| {
        points.filter(|r| *r >= reach * (1.0 - 1e-9)).count()
    };
    let capped = far(&mut miw.boundary.iter().map(|p| {
        (0..3)
            .map(|k| (p[k] - miw.centre[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }));
    let capped_slices: usize = slices
        .iter()
        .zip(SLICES)
        .map(|(boundary, axes)| {
            far(&mut boundary
                .iter()
                .map(|p| (p[0] - miw.centre[axes[0]]).hypot(p[1] - miw.centre[axes[1]])))
        })
        .sum();
    if capped + capped_slices > 0 {
        let _ = writeln!(
            text,
            "  {capped} of {rays} rays (and {capped_slices} of the slices' {}) met no boundary \
             within {reach:.3} m ({REACH} region sizes) and stop there",
            SLICES.len() * SLICE_RAYS
        );
    }
    let _ = writeln!(
        text,
        "picture: the slices z = {z:.7} m (x-y), y = {y:.7} m (x-z) and x = {x:.7} m (y-z) \
         through the home position, at the home orientation"
    );
    let margin = SingularityMargin::new(mechanism)?;
    let panels = slices
        .into_iter()
        .zip(SLICES)
        .map(|(boundary, axes)| {
            let plane = margin.clone().in_plane(axes);
            slice_figure(&plane, boundary, axes, &miw, groups(axes))
        })
        .collect();
    let figure = SlicesFigure {
        title: format!(
            "{}: singularity-free slices through the home position and 3-D MIW",
            mechanism.name
        ),
        panels,
    };
    Ok((text, figure))
}

/// The poses of a pose file, grouped by their leg label (shared poses last), in the pose
/// coordinates `axes` (x, y for a planar picture; projected on a spatial slice's plane).
fn pose_groups(mechanism: &Mechanism, set: &MeasurementSet, axes: [usize; 2]) -> Vec<PoseGroup> {
    let source = set
        .source
        .as_ref()
        .and_then(|p| p.file_name())
        .map_or(String::new(), |n| format!(" of {}", n.to_string_lossy()));
    let labels = mechanism
        .legs
        .iter()
        .enumerate()
        .map(|(l, leg)| (Some(l), leg.name.clone()));
    labels
        .chain(std::iter::once((None, "shared".to_string())))
        .filter_map(|(leg, name)| {
            let points: Vec<[f64; 2]> = set
                .poses()
                .iter()
                .filter(|p| p.leg == leg)
                .map(|p| [p.pose[axes[0]], p.pose[axes[1]]])
                .collect();
            (!points.is_empty()).then(|| PoseGroup {
                name: format!("{name} poses{source}"),
                points,
            })
        })
        .collect()
}
