//! The legs: each chain is a path of URDF joints from the root link, with its actuator and
//! attachment point.

use std::collections::{HashMap, HashSet};

use super::plausible::{tiny_gain, MIN_GAIN};
use super::Builder;
use crate::error::Result;
use crate::model::file::ModelFile;
use crate::model::joint::JointModel;
use crate::model::leg::LegModel;

/// True when `name` can stand in a CSV cell as written and be read back: not empty, without
/// commas, quotes or line breaks, and without spaces at either end (cells are trimmed).
pub(super) fn is_cell_name(name: &str) -> bool {
    !name.is_empty()
        && name.trim() == name
        && !name.contains(|c: char| c == ',' || c == '"' || c.is_control())
}

impl Builder<'_> {
    pub(super) fn legs(&self, file: &ModelFile, closure_dims: usize) -> Result<Vec<LegModel>> {
        if file.legs.is_empty() {
            return Err(self.error("legs", "at least one leg is needed"));
        }
        let joints: HashMap<&str, &urdf_rs::Joint> = self
            .robot
            .joints
            .iter()
            .map(|j| (j.name.as_str(), j))
            .collect();
        let children: HashSet<&str> = self
            .robot
            .joints
            .iter()
            .map(|j| j.child.link.as_str())
            .collect();
        let mut seen_legs = HashSet::new();
        let mut used_joints: HashMap<&str, &str> = HashMap::new();
        let mut legs = Vec::new();
        for (l, entry) in file.legs.iter().enumerate() {
            if !is_cell_name(&entry.name) {
                return Err(self.error(
                    format!("legs[{l}].name"),
                    format!(
                        "`{}` cannot label measurement rows (the `leg` column of a CSV): \
                         expected a non-empty name without commas, quotes, line breaks or \
                         spaces at either end",
                        entry.name
                    ),
                ));
            }
            if !seen_legs.insert(entry.name.as_str()) {
                return Err(self.error(
                    format!("legs[{l}].name"),
                    format!("leg `{}` is defined twice", entry.name),
                ));
            }
            if entry.chain.is_empty() {
                return Err(self.error(format!("legs[{l}].chain"), "the chain is empty"));
            }
            let mut chain = Vec::new();
            for (c, name) in entry.chain.iter().enumerate() {
                let field = format!("legs[{l}].chain[{c}]");
                let Some(joint) = joints.get(name.as_str()) else {
                    return Err(self.error(
                        field,
                        format!("joint `{name}` is not in the URDF `{}`", self.urdf_name()),
                    ));
                };
                if let Some(other) = used_joints.insert(name.as_str(), entry.name.as_str()) {
                    return Err(self.error(field, format!("joint `{name}` is already in leg `{other}`; legs must not share joints")));
                }
                if c == 0 && children.contains(joint.parent.link.as_str()) {
                    return Err(self.error(field, format!("joint `{name}` does not start at the URDF root link (its parent `{}` is a child of another joint)", joint.parent.link)));
                }
                if let Some(previous) = c.checked_sub(1).map(|p| joints[entry.chain[p].as_str()]) {
                    if previous.child.link != joint.parent.link {
                        return Err(self.error(field, format!("joint `{name}` does not follow `{}`: its parent link is `{}`, expected `{}`", previous.name, joint.parent.link, previous.child.link)));
                    }
                }
                chain.push(
                    JointModel::from_urdf(joint)
                        .map_err(|m| self.error(format!("legs[{l}].chain[{c}]"), m))?,
                );
            }
            let moving: Vec<usize> = (0..chain.len()).filter(|&j| chain[j].is_moving()).collect();
            if moving.len() != closure_dims {
                return Err(self.error(
                    format!("legs[{l}].chain"),
                    unknowns_mismatch(&entry.name, &chain, &moving, closure_dims),
                ));
            }
            let actuator = &entry.actuator;
            let Some(actuated) = moving.iter().position(|&j| chain[j].name == actuator.joint)
            else {
                return Err(self.error(
                    format!("legs[{l}].actuator.joint"),
                    format!(
                        "`{}` is not a moving joint of the leg's chain",
                        actuator.joint
                    ),
                ));
            };
            if !(actuator.gain.is_finite() && actuator.gain != 0.0) {
                return Err(self.error(
                    format!("legs[{l}].actuator.gain"),
                    "expected a finite non-zero number",
                ));
            }
            if actuator.gain.abs() < MIN_GAIN {
                return Err(
                    self.error(format!("legs[{l}].actuator.gain"), tiny_gain(actuator.gain))
                );
            }
            if !actuator.offset.is_finite() {
                return Err(self.error(
                    format!("legs[{l}].actuator.offset"),
                    "expected a finite number",
                ));
            }
            let attachment = entry.attachment.unwrap_or([0.0; 3]);
            if attachment.iter().any(|v| !v.is_finite()) {
                return Err(self.error(
                    format!("legs[{l}].attachment"),
                    "expected three finite numbers (metres)",
                ));
            }
            legs.push(LegModel {
                name: entry.name.clone(),
                joints: chain,
                moving,
                actuated,
                gain: actuator.gain,
                offset: actuator.offset,
                attachment,
                params: Vec::new(),
                closure_dims,
                home_joints: Vec::new(),
                branch_sign: 1.0,
            });
        }
        Ok(legs)
    }
}

/// Why a chain is refused when its unknowns (moving joints) do not match its closure equations.
fn unknowns_mismatch(
    leg: &str,
    chain: &[JointModel],
    moving: &[usize],
    closure_dims: usize,
) -> String {
    let names: Vec<&str> = moving.iter().map(|&j| chain[j].name.as_str()).collect();
    let equations = if closure_dims == 3 {
        "3 closure equations (its tip meets its attachment in x, y and z, since z is measured)"
    } else {
        "2 closure equations (its tip meets its attachment in x and y, since z is not measured)"
    };
    let advice = if moving.len() > closure_dims {
        "too many unknowns: make a joint `fixed`, or end the chain at the attachment point and \
         leave out the joints that only turn about it (a spherical joint at the platform)"
    } else {
        "too few unknowns: the leg could not reach the poses around one it reaches"
    };
    format!(
        "leg `{leg}` has {} moving joints ({}) but {equations}; a leg needs as many moving \
         joints as closure equations: {advice}",
        moving.len(),
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        },
    )
}
