//! The validated mechanism (ripgrep's "high args"): the model file cross-checked against its
//! URDF. Every error names the file and the field.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::file::{ModelFile, ParameterEntry, RegionEntry};
use super::joint::{JointKind, JointModel, ORIGIN_COMPONENTS};
use super::leg::LegModel;
use super::params::{ParamTarget, Parameter, Unit};
use crate::error::{Error, Result};
use crate::kinematics::chain::moving_axes;
use crate::kinematics::inverse::newton;
use crate::workspace::region::{
    Region, Workspace, DEFAULT_RANGE_LEVELS, DEFAULT_SINGULARITY_THRESHOLD,
};

/// Names of the end-effector coordinates, in pose-vector order (metres, radians).
pub const COORDINATES: [&str; 6] = ORIGIN_COMPONENTS;

/// A complete, validated mechanism. Immutable once loaded.
#[derive(Debug, Clone)]
pub struct Mechanism {
    /// Human-readable name.
    pub name: String,
    /// The model file it was loaded from.
    pub model_path: PathBuf,
    /// The URDF holding the legs.
    pub urdf_path: PathBuf,
    /// The working/assembly mode label from the model file.
    pub mode: Option<String>,
    /// Indices (into [`COORDINATES`]) of the measured coordinates, in file order.
    pub measured: Vec<usize>,
    /// The home platform pose.
    pub home_pose: [f64; 6],
    /// The legs.
    pub legs: Vec<LegModel>,
    /// The usable workspace.
    pub workspace: Workspace,
    /// Pose selection set-up.
    pub selection: SelectionSetup,
    /// The simulation set-up, if any.
    pub simulation: Option<Simulation>,
}

/// Pose selection set-up (validated).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SelectionSetup {
    /// Poses to select per leg.
    pub poses_per_leg: usize,
    /// Design criterion.
    pub criterion: SelectionCriterion,
}

/// Design criterion of the pose selection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SelectionCriterion {
    /// D-optimal: maximise det(CᵀC) (the observability index O1).
    D,
    /// A-optimal: minimise tr (CᵀC)⁻¹ (the sum of the parameter variances).
    A,
    /// E-optimal: maximise the smallest singular value (O3).
    E,
}

/// Simulation set-up (validated).
#[derive(Debug, Clone)]
pub struct Simulation {
    /// Real values by parameter name.
    pub real: BTreeMap<String, f64>,
    /// Perturbation standard deviations `(length m, angle rad, gain)` for parameters not in `real`.
    pub perturbation: Option<(f64, f64, f64)>,
    /// Noise standard deviation per pose coordinate (zero for unmeasured ones).
    pub pose_noise: [f64; 6],
    /// Noise standard deviation of the actuator readings.
    pub reading_noise: f64,
    /// Identification poses per leg.
    pub poses_per_leg: usize,
    /// Random seed.
    pub seed: u64,
}

impl Mechanism {
    /// Loads and validates a model file and the URDF it names.
    ///
    /// # Errors
    /// [`Error::Io`], [`Error::Yaml`], [`Error::Urdf`] or [`Error::Model`] naming the field.
    pub fn load(path: &Path) -> Result<Self> {
        let file = ModelFile::read(path)?;
        let urdf_path = path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(&file.urdf);
        if !urdf_path.is_file() {
            return Err(Error::Model {
                path: path.to_path_buf(),
                field: "urdf".into(),
                message: format!("URDF file `{}` not found", urdf_path.display()),
            });
        }
        let robot = urdf_rs::read_file(&urdf_path).map_err(|err| Error::Urdf {
            path: urdf_path.clone(),
            message: urdf_message(&err.to_string()),
        })?;
        Builder {
            path,
            urdf_path: &urdf_path,
            robot: &robot,
        }
        .build(file)
    }

    /// Index of the leg called `name`.
    pub fn leg_index(&self, name: &str) -> Option<usize> {
        self.legs.iter().position(|leg| leg.name == name)
    }

    /// Names of the measured coordinates, in file order.
    pub fn measured_names(&self) -> Vec<&'static str> {
        self.measured.iter().map(|&i| COORDINATES[i]).collect()
    }

    /// Names of the actuated joints, one per leg.
    pub fn actuated_names(&self) -> Vec<&str> {
        self.legs
            .iter()
            .map(|leg| leg.joints[leg.moving[leg.actuated]].name.as_str())
            .collect()
    }
}

/// The first line of a urdf-rs error, without serde's internal `custom: ` prefix.
fn urdf_message(message: &str) -> String {
    let first = message.lines().next().unwrap_or("invalid URDF");
    first.strip_prefix("custom: ").unwrap_or(first).to_string()
}

struct Builder<'a> {
    path: &'a Path,
    urdf_path: &'a Path,
    robot: &'a urdf_rs::Robot,
}

impl Builder<'_> {
    fn error(&self, field: impl Into<String>, message: impl Into<String>) -> Error {
        Error::Model {
            path: self.path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    fn urdf_name(&self) -> String {
        self.urdf_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    fn build(&self, file: ModelFile) -> Result<Mechanism> {
        let measured = self.measured(&file.measured)?;
        let home_pose = self.home_pose(&file.home.pose, &measured)?;
        let closure_dims = if measured.contains(&2) { 3 } else { 2 };
        let mut legs = self.legs(&file, closure_dims)?;
        self.parameters(&file.parameters, &mut legs)?;
        for (index, leg) in legs.iter_mut().enumerate() {
            self.home(leg, index, &file.legs[index].home, &home_pose)?;
        }
        let workspace = self.workspace(&file, &measured)?;
        let simulation = self.simulation(&file, &measured, &legs)?;
        let selection = self.selection(&file, simulation.as_ref())?;
        Ok(Mechanism {
            name: file.name,
            model_path: self.path.to_path_buf(),
            urdf_path: self.urdf_path.to_path_buf(),
            mode: file.mode,
            measured,
            home_pose,
            legs,
            workspace,
            selection,
            simulation,
        })
    }

    fn selection(
        &self,
        file: &ModelFile,
        simulation: Option<&Simulation>,
    ) -> Result<SelectionSetup> {
        let entry = file.selection.as_ref();
        let poses_per_leg = entry
            .and_then(|e| e.poses_per_leg)
            .or(simulation.map(|s| s.poses_per_leg))
            .unwrap_or(18);
        if poses_per_leg == 0 {
            return Err(self.error("selection.poses_per_leg", "expected at least one pose"));
        }
        let criterion = match entry.and_then(|e| e.criterion.as_deref()) {
            None | Some("D") | Some("d") => SelectionCriterion::D,
            Some("A") | Some("a") => SelectionCriterion::A,
            Some("E") | Some("e") => SelectionCriterion::E,
            Some(other) => {
                return Err(self.error(
                    "selection.criterion",
                    format!("`{other}` is not one of D, A, E"),
                ))
            }
        };
        Ok(SelectionSetup {
            poses_per_leg,
            criterion,
        })
    }

    fn measured(&self, names: &[String]) -> Result<Vec<usize>> {
        let mut measured = Vec::new();
        for (i, name) in names.iter().enumerate() {
            let Some(index) = COORDINATES.iter().position(|c| c == name) else {
                return Err(self.error(
                    format!("measured[{i}]"),
                    format!(
                        "unknown coordinate `{name}`; expected one of x, y, z, roll, pitch, yaw"
                    ),
                ));
            };
            if measured.contains(&index) {
                return Err(self.error(
                    format!("measured[{i}]"),
                    format!("`{name}` is listed twice"),
                ));
            }
            measured.push(index);
        }
        if !(measured.contains(&0) && measured.contains(&1)) {
            return Err(self.error("measured", "x and y must be measured"));
        }
        Ok(measured)
    }

    fn home_pose(&self, pose: &BTreeMap<String, f64>, measured: &[usize]) -> Result<[f64; 6]> {
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

    fn legs(&self, file: &ModelFile, closure_dims: usize) -> Result<Vec<LegModel>> {
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
                return Err(self.error(format!("legs[{l}].chain"), format!("the chain has {} moving joints; a point closure with the measured coordinates needs exactly {closure_dims}", moving.len())));
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

    fn parameters(&self, entries: &[ParameterEntry], legs: &mut [LegModel]) -> Result<()> {
        let mut names = HashSet::new();
        let mut targets = HashSet::new();
        for (p, entry) in entries.iter().enumerate() {
            let field = format!("parameters[{p}]");
            if !names.insert(entry.name.as_str()) {
                return Err(self.error(
                    format!("{field}.name"),
                    format!("parameter `{}` is defined twice", entry.name),
                ));
            }
            let (leg, target) = self.target(entry, &field, legs)?;
            if !targets.insert((leg, format!("{target:?}"))) {
                return Err(self.error(
                    field,
                    format!(
                        "parameter `{}` stands for a quantity another parameter already names",
                        entry.name
                    ),
                ));
            }
            let model = &legs[leg];
            let (nominal, unit) = match target {
                ParamTarget::JointOrigin { joint, component } => (
                    model.joints[joint].origin[component],
                    if component < 3 {
                        Unit::Metre
                    } else {
                        Unit::Radian
                    },
                ),
                ParamTarget::Gain => (model.gain, Unit::One),
                ParamTarget::Offset => (
                    model.offset,
                    if model.actuated_is_revolute() {
                        Unit::Radian
                    } else {
                        Unit::Metre
                    },
                ),
                ParamTarget::Attachment { component } => (model.attachment[component], Unit::Metre),
            };
            legs[leg].params.push(Parameter {
                name: entry.name.clone(),
                target,
                nominal,
                identified: entry.identify,
                unit,
            });
        }
        Ok(())
    }

    fn target(
        &self,
        entry: &ParameterEntry,
        field: &str,
        legs: &[LegModel],
    ) -> Result<(usize, ParamTarget)> {
        let leg_named = |name: &str, key: &str| {
            legs.iter().position(|l| l.name == name).ok_or_else(|| {
                self.error(
                    format!("{field}.{key}"),
                    format!("no leg is named `{name}`"),
                )
            })
        };
        let component = |value: &str, key: &str, allowed: &[&str]| {
            allowed.iter().position(|c| *c == value).ok_or_else(|| {
                self.error(
                    format!("{field}.{key}"),
                    format!("`{value}` is not one of {}", allowed.join(", ")),
                )
            })
        };
        match (&entry.joint, &entry.origin, &entry.leg, &entry.actuator, &entry.attachment) {
            (Some(joint), Some(origin), None, None, None) => {
                let component = component(origin, "origin", &ORIGIN_COMPONENTS)?;
                for (l, leg) in legs.iter().enumerate() {
                    if let Some(j) = leg.joints.iter().position(|j| &j.name == joint) {
                        return Ok((l, ParamTarget::JointOrigin { joint: j, component }));
                    }
                }
                let known = self.robot.joints.iter().any(|j| &j.name == joint);
                Err(self.error(format!("{field}.joint"), if known {
                    format!("joint `{joint}` is in no leg's chain")
                } else {
                    format!("joint `{joint}` is not in the URDF `{}`", self.urdf_name())
                }))
            }
            (None, None, Some(leg), Some(term), None) => {
                let leg = leg_named(leg, "leg")?;
                match term.as_str() {
                    "gain" => Ok((leg, ParamTarget::Gain)),
                    "offset" => Ok((leg, ParamTarget::Offset)),
                    other => Err(self.error(format!("{field}.actuator"), format!("`{other}` is not one of gain, offset"))),
                }
            }
            (None, None, Some(leg), None, Some(axis)) => {
                let leg = leg_named(leg, "leg")?;
                let component = component(axis, "attachment", &ORIGIN_COMPONENTS[..3])?;
                Ok((leg, ParamTarget::Attachment { component }))
            }
            _ => Err(self.error(field, format!(
                "parameter `{}` needs exactly one target: `joint` + `origin`, `leg` + `actuator`, or `leg` + `attachment`",
                entry.name
            ))),
        }
    }

    fn home(
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

    fn workspace(&self, file: &ModelFile, measured: &[usize]) -> Result<Workspace> {
        let entry = &file.workspace;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        let region = match &entry.region {
            RegionEntry::Disc { centre, radius } => {
                if !positive(*radius) || centre.iter().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.disc",
                        "expected a finite centre and a positive radius (metres)",
                    ));
                }
                Region::Disc {
                    centre: *centre,
                    radius: *radius,
                }
            }
            RegionEntry::Box { min, max } => {
                if !(0..2).all(|i| min[i].is_finite() && max[i].is_finite() && min[i] < max[i]) {
                    return Err(self.error(
                        "workspace.region.box",
                        "expected finite corners with min < max (metres)",
                    ));
                }
                Region::Box {
                    min: *min,
                    max: *max,
                }
            }
            RegionEntry::Polygon { vertices } => {
                if vertices.len() < 3 || vertices.iter().flatten().any(|v| !v.is_finite()) {
                    return Err(self.error(
                        "workspace.region.polygon",
                        "expected at least three finite vertices (metres)",
                    ));
                }
                Region::Polygon {
                    vertices: vertices.clone(),
                }
            }
        };
        if !(entry.margin.is_finite() && entry.margin >= 0.0) {
            return Err(self.error(
                "workspace.margin",
                "expected a non-negative distance (metres)",
            ));
        }
        let mut ranges = [None; 6];
        for (name, range) in &entry.ranges {
            let field = format!("workspace.ranges.{name}");
            match COORDINATES.iter().position(|c| c == name) {
                Some(i) if i >= 2 && measured.contains(&i) => {
                    if !(range[0].is_finite() && range[1].is_finite() && range[0] <= range[1]) {
                        return Err(self.error(field, "expected [min, max] with min <= max"));
                    }
                    ranges[i] = Some(*range);
                }
                _ => {
                    return Err(
                        self.error(field, "expected a measured coordinate other than x and y")
                    )
                }
            }
        }
        if let Some(grid) = entry.grid {
            if !positive(grid) {
                return Err(self.error("workspace.grid", "expected a positive spacing (metres)"));
            }
        }
        let levels = entry.range_levels.unwrap_or(DEFAULT_RANGE_LEVELS);
        if levels == 0 {
            return Err(self.error("workspace.range_levels", "expected at least 1"));
        }
        let thresholds = entry.singularity.as_ref();
        let threshold = |value: Option<f64>, name: &str| match value {
            None => Ok(DEFAULT_SINGULARITY_THRESHOLD),
            Some(v) if v.is_finite() && (0.0..1.0).contains(&v) => Ok(v),
            Some(_) => Err(self.error(
                format!("workspace.singularity.{name}"),
                "expected a number in [0, 1)",
            )),
        };
        let workspace = Workspace {
            region,
            margin: entry.margin,
            ranges,
            grid: entry.grid,
            range_levels: levels,
            serial_threshold: threshold(thresholds.and_then(|t| t.serial), "serial")?,
            parallel_threshold: threshold(thresholds.and_then(|t| t.parallel), "parallel")?,
        };
        let (lo, hi) = workspace.region.bounds();
        let smallest = (hi[0] - lo[0]).min(hi[1] - lo[1]);
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let usable = entry.margin * 2.0 < smallest
            && (workspace.region.depth(centre) >= entry.margin || {
                // A non-convex polygon may not contain its bounding box's centre: try a few points.
                use rand::SeedableRng;
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
                workspace.sample(&[0.0; 6], &mut rng).is_some()
            });
        if !usable {
            return Err(self.error(
                "workspace.margin",
                format!("the margin ({} m) leaves no usable region", entry.margin),
            ));
        }
        Ok(workspace)
    }

    fn simulation(
        &self,
        file: &ModelFile,
        measured: &[usize],
        legs: &[LegModel],
    ) -> Result<Option<Simulation>> {
        let Some(entry) = &file.simulation else {
            return Ok(None);
        };
        for (name, value) in &entry.real {
            if !legs
                .iter()
                .any(|l| l.params.iter().any(|p| &p.name == name))
            {
                return Err(self.error(
                    format!("simulation.real.{name}"),
                    "no parameter has this name",
                ));
            }
            if !value.is_finite() {
                return Err(self.error(
                    format!("simulation.real.{name}"),
                    "expected a finite number",
                ));
            }
        }
        let mut pose_noise = [0.0; 6];
        let mut reading_noise = 0.0;
        for (name, &sigma) in &entry.noise {
            let field = format!("simulation.noise.{name}");
            if !(sigma.is_finite() && sigma >= 0.0) {
                return Err(self.error(
                    field,
                    "expected a non-negative standard deviation (SI units)",
                ));
            }
            match COORDINATES.iter().position(|c| c == name) {
                _ if name == "readings" => reading_noise = sigma,
                Some(i) if measured.contains(&i) => pose_noise[i] = sigma,
                _ => return Err(self.error(field, "expected `readings` or a measured coordinate")),
            }
        }
        let perturbation = match &entry.perturbation {
            Some(p) => {
                if [p.length, p.angle, p.gain]
                    .iter()
                    .any(|v| !(v.is_finite() && *v >= 0.0))
                {
                    return Err(self.error(
                        "simulation.perturbation",
                        "expected non-negative standard deviations",
                    ));
                }
                Some((p.length, p.angle, p.gain))
            }
            None => None,
        };
        if entry.poses_per_leg == 0 {
            return Err(self.error("simulation.poses_per_leg", "expected at least one pose"));
        }
        Ok(Some(Simulation {
            real: entry.real.clone(),
            perturbation,
            pose_noise,
            reading_noise,
            poses_per_leg: entry.poses_per_leg,
            seed: entry.seed,
        }))
    }
}
