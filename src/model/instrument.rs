//! The measuring instrument: its frame in the base frame and the targets it measures on the
//! platform (the model file's optional `instrument` block), as written on disk and validated.
//!
//! A laser tracker, a camera or a CMM reports its targets in its own frame; each target sits
//! at an offset from the platform's reference point. The instrument's parameters (the frame's
//! pose, the targets' offsets) are *shared* by all legs: `docs/models.md` describes the block,
//! `docs/method.md` the identification with them.
//!
//! The shared parameter vector is laid out as: the frame's components (`frame_x frame_y
//! frame_yaw` for a planar model, `frame_x frame_y frame_z frame_roll frame_pitch frame_yaw` for
//! a spatial one), then each target's offset components (`target_x target_y [target_z]`,
//! suffixed `_<name>` when there are several targets), in file order.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::params::Unit;

/// The `instrument` block of a model file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentEntry {
    /// How a row's prediction goes: `inverse` (the default: the platform pose is fitted from
    /// the targets, each leg predicts its reading) or `forward` (the platform pose is the
    /// forward kinematics of every leg's reading, and the targets' coordinates are predicted
    /// from it: for targets that do not give the whole pose, such as a bed probe's height or
    /// one reflector on a rotating platform).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinematics: Option<String>,
    /// The instrument frame in the base frame.
    pub frame: FrameEntry,
    /// The targets on the platform the instrument measures.
    pub targets: Vec<TargetEntry>,
    /// Forward kinematics only: measured distances between one target's positions at two rows
    /// (a ballbar, calipers on a printed part), given as rows of their own in the CSV.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distances: Option<DistancesEntry>,
    /// Forward kinematics only: rows may also carry a platform pose measured in the base frame
    /// (a few tracker poses beside many probe touches), each leg's reading predicted from it by
    /// its inverse kinematics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poses: Option<PosesEntry>,
    /// Forward kinematics only: the largest predicted standard deviation of the first target's
    /// position over the workspace a calibration may leave, metres (above it the result is
    /// not trusted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
}

/// The `instrument.distances` block: which target's positions the distances join, their
/// noise, and how many the simulation measures.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DistancesEntry {
    /// The target whose positions at two rows a distance joins.
    pub target: String,
    /// Standard deviation of a measured distance, metres.
    pub noise: f64,
    /// Simulation: how many distances between pairs of simulated rows are measured.
    #[serde(default)]
    pub simulate: usize,
}

/// The `instrument.poses` block: the noise of the platform poses measured at some rows, and how
/// many the simulation measures.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PosesEntry {
    /// Standard deviation of each measured pose coordinate, by the model's coordinate names
    /// (metres, radians).
    pub noise: BTreeMap<String, f64>,
    /// Simulation: how many rows at random poses of the workspace carry their measured pose.
    #[serde(default)]
    pub simulate: usize,
}

/// Validated measured platform poses of a forward model's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredPoses {
    /// Standard deviation of each pose coordinate `[x, y, z, roll, pitch, yaw]` (zero for the
    /// coordinates the model does not measure).
    pub noise: [f64; 6],
    /// How many the simulation measures.
    pub simulate: usize,
}

/// Validated distance measurements of an instrument.
#[derive(Debug, Clone, PartialEq)]
pub struct Distances {
    /// Index of the target whose positions they join.
    pub target: usize,
    /// Standard deviation of a measured distance, metres.
    pub noise: f64,
    /// How many the simulation measures.
    pub simulate: usize,
}

/// The instrument frame.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FrameEntry {
    /// Nominal pose of the instrument frame in the base frame, by component (`x y yaw` for a
    /// planar model, `x y z roll pitch yaw` for a spatial one; metres, radians); a missing
    /// component is zero.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub pose: BTreeMap<String, f64>,
    /// The identified components (default: all of them); the others stay at their nominal value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identify: Option<Vec<String>>,
    /// Standard deviations of the simulation's perturbation of the identified components.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perturbation: Option<FramePerturbation>,
}

/// Perturbation sizes of the instrument frame (simulation).
#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FramePerturbation {
    /// Of the translation components, metres.
    #[serde(default)]
    pub length: f64,
    /// Of the rotation components, radians.
    #[serde(default)]
    pub angle: f64,
}

/// One target on the platform.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TargetEntry {
    /// Name, used in the measurement columns (`x.<name>`) and the parameter names.
    pub name: String,
    /// Nominal offset of the target from the platform's reference point, in the platform frame
    /// (`[x, y]` for a planar model, `[x, y, z]` for a spatial one), metres.
    pub offset: Vec<f64>,
    /// What the instrument reports of the target: `position`, `pose` (position and
    /// orientation; the target's axes are the platform's), or a list of some of its position
    /// coordinates in the instrument frame (`[z]`: a height; forward kinematics only).
    pub measures: MeasuresEntry,
    /// The identified offset components (default: all of them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identify: Option<Vec<String>>,
    /// Standard deviation of the simulation's perturbation of the identified components, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perturbation: Option<f64>,
    /// For a target measuring one coordinate: every row is a touch, where that coordinate is
    /// this value (a probe touching the bed: `0.0`). Simulation moves each pose along the
    /// platform coordinate of the same name until it holds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub touch: Option<f64>,
}

/// The `measures` field of a target as written: a word or a list of coordinates.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(untagged)]
pub enum MeasuresEntry {
    /// `position` or `pose`.
    Word(String),
    /// Some of the position's coordinates, `[z]` or `[x, y]`.
    Coordinates(Vec<String>),
}

/// What the instrument reports of a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measures {
    /// The target's position (a tracker's reflector).
    Position,
    /// The target's position and orientation (a camera's marker).
    Pose,
    /// Some of the position's coordinates in the instrument frame: bit 0 `x`, bit 1 `y`,
    /// bit 2 `z` (a probe's height is `z` alone). Forward kinematics only.
    Coordinates(u8),
}

/// The position coordinates of each [`Measures::Coordinates`] mask (index = mask), and their
/// indices in `[x, y, z]`.
const COORDINATE_SUBSETS: [(&[&str], &[usize]); 8] = [
    (&[], &[]),
    (&["x"], &[0]),
    (&["y"], &[1]),
    (&["x", "y"], &[0, 1]),
    (&["z"], &[2]),
    (&["x", "z"], &[0, 2]),
    (&["y", "z"], &[1, 2]),
    (&["x", "y", "z"], &[0, 1, 2]),
];

/// Components of the planar instrument frame, in the shared vector's order.
pub const PLANAR_FRAME: [&str; 3] = ["x", "y", "yaw"];

/// Components of a planar target offset, in the shared vector's order.
pub const PLANAR_OFFSET: [&str; 2] = ["x", "y"];

/// Components of the spatial instrument frame, in the shared vector's order (the rotation is
/// `Rz(yaw) Ry(pitch) Rx(roll)`, as the platform pose's).
pub const SPATIAL_FRAME: [&str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];

/// Components of a spatial target offset, in the shared vector's order.
pub const SPATIAL_OFFSET: [&str; 3] = ["x", "y", "z"];

/// A validated target.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Name.
    pub name: String,
    /// What the instrument reports of it.
    pub measures: Measures,
    /// Of a spatial model (3-D coordinates) rather than a planar one.
    pub spatial: bool,
    /// The value of its one coordinate at every row, if the rows are touches.
    pub touch: Option<f64>,
}

impl Target {
    /// The coordinates the instrument reports of this target, in measurement-row order:
    /// `x y` for a position, `x y yaw` for a pose (planar); `x y z`, `x y z roll pitch yaw`
    /// (spatial).
    pub fn coordinates(&self) -> &'static [&'static str] {
        match (self.spatial, self.measures) {
            (false, Measures::Position) => &["x", "y"],
            (false, Measures::Pose) => &["x", "y", "yaw"],
            (true, Measures::Position) => &["x", "y", "z"],
            (true, Measures::Pose) => &SPATIAL_FRAME,
            (_, Measures::Coordinates(mask)) => COORDINATE_SUBSETS[usize::from(mask & 7)].0,
        }
    }

    /// For each of [`Self::coordinates`], the index of the pose coordinate of the same name in
    /// `[x, y, z, roll, pitch, yaw]` (whose noise the coordinate has).
    pub fn pose_indices(&self) -> &'static [usize] {
        match (self.spatial, self.measures) {
            (false, Measures::Position) => &[0, 1],
            (false, Measures::Pose) => &[0, 1, 5],
            (true, Measures::Position) => &[0, 1, 2],
            (true, Measures::Pose) => &[0, 1, 2, 3, 4, 5],
            (_, Measures::Coordinates(mask)) => COORDINATE_SUBSETS[usize::from(mask & 7)].1,
        }
    }
}

/// One shared parameter of the instrument.
#[derive(Debug, Clone, PartialEq)]
pub struct SharedParameter {
    /// Name (`frame_x`, `target_y_t2`, …).
    pub name: String,
    /// Nominal value, SI units.
    pub nominal: f64,
    /// Identified (true) or held at its nominal value.
    pub identified: bool,
    /// SI unit.
    pub unit: Unit,
    /// Standard deviation of the simulation's perturbation (used when identified).
    pub perturbation: f64,
}

/// The validated instrument: frame and targets.
#[derive(Debug, Clone, PartialEq)]
pub struct Instrument {
    /// The shared parameters: the frame's components ([`Self::frame_components`]), then each
    /// target's offset components ([`Self::offset_components`]).
    pub parameters: Vec<SharedParameter>,
    /// The targets, in file order.
    pub targets: Vec<Target>,
    /// Does the platform rotate (is its yaw, or any of its roll, pitch, yaw for a spatial
    /// model, measured)? If not, the pose's orientation stays at home.
    pub rotates: bool,
    /// A spatial model (6-DoF frame, 3-D offsets) rather than a planar one.
    pub spatial: bool,
    /// Rows are predicted through the forward kinematics (`kinematics: forward`): the platform
    /// pose from every leg's reading, the targets' coordinates from the pose.
    pub forward: bool,
    /// Measured distances between a target's positions at two rows (forward only).
    pub distances: Option<Distances>,
    /// Platform poses measured in the base frame at some rows (forward only).
    pub poses: Option<MeasuredPoses>,
    /// The largest predicted σ of the first target's position over the workspace a
    /// calibration may leave, metres (forward only).
    pub tolerance: Option<f64>,
}

impl Instrument {
    /// Index in the shared vector of the frame's first component (x; then the others of
    /// [`Self::frame_components`]).
    pub const FRAME: usize = 0;

    /// The frame's components, in the shared vector's order: [`PLANAR_FRAME`] or
    /// [`SPATIAL_FRAME`].
    pub fn frame_components(&self) -> &'static [&'static str] {
        if self.spatial {
            &SPATIAL_FRAME
        } else {
            &PLANAR_FRAME
        }
    }

    /// A target offset's components, in the shared vector's order: [`PLANAR_OFFSET`] or
    /// [`SPATIAL_OFFSET`].
    pub fn offset_components(&self) -> &'static [&'static str] {
        if self.spatial {
            &SPATIAL_OFFSET
        } else {
            &PLANAR_OFFSET
        }
    }

    /// Index in the shared vector of target `target`'s offset x (y, and z if spatial, follow).
    pub fn offset_index(&self, target: usize) -> usize {
        self.frame_components().len() + self.offset_components().len() * target
    }

    /// The nominal shared vector.
    pub fn nominal(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }

    /// Indices of the identified shared parameters.
    pub fn identified(&self) -> Vec<usize> {
        (0..self.parameters.len())
            .filter(|&k| self.parameters[k].identified)
            .collect()
    }

    /// Number of values one measurement row holds (every target's coordinates).
    pub fn observed_len(&self) -> usize {
        self.targets.iter().map(|t| t.coordinates().len()).sum()
    }

    /// The measurement column names of the targets, in row order (`x.t1, y.t1, …`).
    pub fn columns(&self) -> Vec<String> {
        self.targets
            .iter()
            .flat_map(|t| {
                t.coordinates()
                    .iter()
                    .map(move |c| format!("{c}.{}", t.name))
            })
            .collect()
    }

    /// Index of the shared parameter called `name`.
    pub fn parameter_index(&self, name: &str) -> Option<usize> {
        self.parameters.iter().position(|p| p.name == name)
    }
}
