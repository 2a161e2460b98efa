//! Joints of a leg chain: a closed set of kinds, converted from URDF with errors naming the joint.

use nalgebra::Vector3;

/// What a joint does when its variable changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Rotation about the joint axis; variable in radians (URDF `revolute` or `continuous`).
    Revolute,
    /// Translation along the joint axis; variable in metres (URDF `prismatic`).
    Prismatic,
    /// No motion (URDF `fixed`).
    Fixed,
}

/// Index of a joint-origin component: `x y z roll pitch yaw`.
pub const ORIGIN_COMPONENTS: [&str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];

/// One joint of a leg chain, with its nominal origin (URDF convention: the joint frame is the
/// parent link frame moved by `origin`; the child link frame is the joint frame moved by the joint
/// variable along or about `axis`).
#[derive(Debug, Clone, PartialEq)]
pub struct JointModel {
    /// URDF joint name.
    pub name: String,
    /// Kind of motion.
    pub kind: JointKind,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    /// Nominal origin `[x, y, z, roll, pitch, yaw]` (metres, radians).
    pub origin: [f64; 6],
    /// The joint's range `[lower, upper]` (metres for a prismatic joint's stroke, radians for a
    /// revolute), from the URDF `<limit>` of a `prismatic` or `revolute` joint; `None` for
    /// `continuous` and `fixed` joints and for a `<limit>` without a range (lower = upper, as a
    /// missing element reads). The workspace computations keep every joint within it.
    pub limits: Option<[f64; 2]>,
}

impl JointModel {
    /// Converts a URDF joint, rejecting kinds a leg chain cannot hold.
    ///
    /// # Errors
    /// A message naming the joint and the expected kinds, or a degenerate axis.
    pub fn from_urdf(joint: &urdf_rs::Joint) -> Result<Self, String> {
        let kind = match joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => JointKind::Revolute,
            urdf_rs::JointType::Prismatic => JointKind::Prismatic,
            urdf_rs::JointType::Fixed => JointKind::Fixed,
            ref other => {
                return Err(format!(
                    "joint `{}` is of type {other:?}; expected revolute, continuous, prismatic or fixed",
                    joint.name
                ))
            }
        };
        let axis = Vector3::from(joint.axis.xyz.0);
        let norm = axis.norm();
        if kind != JointKind::Fixed && !(norm.is_finite() && norm > 1e-12) {
            return Err(format!(
                "joint `{}` has a zero or non-finite axis",
                joint.name
            ));
        }
        let xyz = joint.origin.xyz.0;
        let rpy = joint.origin.rpy.0;
        let origin = [xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]];
        if origin.iter().any(|v| !v.is_finite()) {
            return Err(format!("joint `{}` has a non-finite origin", joint.name));
        }
        let limits = match joint.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic => limits(joint)?,
            _ => None,
        };
        Ok(Self {
            name: joint.name.clone(),
            limits,
            kind,
            axis: if kind == JointKind::Fixed {
                Vector3::z()
            } else {
                axis / norm
            },
            origin,
        })
    }

    /// True for joints with a variable (revolute or prismatic).
    pub fn is_moving(&self) -> bool {
        self.kind != JointKind::Fixed
    }
}

/// The range of a `prismatic` or `revolute` URDF joint: `Some([lower, upper])` when lower <
/// upper, `None` when they are equal (no `<limit>` element reads as 0, 0).
///
/// # Errors
/// A NaN bound, or lower above upper.
fn limits(joint: &urdf_rs::Joint) -> Result<Option<[f64; 2]>, String> {
    let (lower, upper) = (joint.limit.lower, joint.limit.upper);
    if lower.is_nan() || upper.is_nan() || lower > upper {
        return Err(format!(
            "joint `{}` has <limit lower=\"{lower}\" upper=\"{upper}\">; expected lower <= upper",
            joint.name
        ));
    }
    Ok((lower < upper).then_some([lower, upper]))
}
