//! The model file as written on disk: a serde mirror of the YAML (read, and written back by
//! the calibrated-model writer), checked only for syntax and
//! types (ripgrep's "low args"). Cross-checks against the URDF happen in [`super::mechanism`].
//!
//! The reference for every field is `docs/models.md`.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::region::Region;
use crate::error::{Error, Result};

/// The whole model file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Human-readable name of the mechanism.
    pub name: String,
    /// Path of the URDF holding the legs, relative to the model file.
    pub urdf: String,
    /// Measured end-effector coordinates, among `x y z roll pitch yaw` (metres, radians).
    pub measured: Vec<String>,
    /// Free text naming the working and assembly mode the home configuration selects.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<String>,
    /// The home configuration: it fixes the working mode (branch) of every leg.
    pub home: HomeEntry,
    /// The legs, each a serial chain of URDF joints from the base to the platform attachment.
    pub legs: Vec<LegEntry>,
    /// Named quantities other parameters are functions of (optional).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub quantities: Vec<QuantityEntry>,
    /// Named kinematic parameters, each mapped onto one quantity of the model.
    pub parameters: Vec<ParameterEntry>,
    /// Named sets of factors to fit and compare (optional; `legwise sets`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub factor_sets: Vec<FactorSetEntry>,
    /// The usable workspace.
    pub workspace: WorkspaceEntry,
    /// Pose selection (optional; defaults: D-optimal, `simulation.poses_per_leg` or 18 poses).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub selection: Option<SelectionEntry>,
    /// Measurement noise: standard deviation by measured coordinate name, and `readings` for
    /// the actuator readings (SI units). Optional; the residuals of every fit are tested against
    /// it, and it is the default noise of simulations.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<BTreeMap<String, f64>>,
    /// The simulation set-up (optional: real users bring measurements).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation: Option<SimulationEntry>,
    /// The measuring instrument's frame and targets (optional: without it, the measurements
    /// are platform poses in the base frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instrument: Option<super::instrument::InstrumentEntry>,
    /// What a calibrated model was calibrated to (written by `identify --calibrated`): the
    /// identified parameters, their estimates and covariance. Unused by the model itself;
    /// `identify --prior FILE` takes it as the prior of a new fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<CalibrationEntry>,
}

/// A calibration's estimates and their covariance (model file `calibration:`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationEntry {
    /// The identified parameters, by name (legs' and instrument's).
    pub parameters: Vec<String>,
    /// Their estimates, SI units, in the same order.
    pub estimates: Vec<f64>,
    /// Their covariance, one row per parameter, SI units.
    pub covariance: Vec<Vec<f64>>,
}

/// Pose selection set-up.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionEntry {
    /// Identification poses to select per leg (and shared poses for the traditional strategy).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poses_per_leg: Option<usize>,
    /// Design criterion: `D` (maximise det CᵀC, i.e. O1; default), `A` (minimise tr (CᵀC)⁻¹) or
    /// `E` (maximise the smallest singular value, O3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub criterion: Option<String>,
}

/// The home configuration.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HomeEntry {
    /// The platform pose at home, by measured coordinate name (metres, radians).
    pub pose: BTreeMap<String, f64>,
}

/// One leg.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LegEntry {
    /// Leg name, used in measurement files and reports.
    pub name: String,
    /// URDF joint names from the base to the leg's tip, in order.
    pub chain: Vec<String>,
    /// The actuated joint and its actuator model `joint = gain * reading + offset`.
    pub actuator: ActuatorEntry,
    /// The point of the platform the leg tip coincides with, in the platform (measured) frame, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attachment: Option<[f64; 3]>,
    /// Joint values of the leg's moving joints at the home pose (radians or metres); they select
    /// the working mode. Approximate values are refined by Newton's method.
    pub home: BTreeMap<String, f64>,
}

/// Actuator model of a leg.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorEntry {
    /// The actuated URDF joint (must be in the leg's chain).
    pub joint: String,
    /// Nominal gain (dimensionless).
    #[serde(default = "one")]
    pub gain: f64,
    /// Nominal offset (radians for a revolute joint, metres for a prismatic one).
    #[serde(default)]
    pub offset: f64,
}

fn one() -> f64 {
    1.0
}

fn yes() -> bool {
    true
}

/// One named parameter. Exactly one target: `joint` + `origin`, `leg` + `actuator`, or
/// `leg` + `attachment`.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterEntry {
    /// Parameter name (as in reports and `simulation.real`).
    pub name: String,
    /// A URDF joint whose origin holds the parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<String>,
    /// Component of the joint origin: `x y z` (metres) or `roll pitch yaw` (radians).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<String>,
    /// A leg whose actuator or attachment holds the parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leg: Option<String>,
    /// `gain` or `offset` of the leg's actuator model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub actuator: Option<String>,
    /// Component `x y z` of the leg's platform attachment (metres).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attachment: Option<String>,
    /// Identified (true, the default) or held fixed at its nominal value (false).
    #[serde(default = "yes")]
    pub identify: bool,
    /// An expression of the model's quantities the parameter equals (a derived parameter: it
    /// follows them in a factor set that fits one of them; `identify` still says what the
    /// model's own fit does with it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<String>,
    /// The standard deviation of what is known of the parameter before any measurement (a
    /// tolerance around its nominal value, SI units): a fit that frees it is the maximum a
    /// posteriori one, the prior one residual row of its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<f64>,
}

/// A named quantity.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct QuantityEntry {
    /// Its name, as expressions and factor sets write it.
    pub name: String,
    /// Its nominal value, SI units.
    pub value: f64,
    /// Its unit: `m`, `rad` or `1` (dimensionless).
    pub unit: String,
    /// The standard deviation of what is known of it before any measurement (SI units), as a
    /// parameter's `prior`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<f64>,
}

/// A named set of factors to fit together.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FactorSetEntry {
    /// Its name.
    pub name: String,
    /// The quantities and parameters it fits.
    pub fit: Vec<String>,
    /// Where it comes from (one line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The usable workspace.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WorkspaceEntry {
    /// The region of the end-effector point: in x, y (planar) or x, y, z (spatial).
    pub region: Region,
    /// Inward safety margin from the region's boundary, metres.
    #[serde(default)]
    pub margin: f64,
    /// Ranges `[min, max]` for measured coordinates other than x and y (e.g. `yaw`); a coordinate
    /// without a range stays at its home value.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub ranges: BTreeMap<String, [f64; 2]>,
    /// Spacing of the candidate grid for pose selection, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<f64>,
    /// Number of evenly spaced values of each ranged coordinate in the candidate grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range_levels: Option<usize>,
    /// Singularity thresholds a candidate pose must clear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub singularity: Option<SingularityEntry>,
}

/// Singularity thresholds (scale-free measures, see `docs/models.md`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SingularityEntry {
    /// Smallest allowed serial (type I) measure of every leg (default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<f64>,
    /// Smallest allowed parallel (type II) measure (default 0.05).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parallel: Option<f64>,
}

/// The simulation set-up.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationEntry {
    /// "Real" values by parameter name (any parameter, identified or fixed: a fixed parameter
    /// given a real value different from its nominal one models an error the identification
    /// cannot absorb). Identified parameters not listed are perturbed (if `perturbation` is
    /// given); all others equal their nominal value.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub real: BTreeMap<String, f64>,
    /// Standard deviations of a seeded random perturbation of the parameters not in `real`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perturbation: Option<PerturbationEntry>,
    /// Simulated measurement noise standard deviation by measured coordinate name, and
    /// `readings` for the actuator readings (SI units); default: the top-level `noise` block.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<BTreeMap<String, f64>>,
    /// Number of identification poses per leg.
    pub poses_per_leg: usize,
    /// Seed of the random generator (poses, perturbation, noise).
    #[serde(default)]
    pub seed: u64,
}

/// Standard deviations of the parameter perturbation, by kind of quantity.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PerturbationEntry {
    /// Lengths (joint origin x y z, attachments, prismatic offsets), metres.
    #[serde(default)]
    pub length: f64,
    /// Angles (joint origin roll pitch yaw, revolute offsets), radians.
    #[serde(default)]
    pub angle: f64,
    /// Actuator gains, dimensionless.
    #[serde(default)]
    pub gain: f64,
}

impl ModelFile {
    /// Reads and parses a model file. Syntax and type errors carry the line and column.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, [`Error::Yaml`] if it is not a valid model file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = crate::model::source::read_text_file(path)?;
        Self::parse(&text, path)
    }

    /// Parses model-file text; `path` is only used in error messages.
    ///
    /// # Errors
    /// [`Error::Yaml`] if the text is not a valid model file.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        if super::yaml_errors::is_empty(text) {
            return Err(Error::Yaml {
                path: path.to_path_buf(),
                message: super::yaml_errors::EMPTY.into(),
            });
        }
        // The field an error is in (`home.pose.x`), which the parser's message lacks.
        let mut field = String::new();
        let parsed = serde_saphyr::with_deserializer_from_str(text, |de| {
            serde_path_to_error::deserialize(de).map_err(|err| {
                field = err.path().to_string();
                err.into_inner()
            })
        });
        parsed.map_err(|err| Error::Yaml {
            path: path.to_path_buf(),
            message: super::yaml_errors::located(
                &crate::error::first_line(&err.to_string(), "error: ", "invalid YAML"),
                &field,
                text,
            ),
        })
    }
}
