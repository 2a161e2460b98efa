//! The scalar abstraction: kinematics is written once and runs on `f64` and on dual numbers.

use nalgebra::{Const, RealField, U1};
use num_dual::{Dual64, DualNum, DualSVec64};

/// A real number type the kinematics can run on: `f64` or one of num-dual's `Copy` dual types.
///
/// `re()` (from [`num_dual::DualStruct`]) gives the `f64` value part.
pub trait Scalar: RealField + DualNum<f64> + Copy + Constant {}

impl<T: RealField + DualNum<f64> + Copy + Constant> Scalar for T {}

/// Whether a value carries no derivative: an `f64` always, a dual number when every one of its
/// derivative parts is zero (a parameter nobody differentiates by).
pub trait Constant {
    /// True if the value has no non-zero derivative part.
    fn is_constant(&self) -> bool;
}

impl Constant for f64 {
    #[inline]
    fn is_constant(&self) -> bool {
        true
    }
}

impl Constant for Dual64 {
    #[inline]
    fn is_constant(&self) -> bool {
        self.eps == 0.0
    }
}

impl<const N: usize> Constant for DualSVec64<N> {
    #[inline]
    fn is_constant(&self) -> bool {
        self.eps
            .unwrap_generic(Const::<N>, U1)
            .iter()
            .all(|&lane| lane == 0.0)
    }
}

/// Lifts an `f64` constant into the scalar type (Ceres' "T(k)").
#[inline]
pub fn lift<T: Scalar>(value: f64) -> T {
    T::from(value)
}

#[cfg(test)]
mod tests {
    use num_dual::{Dual64, DualSVec64};

    use super::*;

    /// A value is constant exactly when none of its derivative parts is non-zero.
    #[test]
    fn a_value_is_constant_without_a_derivative() {
        assert!(2.5f64.is_constant());
        assert!(Dual64::from_re(2.5).is_constant());
        assert!(!Dual64::from_re(2.5).derivative().is_constant());
        assert!(!Dual64::new(0.0, -1e-300).is_constant());
        assert!(DualSVec64::<3>::from_re(0.0).is_constant());
        for lane in 0..3 {
            assert!(!DualSVec64::<3>::from_re(0.0).derivative(lane).is_constant());
        }
    }
}
