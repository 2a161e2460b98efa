//! # legwise — kinematic identification of parallel mechanisms, leg by leg
//!
//! legwise estimates the kinematic parameters of a parallel mechanism (joint centres, link
//! lengths, actuator gains and offsets) with the *inverse calibration method*: at every measured
//! platform pose, each leg's inverse kinematics predicts its actuator reading, and a nonlinear
//! least-squares fit minimises the difference to the measured readings. With the *divide and
//! conquer* strategy (Durango et al., ICINCO 2010) each leg is identified on its own; the
//! traditional strategy stacks all legs on shared poses.
//!
//! ## Data flow of `legwise identify --model models/5r.yaml`
//! ```text
//! model file (YAML) ─► model::file::ModelFile        syntax, types (file:line:column errors)
//! + URDF            ─► model::Mechanism::load        cross-checks (errors name the field;
//!                                                    model::load: values, then the region's
//!                                                    geometry and the kinematic checks)
//! measurements      ─► measure::file::read | measure::simulate::simulate
//! per leg           ─► identify::problem::IdentificationProblem (residual blocks)
//!                      identify::observability       rank check, names unidentifiable params
//!                      solver::solve                 Levenberg–Marquardt | Gauss–Newton (argmin)
//!                      identify::estimate            estimates, σ, cost, singular values
//! report            ─► report::terminal | report::json
//! ```
//! With an `instrument` block (model::instrument) the rows are the targets' coordinates in the
//! instrument frame (measure::observations, measure::observe_simulate); the platform pose is
//! fitted from them inside every evaluation (measure::targets), and the legs and the instrument
//! are identified together (identify::shared, identify::shared_estimate, solver::solve_bordered;
//! report::instrument). After the fit, evaluate::through_instrument compares where a model puts
//! each target with where the instrument saw it; accuracy maps and study::montecarlo compare the
//! identified legs with the real ones.
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
//! report                               terminal, JSON, plots (the workspace pictures)
//! study                                Monte Carlo and other studies
//! cli                                  the command line
//! ```
//!
//! ## Principles
//! * A mechanism is data: no code path knows which mechanism it runs.
//! * The model is immutable; per-pose results are values (Pinocchio's Model/Data).
//! * Kinematics is written once, generic over [`scalar::Scalar`] (f64 and num-dual duals).
//!   Identification Jacobians come from dual numbers through the implicit function theorem,
//!   never from finite differences and never by differentiating Newton iterations.
//! * One residual block = one leg × one pose; strategies only group blocks differently.
//! * Units are SI everywhere: metres, radians, dimensionless gains.
//!
//! ## Example
//! ```
//! use legwise::identify::estimate::{identify, Strategy};
//! use legwise::measure::simulate::{simulate, SimulationOptions};
//! use legwise::model::Mechanism;
//! use legwise::solver::SolverKind;
//!
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/5r.yaml");
//! let mechanism = Mechanism::load(&path)?;
//! let noise_free = SimulationOptions { noise_scale: 0.0, ..Default::default() };
//! let experiment = simulate(&mechanism, noise_free)?;
//! let result = identify(&mechanism, &experiment.measurements, Strategy::DivideAndConquer,
//!                       SolverKind::GaussNewton)?;
//! let l1 = &result.legs[0].parameters[0];
//! assert_eq!(l1.name, "l1");
//! assert!((l1.estimate - 0.7507).abs() < 1e-9); // the "real" value of Table 2
//! # Ok::<(), legwise::error::Error>(())
//! ```
pub mod cli;
pub mod error;
pub mod evaluate;
pub mod identify;
pub mod kinematics;
pub mod measure;
pub mod model;
pub mod progress;
pub mod report;
pub mod scalar;
pub mod selection;
pub mod solver;
pub mod study;
pub mod workspace;
