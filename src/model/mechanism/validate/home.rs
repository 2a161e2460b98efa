//! The home pose and each leg's home configuration, which fixes its branch (working mode).

use std::collections::BTreeMap;

use super::Builder;
use crate::error::Result;
use crate::kinematics::chain::moving_axes;
use crate::kinematics::inverse::newton;
use crate::model::joint::JointKind;
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
        home_pose: &[f64; 6],
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
        let geometry = leg.geometry(&leg.nominal());
        if leg.closure_dims == 2 {
            // A planar model: revolute joints must turn about z, prismatic ones slide in x, y.
            let axes = moving_axes(leg, &geometry, &seed);
            for ((kind, axis), &j) in axes.iter().zip(&leg.moving) {
                let planar = match kind {
                    JointKind::Revolute => axis.z.abs() > 1.0 - 1e-9,
                    _ => axis.z.abs() < 1e-9,
                };
                if !planar {
                    let name = &leg.joints[j].name;
                    return Err(self.error(
                        format!("legs[{index}].chain"),
                        format!(
                            "joint `{name}` has world axis ({:.3}, {:.3}, {:.3}) at home; a planar model (z not measured) needs revolute axes along z and prismatic axes in the x-y plane (check its <axis> in the URDF)",
                            axis.x, axis.y, axis.z
                        ),
                    ));
                }
            }
        }
        let solution = newton(leg, &geometry, home_pose, &seed).map_err(|err| {
            self.error(
                &field,
                format!("the home configuration does not close at the home pose: {err}"),
            )
        })?;
        leg.branch_sign = solution.normalised_determinant.signum();
        leg.home_joints = solution.q;
        Ok(())
    }
}
