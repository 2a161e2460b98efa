//! Measurements: measured platform poses with actuator readings, from a CSV file or simulated.
pub mod checks;
pub mod file;
pub mod observations;
pub mod observe_simulate;
mod rows;
pub mod simulate;
pub mod targets;

use std::path::PathBuf;

/// One measured platform pose and the readings taken there.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredPose {
    /// Line in the source file (1-based, the header is line 1), if read from a file.
    pub line: Option<usize>,
    /// The leg whose identification set the pose belongs to; `None` for a pose shared by all.
    pub leg: Option<usize>,
    /// Measured pose `[x, y, z, roll, pitch, yaw]` (unmeasured coordinates at their home value).
    pub pose: [f64; 6],
    /// Raw reading of each leg's actuated joint, `None` when not read.
    pub readings: Vec<Option<f64>>,
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

/// A set of measured poses.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeasurementSet {
    /// The file the measurements came from, if any.
    pub source: Option<PathBuf>,
    /// The poses, in file order.
    pub poses: Vec<MeasuredPose>,
}

impl MeasurementSet {
    /// Divide and conquer: the blocks of leg `leg` — the poses labelled with the leg, or, if
    /// no pose is, the shared poses where the leg's reading is present.
    pub fn leg_blocks(&self, leg: usize) -> Vec<ResidualBlock> {
        let labelled = self.poses.iter().any(|p| p.leg == Some(leg));
        self.poses
            .iter()
            .filter(|p| {
                if labelled {
                    p.leg == Some(leg)
                } else {
                    p.leg.is_none()
                }
            })
            .filter_map(|p| block(p, leg))
            .collect()
    }

    /// Traditional: the blocks of every leg at the shared poses (rows without a leg label).
    pub fn shared_blocks(&self, legs: usize) -> Vec<ResidualBlock> {
        let mut blocks = Vec::new();
        for leg in 0..legs {
            blocks.extend(
                self.poses
                    .iter()
                    .filter(|p| p.leg.is_none())
                    .filter_map(|p| block(p, leg)),
            );
        }
        blocks
    }

    /// Number of shared poses (rows without a leg label).
    pub fn shared_count(&self) -> usize {
        self.poses.iter().filter(|p| p.leg.is_none()).count()
    }
}

fn block(pose: &MeasuredPose, leg: usize) -> Option<ResidualBlock> {
    pose.readings[leg].map(|reading| ResidualBlock {
        leg,
        pose: pose.pose,
        reading,
        line: pose.line,
    })
}
