//! The workspace region and the usable workspace, declared by the model file: they live in
//! [`crate::model`] (re-exported here for the workspace computations).

pub use crate::model::region::Region;
pub use crate::model::workspace::{Workspace, DEFAULT_RANGE_LEVELS, DEFAULT_SINGULARITY_THRESHOLD};

/// The planar parry queries the MIW uses.
pub(crate) mod geometry {
    pub(crate) use crate::model::region::{closed_polyline, distance_to};
}
