//! The scalar abstraction: kinematics is written once and runs on `f64` and on dual numbers.

use nalgebra::RealField;
use num_dual::DualNum;

/// A real number type the kinematics can run on: `f64` or one of num-dual's `Copy` dual types.
///
/// `re()` (from [`num_dual::DualStruct`]) gives the `f64` value part.
pub trait Scalar: RealField + DualNum<f64> + Copy {}

impl<T: RealField + DualNum<f64> + Copy> Scalar for T {}

/// Lifts an `f64` constant into the scalar type (Ceres' "T(k)").
#[inline]
pub fn lift<T: Scalar>(value: f64) -> T {
    T::from(value)
}
