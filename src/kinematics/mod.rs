//! Kinematics as free functions over the immutable model, generic over the scalar.
mod arc_tangent;
pub mod assembly;
pub mod carriage_leg;
pub mod chain;
mod circle_intersection;
pub mod distance_leg;
pub mod dyad;
pub mod inverse;
pub mod kernel;
mod kernel_forward;
pub use kernel_forward::KernelRows;
mod newton_stop;
pub mod platform;
pub mod pointing;
pub(crate) mod pose_derivative;
pub mod reading;
pub mod singularity;
mod sphere_intersection;
