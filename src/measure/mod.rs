//! Measurements: measured platform poses with actuator readings, from a CSV file or simulated.
pub mod checks;
mod data;
pub mod file;
pub mod forward_simulate;
mod line_endings;
pub mod observations;
mod observations_csv;
pub mod observe_simulate;
mod observed;
mod observed_rows;
mod rows;
pub mod simulate;
pub mod targets;

use std::path::PathBuf;

pub use data::{Measurements, STDIN_NAME};

/// One measured platform pose (its readings are kept by its [`MeasurementSet`], flat:
/// [`MeasurementSet::readings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredPose {
    /// Line in the source file (1-based, the header is line 1), if read from a file.
    pub line: Option<usize>,
    /// The leg whose identification set the pose belongs to; `None` for a pose shared by all.
    pub leg: Option<usize>,
    /// Measured pose `[x, y, z, roll, pitch, yaw]` (unmeasured coordinates at their home value).
    pub pose: [f64; 6],
}

/// One measured pose and one leg's measured actuator reading at it: a residual block of the
/// identification (one leg × one pose, Ceres' residual block).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualBlock {
    /// Index of the leg.
    pub leg: usize,
    /// Measured platform pose `[x, y, z, roll, pitch, yaw]` (metres, radians).
    pub pose: [f64; 6],
    /// Measured raw actuator reading.
    pub reading: f64,
    /// Line of the measurement file the pose came from (1-based, counting the header), if any.
    pub line: Option<usize>,
}

/// A set of measured poses and the readings taken at each, one per leg (`None` when not read).
///
/// The readings are stored flat, [`MeasurementSet::legs`] values a pose (no allocation per
/// pose: a million rows of a two-legged mechanism take 112 MB).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeasurementSet {
    /// The file the measurements came from, if any.
    pub source: Option<PathBuf>,
    /// The poses, in file order.
    poses: Vec<MeasuredPose>,
    /// Pose `i`'s readings are `readings[i * legs..(i + 1) * legs]`.
    readings: Vec<Option<f64>>,
    /// Readings per pose (the mechanism's number of legs).
    legs: usize,
}

impl MeasurementSet {
    /// An empty set for a mechanism of `legs` legs.
    pub fn new(source: Option<PathBuf>, legs: usize) -> Self {
        Self {
            source,
            poses: Vec::new(),
            readings: Vec::new(),
            legs,
        }
    }

    /// A set of the `rows` (each pose with its readings, one per leg).
    ///
    /// # Panics
    /// If a row does not have `legs` readings.
    pub fn from_rows(
        source: Option<PathBuf>,
        legs: usize,
        rows: impl IntoIterator<Item = (MeasuredPose, Vec<Option<f64>>)>,
    ) -> Self {
        let mut set = Self::new(source, legs);
        for (pose, readings) in rows {
            set.push(pose, &readings);
        }
        set
    }

    /// Appends a pose and its readings (one per leg).
    ///
    /// # Panics
    /// If `readings` does not have [`MeasurementSet::legs`] values.
    pub fn push(&mut self, pose: MeasuredPose, readings: &[Option<f64>]) {
        assert_eq!(readings.len(), self.legs, "one reading per leg");
        self.poses.push(pose);
        self.readings.extend_from_slice(readings);
    }

    /// Appends every pose of `other` (of the same mechanism) with its readings.
    ///
    /// # Panics
    /// If `other` has another number of readings per pose.
    pub fn extend(&mut self, other: &MeasurementSet) {
        assert_eq!(other.legs, self.legs, "one reading per leg");
        self.poses.extend_from_slice(&other.poses);
        self.readings.extend_from_slice(&other.readings);
    }

    /// Frees the capacity beyond the poses held.
    pub fn shrink_to_fit(&mut self) {
        self.poses.shrink_to_fit();
        self.readings.shrink_to_fit();
    }

    /// Readings per pose (the mechanism's number of legs).
    pub fn legs(&self) -> usize {
        self.legs
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// Whether the set has no pose.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// The poses, in file order.
    pub fn poses(&self) -> &[MeasuredPose] {
        &self.poses
    }

    /// Pose `index`'s readings, one per leg.
    pub fn readings(&self, index: usize) -> &[Option<f64>] {
        &self.readings[index * self.legs..(index + 1) * self.legs]
    }

    /// Pose `index`'s readings, to change in place.
    pub fn readings_mut(&mut self, index: usize) -> &mut [Option<f64>] {
        &mut self.readings[index * self.legs..(index + 1) * self.legs]
    }

    /// Every pose with its readings, in file order.
    pub fn rows(&self) -> impl ExactSizeIterator<Item = (&MeasuredPose, &[Option<f64>])> + '_ {
        self.poses
            .iter()
            .enumerate()
            .map(|(i, pose)| (pose, self.readings(i)))
    }

    /// The poses for which `keep` holds (given the pose and its readings), with their
    /// readings, in order.
    pub fn filtered(&self, keep: impl Fn(&MeasuredPose, &[Option<f64>]) -> bool) -> Self {
        let mut set = Self::new(self.source.clone(), self.legs);
        for (pose, readings) in self.rows().filter(|(p, r)| keep(p, r)) {
            set.push(*pose, readings);
        }
        set
    }

    /// Divide and conquer: the blocks of leg `leg` — the poses labelled with the leg, or, if
    /// no pose is, the shared poses where the leg's reading is present.
    pub fn leg_blocks(&self, leg: usize) -> Vec<ResidualBlock> {
        // The label of the leg's poses: the leg, or none (the shared poses).
        let label = self.poses.iter().any(|p| p.leg == Some(leg)).then_some(leg);
        self.rows()
            .filter(|(p, _)| p.leg == label)
            .filter_map(|(p, r)| block(p, r, leg))
            .collect()
    }

    /// Traditional: the blocks of every leg at the shared poses (rows without a leg label).
    pub fn shared_blocks(&self, legs: usize) -> Vec<ResidualBlock> {
        let shared = || self.rows().filter(|(p, _)| p.leg.is_none());
        (0..legs)
            .flat_map(|leg| shared().filter_map(move |(p, r)| block(p, r, leg)))
            .collect()
    }

    /// Number of shared poses (rows without a leg label).
    pub fn shared_count(&self) -> usize {
        self.poses.iter().filter(|p| p.leg.is_none()).count()
    }
}

fn block(pose: &MeasuredPose, readings: &[Option<f64>], leg: usize) -> Option<ResidualBlock> {
    readings[leg].map(|reading| ResidualBlock {
        leg,
        pose: pose.pose,
        reading,
        line: pose.line,
    })
}
