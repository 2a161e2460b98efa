//! The arms of a Monte Carlo study: the strategies it compares, with their names in reports
//! and JSON keys.

use crate::identify::estimate::Strategy;

/// The strategies a study compares, in report order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arm {
    /// Divide and conquer on each leg's own selected poses.
    DivideAndConquer,
    /// All legs at once on the shared selected poses (as many as one leg's set).
    Traditional,
    /// All legs at once on as many shared poses as divide and conquer measures in all.
    TraditionalEqualPoses,
    /// Through the instrument: every leg and the instrument together (Schur complement).
    Joint,
    /// Through the instrument: the instrument registered first, then divide and conquer.
    TwoStage,
}

/// The arms of a study without an instrument, in report order.
pub const ARMS: [Arm; 3] = [
    Arm::DivideAndConquer,
    Arm::Traditional,
    Arm::TraditionalEqualPoses,
];

/// The arms of a study through an instrument, in report order.
pub const INSTRUMENT_ARMS: [Arm; 2] = [Arm::Joint, Arm::TwoStage];

impl Arm {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Arm::DivideAndConquer => "D&C",
            Arm::Traditional => "traditional",
            Arm::TraditionalEqualPoses => "traditional, equal poses",
            Arm::Joint => "joint",
            Arm::TwoStage => "two-stage",
        }
    }

    /// Key in the JSON report.
    pub fn key(self) -> &'static str {
        match self {
            Arm::DivideAndConquer => "divide_and_conquer",
            Arm::Traditional => "traditional",
            Arm::TraditionalEqualPoses => "traditional_equal_poses",
            Arm::Joint => "joint",
            Arm::TwoStage => "two_stage",
        }
    }

    /// The plain strategy of an arm without an instrument (the instrument's arms identify each
    /// leg from its own rows, as divide and conquer).
    pub(super) fn strategy(self) -> Strategy {
        match self {
            Arm::Traditional | Arm::TraditionalEqualPoses => Strategy::Traditional,
            Arm::DivideAndConquer => Strategy::DivideAndConquer,
            Arm::Joint => Strategy::Joint,
            Arm::TwoStage => Strategy::TwoStage,
        }
    }
}
