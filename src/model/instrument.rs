//! The measuring instrument: its frame in the base frame and the targets it measures on the
//! platform (the model file's optional `instrument` block), as written on disk and validated.
//!
//! A laser tracker, a camera or a CMM reports its targets in its own frame; each target sits
//! at an offset from the platform's reference point. The instrument's parameters (the frame's
//! pose, the targets' offsets) are *shared* by all legs: `docs/models.md` describes the block,
//! `docs/method.md` the identification with them.
//!
//! The shared parameter vector is laid out as: the frame's components (`frame_x frame_y
//! frame_yaw` for a planar model), then each target's offset components (`target_x target_y`,
//! suffixed `_<name>` when there are several targets), in file order.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::params::Unit;

/// The `instrument` block of a model file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentEntry {
    /// The instrument frame in the base frame.
    pub frame: FrameEntry,
    /// The targets on the platform the instrument measures.
    pub targets: Vec<TargetEntry>,
}

/// The instrument frame.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FrameEntry {
    /// Nominal pose of the instrument frame in the base frame, by component (`x y yaw` for a
    /// planar model; metres, radians); a missing component is zero.
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
    /// (`[x, y]` for a planar model), metres.
    pub offset: Vec<f64>,
    /// What the instrument reports of the target: `position`, or `pose` (position and
    /// orientation; the target's axes are the platform's).
    pub measures: String,
    /// The identified offset components (default: all of them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identify: Option<Vec<String>>,
    /// Standard deviation of the simulation's perturbation of the identified components, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perturbation: Option<f64>,
}

/// What the instrument reports of a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Measures {
    /// The target's position (a tracker's reflector).
    Position,
    /// The target's position and orientation (a camera's marker).
    Pose,
}

/// Components of the planar instrument frame, in the shared vector's order.
pub const PLANAR_FRAME: [&str; 3] = ["x", "y", "yaw"];

/// Components of a planar target offset, in the shared vector's order.
pub const PLANAR_OFFSET: [&str; 2] = ["x", "y"];

/// A validated target.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Name.
    pub name: String,
    /// What the instrument reports of it.
    pub measures: Measures,
}

impl Target {
    /// The coordinates the instrument reports of this target, in measurement-row order:
    /// `x y` for a position, `x y yaw` for a pose (planar).
    pub fn coordinates(&self) -> &'static [&'static str] {
        match self.measures {
            Measures::Position => &["x", "y"],
            Measures::Pose => &["x", "y", "yaw"],
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

/// The validated instrument (planar): frame and targets.
#[derive(Debug, Clone, PartialEq)]
pub struct Instrument {
    /// The shared parameters: frame `x y yaw`, then each target's offset `x y`.
    pub parameters: Vec<SharedParameter>,
    /// The targets, in file order.
    pub targets: Vec<Target>,
    /// Does the platform rotate (is its yaw measured)? If not, the pose's yaw stays at home.
    pub rotates: bool,
}

impl Instrument {
    /// Index in the shared vector of the frame's first component (x; then y, yaw).
    pub const FRAME: usize = 0;

    /// Index in the shared vector of target `target`'s offset x (y follows).
    pub fn offset_index(&self, target: usize) -> usize {
        PLANAR_FRAME.len() + PLANAR_OFFSET.len() * target
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
