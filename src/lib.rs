//! # legwise — kinematic identification of parallel mechanisms, leg by leg
//!
//! legwise estimates the kinematic parameters of a parallel mechanism (joint centres, link
//! lengths, actuator gains and offsets) with the *inverse calibration method*: at every measured
//! platform pose, each leg's inverse kinematics predicts its actuator reading, and a nonlinear
//! least-squares fit minimises the difference to the measured readings. With the *divide and
//! conquer* strategy (Durango et al., ICINCO 2010) each leg is identified on its own; the
//! traditional strategy stacks all legs on shared poses.
//!
//! ## The public face
//! Load a [`Mechanism`], read its [`Measurements`] (or simulate them), and call [`identify()`]
//! (or [`run`] to simulate first) with [`Settings`]: the model decides the pipeline (readings at
//! measured poses, or target coordinates through an instrument). The [`Report`] holds one
//! [`StrategyResult`] per strategy, the trust verdict, and in simulation the real values and
//! accuracy maps; it renders as terminal text and as the JSON document of docs/report.md, and
//! gives the calibrated model ([`report::calibrated`]).
//! ```
//! use legwise::{run, Mechanism, Settings};
//!
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
//! let mechanism = Mechanism::load(&path)?;
//! let mut settings = Settings::default();
//! settings.simulation.options.noise_scale = 0.0;
//! let report = run(&mechanism, &settings)?;
//! let l1 = report.results[0].parameters().next().unwrap();
//! assert_eq!(l1.name, "l1");
//! assert!((l1.estimate - 0.7507).abs() < 1e-9); // the "real" value of Table 2
//! assert!(report.trusted());
//! # Ok::<(), legwise::Error>(())
//! ```
//!
//! ## Data flow of `legwise identify --model models/5r.yaml`
//! ```text
//! model file (YAML) ─► model::file::ModelFile        syntax, types (file:line:column errors)
//! + URDF            ─► model::Mechanism::load        cross-checks (errors name the field;
//!                                                    model::load: values, then the region's
//!                                                    geometry and the kinematic checks)
//! measurements      ─► measure::Measurements::read | pipeline::simulate
//! pipeline::identify_one: by the measurements' kind
//!   readings        ─► identify::estimate            per leg (D&C) or all legs: residual
//!                      blocks, observability, solver::solve (LM | GN), statistics
//!   targets         ─► identify::shared_estimate     legs + instrument blocks, Schur LM
//!                      (solver::solve_bordered), sandwich covariance, held-frame test
//! report            ─► report::Report                terminal text, JSON, calibrated model,
//!                                                    accuracy maps, pictures
//! ```
//!
//! ## Data flow of `legwise select --model models/5r.yaml`
//! ```text
//! model file        ─► model::Mechanism::load
//! candidate poses   ─► workspace::candidates::feasible_poses  grid over the usable region, feasible
//!                                                             poses (geometry, kinematics)
//!                      selection::candidates::candidate_pool  their identification rows
//! experiment design ─► selection::design::ExperimentDesign    per leg (D&C), shared (traditional)
//!                      selection::select                      greedy + exchange + DETMAX (D, A, E)
//!                      identify::observability                indices of the chosen poses
//! pose file         ─► measure::file::to_csv
//! ```
//!
//! ## Layers
//! Each module uses only the ones on lines above it (no module cycles; `python3
//! tools/file_cycles.py` lists the import cycles between files):
//! ```text
//! scalar, error, progress, solver      numbers, errors, progress bars, least-squares solvers
//! model                                model file + URDF cross-checks: values (no kinematics,
//!                                      no geometry)
//! kinematics                           chains, leg IK, singularities (takes model types);
//!                                      kinematics::assembly: home closure, planar axes, platform
//! workspace                            geometry only: the region's depths and containment (the
//!                                      only caller of the collision-geometry crates), feasible
//!                                      candidate poses, MIW, singular curves
//! model::load                          Mechanism::load: model values, then the region checks
//!                                      (workspace::region) and kinematics::assembly
//! measure                              measurement files, simulation, residual blocks
//! identify                             problems, Jacobians, fits, statistics, trust
//! evaluate                             accuracy maps, held-out evaluation
//! selection                            candidate identification rows, experiment design
//! report                               the one Report: terminal, JSON, calibrated model, plots
//!                                      (the workspace pictures)
//! files                                output files: checked first, written atomically
//! pipeline                             the whole job: run / identify (simulate or read, the
//!                                      model's pipeline, maps)
//! study                                Monte Carlo and other studies
//! cli                                  the command line: arguments, one library call, outputs
//! ```
//!
//! ## Principles
//! * A mechanism is data: no code path knows which mechanism it runs.
//! * The model is immutable; per-pose results are values (Pinocchio's Model/Data).
//! * Kinematics is written once, generic over [`scalar::Scalar`] (f64 and num-dual duals).
//!   Identification Jacobians come from dual numbers through the implicit function theorem,
//!   never from finite differences and never by differentiating Newton iterations.
//! * One residual block = one leg's reading at one platform pose (measured, or fitted from the
//!   targets an instrument saw); one problem of parameter blocks (each leg's, the instrument's)
//!   and residual blocks ([`identify::problem::IdentificationProblem`]): strategies only group
//!   the blocks differently, and the Schur-complement step serves a layout with shared columns.
//! * Units are SI everywhere: metres, radians, dimensionless gains.
//!
pub mod cli;
pub mod error;
pub mod evaluate;
pub mod files;
pub mod identify;
pub mod kinematics;
pub mod measure;
pub mod model;
pub mod pipeline;
pub mod printer;
pub mod progress;
pub mod report;
pub mod scalar;
pub mod selection;
pub mod solver;
pub mod study;
pub mod workspace;

pub use error::{Error, Result};
pub use identify::result::{
    FitOptions, InstrumentEstimate, LegEstimate, ParameterEstimate, Strategy, StrategyResult,
    Weighting,
};
pub use identify::robust::RobustLoss;
pub use measure::Measurements;
pub use model::Mechanism;
pub use pipeline::{identify, run, MapSettings, PoseSource, Settings, SimulationSettings};
pub use report::json::ReportJson;
pub use report::Report;
pub use solver::SolverKind;
