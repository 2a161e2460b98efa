//! Kinematics as free functions over the immutable model, generic over the scalar.
mod arc_tangent;
pub mod assembly;
pub mod chain;
mod circle_intersection;
pub mod dyad;
pub mod inverse;
pub mod kernel;
mod kernel_forward;
pub use kernel_forward::KernelRows;
mod newton_stop;
pub mod platform;
mod pose_derivative;
pub mod reading;
pub mod singularity;
