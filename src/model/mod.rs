//! What the mechanism is: the model file, the URDF legs and the validated [`Mechanism`].
pub mod expression;
pub mod file;
pub mod instrument;
pub mod joint;
pub mod leg;
pub mod load;
pub mod mechanism;
pub mod params;
pub mod prior_covariance;
pub mod quantities;
pub mod region;
pub mod source;
pub mod urdf;
mod urdf_scan;
pub mod with_prior;
pub mod with_values;
pub mod workspace;
mod yaml_errors;

pub use mechanism::Mechanism;
