//! The home pose and each leg's home configuration (its joints' seeds, checked for presence
//! here; solved at the home pose, which fixes the branch, by [`crate::kinematics::assembly`]).

use std::collections::BTreeMap;

use super::Builder;
use crate::error::Result;
use crate::model::leg::LegModel;
use crate::model::mechanism::COORDINATES;

impl Builder<'_> {
    pub(super) fn home_pose(
        &self,
        pose: &BTreeMap<String, f64>,
        measured: &[usize],
    ) -> Result<[f64; 6]> {
        let mut home = [0.0; 6];
        for (name, &value) in pose {
            match COORDINATES.iter().position(|c| c == name) {
                Some(i) if measured.contains(&i) && value.is_finite() => home[i] = value,
                Some(i) if measured.contains(&i) => {
                    return Err(self.error(format!("home.pose.{name}"), "expected a finite number"))
                }
                _ => {
                    return Err(self.error(
                        format!("home.pose.{name}"),
                        "not a measured coordinate (see `measured`)",
                    ))
                }
            }
        }
        for &i in measured {
            if !pose.contains_key(COORDINATES[i]) {
                return Err(self.error(
                    format!("home.pose.{}", COORDINATES[i]),
                    "missing: the home pose needs every measured coordinate",
                ));
            }
        }
        Ok(home)
    }

    pub(super) fn home(
        &self,
        leg: &mut LegModel,
        index: usize,
        seeds: &BTreeMap<String, f64>,
    ) -> Result<()> {
        let field = format!("legs[{index}].home");
        let mut seed = Vec::new();
        for &j in &leg.moving {
            let name = &leg.joints[j].name;
            match seeds.get(name) {
                Some(v) if v.is_finite() => seed.push(*v),
                Some(v) => {
                    return Err(self.error(
                        format!("{field}.{name}"),
                        format!("expected a finite number, found {v}"),
                    ))
                }
                None => {
                    return Err(self.error(
                        format!("{field}.{name}"),
                        "missing: every moving joint of the leg needs a home value",
                    ))
                }
            }
        }
        if let Some(extra) = seeds
            .keys()
            .find(|k| !leg.moving.iter().any(|&j| &&leg.joints[j].name == k))
        {
            return Err(self.error(
                format!("{field}.{extra}"),
                "not a moving joint of the leg's chain",
            ));
        }
        // The kinematic checks (planar axes, closure at the home pose, branch) are
        // `crate::kinematics::assembly`'s: this module stays below the kinematics.
        leg.home_joints = seed;
        Ok(())
    }
}
