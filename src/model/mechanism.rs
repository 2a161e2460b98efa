//! The validated mechanism (ripgrep's "high args"): the model file cross-checked against its
//! URDF. Every error names the file and the field.

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::instrument::Instrument;
use super::joint::ORIGIN_COMPONENTS;
use super::leg::LegModel;
use super::quantities::{FactorSet, Quantity};
use super::workspace::Workspace;

mod validate;

/// Largest number of identification poses per leg (simulated or selected).
pub const MAX_POSES_PER_LEG: usize = 100_000;

/// Names of the end-effector coordinates, in pose-vector order (metres, radians).
pub const COORDINATES: [&str; 6] = ORIGIN_COMPONENTS;

/// A complete, validated mechanism, immutable once loaded: its [`MechanismParts`] are read
/// through it (`mechanism.legs`, `mechanism.noise`, …) and never written. A variant for a
/// study or a test is a new value ([`Mechanism::edited`]); a new mechanism is a model file.
#[derive(Debug, Clone)]
pub struct Mechanism {
    parts: MechanismParts,
}

impl std::ops::Deref for Mechanism {
    type Target = MechanismParts;

    fn deref(&self) -> &MechanismParts {
        &self.parts
    }
}

impl Mechanism {
    /// The mechanism of validated `parts` (the model's cross-checks and the kinematic checks
    /// run by [`Mechanism::load`]).
    pub(crate) fn from_parts(parts: MechanismParts) -> Self {
        Mechanism { parts }
    }

    /// The parts, for the kinematic checks that complete them while loading.
    pub(crate) fn parts_mut(&mut self) -> &mut MechanismParts {
        &mut self.parts
    }

    /// Whether a fit of the model takes priors: an identified parameter with a `prior:`, or a
    /// previous calibration (`identify --prior`).
    pub fn has_priors(&self) -> bool {
        let mut legs = self.legs.iter().flat_map(|l| &l.params);
        self.prior_covariance.is_some() || legs.any(|p| p.identified && p.prior.is_some())
    }

    /// A copy of this mechanism with `edit` applied to its parts, this one unchanged: for
    /// studies and tests that vary one thing of a loaded model (the declared noise, which
    /// parameters are identified, the simulation's noise). The copy is not validated again.
    pub fn edited(&self, edit: impl FnOnce(&mut MechanismParts)) -> Mechanism {
        let mut parts = self.parts.clone();
        edit(&mut parts);
        Mechanism { parts }
    }
}

/// What a [`Mechanism`] is made of (read through it).
#[derive(Debug, Clone)]
pub struct MechanismParts {
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
    /// The declared measurement noise (the model's `noise` block), if any.
    pub noise: Option<MeasurementNoise>,
    /// The simulation set-up, if any.
    pub simulation: Option<Simulation>,
    /// The measuring instrument (frame and targets), if the model has the block: the
    /// measurements are then the targets' coordinates in the instrument frame.
    pub instrument: Option<Instrument>,
    /// Named quantities derived parameters are functions of (model file `quantities:`).
    pub quantities: Vec<Quantity>,
    /// Named sets of factors to fit (model file `factor_sets:`).
    pub factor_sets: Vec<FactorSet>,
    /// A previous calibration taken as the prior of the fit (`identify --prior FILE`): never
    /// from the model file itself.
    pub prior_covariance: Option<super::prior_covariance::PriorCovariance>,
    /// What the model file holds that is accepted but implausible (an angle beyond ±2π rad:
    /// degrees?), one line each naming the file and the field; every command's result is then
    /// untrusted.
    pub warnings: Vec<String>,
}

/// Measurement noise standard deviations (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasurementNoise {
    /// Per pose coordinate `[x, y, z, roll, pitch, yaw]` (zero for unmeasured ones).
    pub pose: [f64; 6],
    /// Of the actuator readings.
    pub reading: f64,
    /// The factor the declared σ were scaled by (a run's noise scale, 1 as declared): the σ
    /// the instrument block declares itself (its distances', its measured poses') take it too.
    pub scale: f64,
}

impl Default for MeasurementNoise {
    /// No noise, scale 1.
    fn default() -> Self {
        Self {
            pose: [0.0; 6],
            reading: 0.0,
            scale: 1.0,
        }
    }
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
    /// Index of the leg called `name`.
    pub fn leg_index(&self, name: &str) -> Option<usize> {
        self.legs.iter().position(|leg| leg.name == name)
    }

    /// Is the mechanism planar: measured in x, y and at most yaw, with a planar workspace
    /// region? The planar-only computations (the MIW, the workspace picture) need it.
    pub fn is_planar(&self) -> bool {
        self.measured.iter().all(|&c| matches!(c, 0 | 1 | 5)) && !self.workspace.region.is_spatial()
    }

    /// The instrument, when it is seen through the forward kinematics
    /// (`instrument.kinematics: forward`): rows of every leg's reading predict what it saw.
    pub fn forward_instrument(&self) -> Option<&Instrument> {
        self.instrument.as_ref().filter(|i| i.forward)
    }

    /// Names of the measured coordinates, in file order.
    pub fn measured_names(&self) -> Vec<&'static str> {
        self.measured.iter().map(|&i| COORDINATES[i]).collect()
    }

    /// Indices of the legs with at least one identified parameter (the others have nothing to
    /// identify and are left out of pose selection and identification).
    pub fn identified_legs(&self) -> Vec<usize> {
        (0..self.legs.len())
            .filter(|&l| self.legs[l].params.iter().any(|p| p.identified))
            .collect()
    }

    /// Every leg's nominal parameter vector.
    pub fn nominal_parameters(&self) -> Vec<Vec<f64>> {
        self.legs.iter().map(|leg| leg.nominal()).collect()
    }

    /// `x=…, y=…` over the measured coordinates of `pose`, for messages.
    pub fn pose_text(&self, pose: &[f64; 6]) -> String {
        self.measured
            .iter()
            .map(|&c| format!("{}={}", COORDINATES[c], pose[c]))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Names of the actuated joints, one per leg.
    pub fn actuated_names(&self) -> Vec<&str> {
        self.legs
            .iter()
            .map(|leg| leg.joints[leg.moving[leg.actuated]].name.as_str())
            .collect()
    }
}
