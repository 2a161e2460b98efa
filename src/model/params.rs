//! Named kinematic parameters and the quantity each one stands for.

use std::fmt;

use super::expression::Expression;

/// The model quantity a parameter stands for, within its leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamTarget {
    /// Component `component` (0..6: x y z roll pitch yaw) of the origin of chain joint `joint`.
    JointOrigin {
        /// Index of the joint in the leg chain.
        joint: usize,
        /// Origin component index.
        component: usize,
    },
    /// The actuator gain.
    Gain,
    /// The actuator offset.
    Offset,
    /// Component (0..3: x y z) of the platform attachment point.
    Attachment {
        /// Component index.
        component: usize,
    },
}

/// Physical unit of a parameter (SI).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// metres
    Metre,
    /// radians
    Radian,
    /// dimensionless
    One,
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unit::Metre => "m",
            Unit::Radian => "rad",
            Unit::One => "-",
        })
    }
}

/// One parameter of a leg.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Name as in the model file.
    pub name: String,
    /// What it stands for.
    pub target: ParamTarget,
    /// Nominal value (from the URDF or the model file), SI units.
    pub nominal: f64,
    /// Identified (true) or held at its nominal value.
    pub identified: bool,
    /// SI unit.
    pub unit: Unit,
    /// For a derived parameter, the expression of the model's quantities it equals: it follows
    /// them in a factor set that fits one of them; elsewhere `identified` says what it is.
    pub derived: Option<Expression>,
    /// The standard deviation of what is known of it before any measurement, around
    /// `nominal` (model file `prior:`), SI units.
    pub prior: Option<f64>,
}
