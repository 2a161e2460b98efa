//! A plausibility check of the length unit: the legs' geometry (URDF) and the workspace region
//! (model file) must be of comparable size. A URDF written in millimetres next to a model file
//! in metres would otherwise fail much later with a misleading message (a singular design).

use super::Builder;
use crate::error::Result;
use crate::model::file::ModelFile;
use crate::model::instrument::SharedParameter;
use crate::model::joint::JointKind;
use crate::model::leg::LegModel;

/// Largest accepted ratio between a leg's size and the workspace's (either way round).
/// Real mechanisms stay within a factor 10; a unit mix-up gives 1000 (mm vs m).
pub(super) const MAX_SCALE_RATIO: f64 = 100.0;

impl Builder<'_> {
    /// Compares each leg's size (the lengths of its joint origins, attachment and prismatic
    /// offset) with the workspace's (the farthest bounding-box corner from the base origin, or
    /// the box diagonal if larger). Skipped when the region is not finite (reported later).
    pub(super) fn scale(&self, file: &ModelFile, legs: &[LegModel]) -> Result<()> {
        let region = &file.workspace.region;
        let (lo, hi) = region.bounds();
        // A planar region has no extent in z; a spatial one's corners are in 3-D.
        let [z_lo, z_hi] = region.z_bounds().unwrap_or([0.0; 2]);
        let corners = (0..8).map(|k| {
            let pick = |bit: usize, low: f64, high: f64| if k >> bit & 1 == 0 { low } else { high };
            [
                pick(0, lo[0], hi[0]),
                pick(1, lo[1], hi[1]),
                pick(2, z_lo, z_hi),
            ]
        });
        let norm = |v: [f64; 3]| v[0].hypot(v[1]).hypot(v[2]);
        let farthest = corners.map(norm).fold(0.0, f64::max);
        let diagonal = norm([hi[0] - lo[0], hi[1] - lo[1], z_hi - z_lo]);
        let workspace = farthest.max(diagonal);
        if !(workspace.is_finite() && workspace > 0.0) {
            return Ok(());
        }
        for leg in legs {
            let size = leg_size(leg);
            // An overflowing sum (origins near 1e308) is infinite: implausible, not skipped.
            if size.is_nan() || size <= 0.0 {
                continue;
            }
            let hint = |large: &str, small: &str| {
                format!(
                    "the URDF joint origins of leg `{}` add up to {} m while the workspace \
                     region reaches {} m: {large} is {:.0} times the size of {small}, so the URDF \
                     and the model file seem to use different length units (millimetres vs \
                     metres?); legwise expects every length in metres",
                    leg.name,
                    length(size),
                    length(workspace),
                    (size / workspace).max(workspace / size)
                )
            };
            if size > MAX_SCALE_RATIO * workspace {
                return Err(self.error(
                    "urdf",
                    format!(
                        "`{}`: {}",
                        self.urdf_name(),
                        hint("the leg", "the workspace")
                    ),
                ));
            }
            if workspace > MAX_SCALE_RATIO * size {
                return Err(self.error("workspace.region", hint("the workspace", "the leg")));
            }
        }
        Ok(())
    }
}

impl Builder<'_> {
    /// The instrument frame must stand within [`MAX_SCALE_RATIO`] times the mechanism's size of
    /// the base origin: a frame pose written in millimetres (`x: 1200`) put the tracker a
    /// kilometre away without a word.
    pub(super) fn frame_scale(&self, frame: &[SharedParameter], legs: &[LegModel]) -> Result<()> {
        let distance = frame
            .iter()
            .filter(|p| ["frame_x", "frame_y", "frame_z"].contains(&p.name.as_str()))
            .map(|p| p.nominal * p.nominal)
            .sum::<f64>()
            .sqrt();
        let size = mechanism_size(legs);
        if size > 0.0 && distance > MAX_SCALE_RATIO * size {
            return Err(self.error(
                "instrument.frame.pose",
                format!(
                    "the instrument frame is {} m from the base origin, more than \
                     {MAX_SCALE_RATIO} times the mechanism's size ({size:.3} m): millimetres \
                     instead of metres?",
                    length(distance)
                ),
            ));
        }
        Ok(())
    }
}

/// The mechanism's size from its legs, metres: the longest leg's [`leg_size`].
pub(super) fn mechanism_size(legs: &[LegModel]) -> f64 {
    legs.iter().map(leg_size).fold(0.0, f64::max)
}

/// Sum of the translation lengths along the leg: joint origins, attachment and the actuator
/// offset of a prismatic actuator (metres).
fn leg_size(leg: &LegModel) -> f64 {
    let origins: f64 = leg
        .joints
        .iter()
        .map(|j| (j.origin[0].powi(2) + j.origin[1].powi(2) + j.origin[2].powi(2)).sqrt())
        .sum();
    let attachment = leg.attachment.iter().map(|v| v * v).sum::<f64>().sqrt();
    let actuated = &leg.joints[leg.moving[leg.actuated]];
    let offset = if actuated.kind == JointKind::Prismatic {
        leg.offset.abs()
    } else {
        0.0
    };
    origins + attachment + offset
}

/// A length for messages: whole metres when large, else four significant digits.
fn length(value: f64) -> String {
    if !value.is_finite() {
        "more than 1e308".into()
    } else if value >= 100.0 {
        format!("{value:.0}")
    } else {
        format!("{value:.4}")
    }
}
