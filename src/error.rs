//! The crate's error type. Every variant names where the problem is (file and field or line)
//! and what was expected, so that the command line can print it on one line.

use std::path::PathBuf;

/// Result alias used throughout legwise.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error (part of the message, not a separate cause, so that
        /// the command line prints it once).
        error: std::io::Error,
    },
    /// The YAML model file is not valid YAML or does not have the expected shape.
    #[error("{}: {}", path.display(), one_line(message))]
    Yaml {
        /// The model file.
        path: PathBuf,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A field of the model file is inconsistent with the URDF or with another field.
    #[error("{}: field `{}`: {}", path.display(), one_line(field), one_line(message))]
    Model {
        /// The model file.
        path: PathBuf,
        /// The offending field, as a YAML path (`legs[0].actuated`).
        field: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// The URDF file is not valid or does not describe the legs as expected.
    #[error("{}: {}", path.display(), one_line(message))]
    Urdf {
        /// The URDF file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A measurement file is malformed or holds a pose that cannot be used.
    #[error("{}: {}: {}", path.display(), one_line(location), one_line(message))]
    Measurement {
        /// The CSV file.
        path: PathBuf,
        /// `line N`, `line N, column `c`` or `header`.
        location: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A leg's inverse kinematics failed.
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// The pose set does not determine every identified parameter of a leg.
    #[error(
        "{}leg `{}`: rank-deficient identification: rank {rank} of {n} parameters; \
         cannot be identified: {}",
        file_prefix(file),
        one_line(leg),
        one_line(params)
    )]
    Unidentifiable {
        /// The measurement file the pose set came from, if any.
        file: Option<PathBuf>,
        /// The leg.
        leg: String,
        /// Numerical rank of the column-scaled identification Jacobian.
        rank: usize,
        /// Number of identified parameters.
        n: usize,
        /// The parameters (or combinations) that cannot be identified.
        params: String,
    },
    /// The least-squares solver failed.
    #[error("{}: solver failed: {}", one_line(context), one_line(message))]
    Solver {
        /// Which identification (leg or strategy).
        context: String,
        /// The solver's message.
        message: String,
    },
    /// A leg has no measurements to be identified from.
    #[error("{}leg `{leg}`: no measurements (rows labelled `{leg}`, or shared rows with its reading when none is labelled)", file_prefix(file))]
    NoMeasurements {
        /// The measurement file, if any.
        file: Option<PathBuf>,
        /// The leg.
        leg: String,
    },
    /// A request that cannot be carried out with the given data.
    #[error("{}", one_line(.0))]
    Invalid(String),
}

/// `text` on one line: line breaks and other control characters (which a quoted CSV cell or an
/// XML tag may hold, and which a parser may echo) are shown escaped (`\n`), so that every message
/// stays one line.
fn one_line(text: &str) -> std::borrow::Cow<'_, str> {
    if text.chars().any(char::is_control) {
        text.chars()
            .map(|c| {
                if c.is_control() {
                    c.escape_default().to_string()
                } else {
                    c.to_string()
                }
            })
            .collect::<String>()
            .into()
    } else {
        text.into()
    }
}

/// `"path: "` for an optional file, or nothing.
fn file_prefix(file: &Option<PathBuf>) -> String {
    file.as_ref()
        .map_or(String::new(), |p| format!("{}: ", p.display()))
}

/// Failures of a leg's inverse kinematics, independent of where the pose came from.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum KinematicsError {
    /// Newton's method on the closure equations did not converge: the pose is out of reach.
    #[error(
        "leg `{leg}` cannot reach the pose (closure residual {residual:.3e} m after {iterations} Newton iterations)"
    )]
    Unreachable {
        /// The leg.
        leg: String,
        /// Remaining closure error, metres.
        residual: f64,
        /// Iterations spent.
        iterations: usize,
    },
    /// The solution is on another branch (working mode) than the home configuration.
    #[error("leg `{leg}` reaches the pose only on another branch than its home configuration (working-mode change)")]
    BranchChange {
        /// The leg.
        leg: String,
    },
    /// The closure Jacobian is singular: the leg is at a serial (type I) singularity.
    #[error("leg `{leg}` is at a serial (type I) singularity at this pose")]
    Singular {
        /// The leg.
        leg: String,
    },
    /// The platform cannot be assembled for the given readings (forward kinematics diverged).
    #[error(
        "the platform cannot be assembled for these readings (closure residual {residual:.3e} m)"
    )]
    NotAssemblable {
        /// Remaining closure error, metres.
        residual: f64,
    },
    /// Forward kinematics reached another assembly mode (or a parallel singularity) than home.
    #[error("forward kinematics reaches another assembly mode than the home configuration (parallel singularity crossed)")]
    AssemblyModeChange,
    /// The parallel Jacobian is not square: legs and measured coordinates differ in number.
    #[error("the parallel (type II) measure needs as many legs ({legs}) as measured coordinates ({coordinates})")]
    NotSquare {
        /// Number of legs.
        legs: usize,
        /// Number of measured coordinates.
        coordinates: usize,
    },
    /// Finite inputs too large to compute with: the arithmetic overflowed (e.g. a coordinate of
    /// 1e308).
    #[error(
        "leg `{leg}`: the inverse kinematics overflows: the pose or the parameters are finite but \
         far too large for a mechanism in metres (largest magnitude {largest:e})"
    )]
    Overflow {
        /// The leg.
        leg: String,
        /// The largest magnitude among the pose, the joint values and the parameters.
        largest: f64,
    },
    /// A non-finite number appeared (parameters or pose hold NaN or infinity).
    #[error("leg `{leg}`: non-finite value in the parameters or the pose")]
    NonFinite {
        /// The leg.
        leg: String,
    },
    /// The leg reaches the pose only with a joint beyond its URDF `<limit>` (a prismatic
    /// joint's stroke, a revolute joint's range).
    #[error("{0}")]
    BeyondLimits(Box<JointBeyondLimits>),
}

/// A joint outside its URDF `<limit>` range at a pose (boxed in [`KinematicsError`] to keep that
/// error small).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("leg `{leg}` reaches the pose only with joint `{joint}` at {value}, beyond its limits [{lower}, {upper}]")]
pub struct JointBeyondLimits {
    /// The leg.
    pub leg: String,
    /// The joint.
    pub joint: String,
    /// The joint's value there (m or rad).
    pub value: f64,
    /// Its lower limit.
    pub lower: f64,
    /// Its upper limit.
    pub upper: f64,
}

/// The first non-empty line of a dependency's error message, without its `prefix` (serde-saphyr
/// appends a multi-line snippet; urdf-rs prefixes serde's `custom: `), or `fallback`.
pub(crate) fn first_line(message: &str, prefix: &str, fallback: &str) -> String {
    let first = message
        .lines()
        .map(str::trim)
        .find(|line| !line.is_empty())
        .unwrap_or(fallback);
    first.strip_prefix(prefix).unwrap_or(first).to_string()
}
