//! The command line: a thin shell over the library (clap derive).
mod evaluate;
mod identify;
mod select;
mod simulate;
mod workspace;

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use crate::identify::estimate::Strategy;
use crate::solver::SolverKind;

/// Kinematic identification of parallel mechanisms, leg by leg.
#[derive(Debug, Parser)]
#[command(name = "legwise", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Identify the parameters of a mechanism from measurements (or from a simulation).
    Identify(IdentifyArgs),
    /// Select the identification poses to measure (observability-optimal, feasible) and write
    /// them as a measurement CSV with empty readings.
    Select(SelectArgs),
    /// Simulate an identification experiment and write it as a measurement CSV.
    Simulate(SimulateArgs),
    /// Compute the singularity-free region and its maximal inscribed workspace (MIW), with a picture.
    Workspace(WorkspaceArgs),
    /// How well a model explains measurements (typically held out of the fit): pose errors by
    /// forward kinematics from the readings, and each leg's reading residuals.
    Evaluate(EvaluateArgs),
}

/// Options of `legwise evaluate`.
#[derive(Debug, clap::Args)]
pub struct EvaluateArgs {
    /// The model file (YAML), e.g. a calibrated model.
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement CSV (rows with every actuator reading give pose errors).
    #[arg(long)]
    pub measurements: PathBuf,
    /// Another model to evaluate side by side (typically the nominal one), with the improvement.
    #[arg(long)]
    pub against: Option<PathBuf>,
    /// Also write the evaluation as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Directory for the pictures (created if missing): the distribution of position errors.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the pictures as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
}

/// `identify` options for after the fit: the calibrated model and the accuracy map.
#[derive(Debug, Clone, clap::Args)]
pub struct AfterFitArgs {
    /// Write the calibrated model (identified values in place of nominal ones) to this YAML
    /// file, and its URDF beside it (same name, extension `urdf`).
    #[arg(long, value_name = "OUT.yaml")]
    pub calibrated: Option<PathBuf>,
    /// Simulation only: the accuracy map (model IK commands, real mechanism moves) over a grid
    /// of this spacing (metres), before and after identification.
    #[arg(long, value_name = "GRID_M")]
    pub map: Option<f64>,
    /// Fraction of the workspace region the accuracy map covers (shrunk about its centre).
    #[arg(long, default_value_t = 0.95)]
    pub map_scale: f64,
}

/// Options of `legwise workspace`.
#[derive(Debug, clap::Args)]
pub struct WorkspaceArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Where to write the picture, SVG or PNG by the extension (default:
    /// `<model name>-workspace.svg`, or `.png` with `--png`).
    #[arg(long, visible_alias = "svg")]
    pub out: Option<PathBuf>,
    /// Write the default picture as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
    /// A pose file to draw on the picture (measurement CSV layout; readings may be empty).
    #[arg(long)]
    pub poses: Option<PathBuf>,
    /// Rays cast to trace the region's boundary.
    #[arg(long, default_value_t = 1440)]
    pub rays: usize,
}

/// Options of `legwise identify`.
#[derive(Debug, clap::Args)]
pub struct IdentifyArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement CSV; without it, the model's simulation block is simulated.
    #[arg(long)]
    pub measurements: Option<PathBuf>,
    /// Least-squares solver.
    #[arg(long, value_enum, default_value_t = SolverArg::Lm)]
    pub solver: SolverArg,
    /// Divide and conquer, traditional (all legs on shared poses), or both.
    #[arg(long, value_enum, default_value_t = StrategyArg::Dc)]
    pub strategy: StrategyArg,
    /// Also write the report as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Simulation overrides.
    #[command(flatten)]
    pub simulation: SimulationArgs,
    /// Calibrated model and accuracy map.
    #[command(flatten)]
    pub after: AfterFitArgs,
    /// Pictures.
    #[command(flatten)]
    pub pictures: IdentifyPlotArgs,
}

/// `identify` options for the pictures.
#[derive(Debug, Clone, clap::Args)]
pub struct IdentifyPlotArgs {
    /// Simulation only: write the pictures to this directory (created if missing): the
    /// parameter errors before and after, and with `--map` the accuracy map.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the pictures as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
}

/// Options of `legwise simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Where to write the measurement CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Simulation overrides.
    #[command(flatten)]
    pub simulation: SimulationArgs,
}

/// Options of `legwise select`.
#[derive(Debug, clap::Args)]
pub struct SelectArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Where to write the poses (measurement CSV layout, readings empty).
    #[arg(long)]
    pub out: PathBuf,
    /// Per-leg sets (dc), one shared set (traditional), or both.
    #[arg(long, value_enum, default_value_t = StrategyArg::Dc)]
    pub strategy: StrategyArg,
    /// Candidate grid spacing, metres (default: the model's `workspace.grid`).
    #[arg(long)]
    pub grid: Option<f64>,
    /// Poses per leg (default: the model's `selection.poses_per_leg`).
    #[arg(long)]
    pub poses_per_leg: Option<usize>,
    /// Design criterion (default: the model's `selection.criterion`): D maximises det CᵀC (O1),
    /// A minimises tr (CᵀC)⁻¹, E maximises the smallest singular value (O3).
    #[arg(long, value_enum)]
    pub criterion: Option<CriterionArg>,
}

/// `--criterion`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CriterionArg {
    /// D-optimal.
    D,
    /// A-optimal.
    A,
    /// E-optimal.
    E,
}

impl CriterionArg {
    fn criterion(self) -> crate::model::mechanism::SelectionCriterion {
        use crate::model::mechanism::SelectionCriterion;
        match self {
            CriterionArg::D => SelectionCriterion::D,
            CriterionArg::A => SelectionCriterion::A,
            CriterionArg::E => SelectionCriterion::E,
        }
    }
}

/// Where simulated identification poses come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PosesArg {
    /// Observability-optimal poses selected from the candidate grid (the paper's protocol).
    Selected,
    /// A seeded random spread over the usable workspace.
    Random,
}

/// Simulation overrides.
#[derive(Debug, Clone, clap::Args)]
pub struct SimulationArgs {
    /// Where the simulated poses come from.
    #[arg(long, value_enum, default_value_t = PosesArg::Selected)]
    pub poses: PosesArg,
    /// Candidate grid spacing for selected poses, metres (default: the model's `workspace.grid`).
    #[arg(long)]
    pub grid: Option<f64>,
    /// Random seed (default: the model's `simulation.seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Multiplies every simulated noise standard deviation (0 = noise-free).
    #[arg(long, default_value_t = 1.0)]
    pub noise_scale: f64,
    /// Poses per leg (default: the model's `simulation.poses_per_leg`).
    #[arg(long)]
    pub poses_per_leg: Option<usize>,
}

/// `--solver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SolverArg {
    /// Levenberg–Marquardt.
    Lm,
    /// Gauss–Newton.
    Gn,
}

/// `--strategy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StrategyArg {
    /// Divide and conquer: each leg on its own poses.
    Dc,
    /// All legs stacked on shared poses.
    Traditional,
    /// Both, one after the other.
    Both,
}

impl SolverArg {
    fn kind(self) -> SolverKind {
        match self {
            SolverArg::Lm => SolverKind::LevenbergMarquardt,
            SolverArg::Gn => SolverKind::GaussNewton,
        }
    }
}

impl StrategyArg {
    fn strategies(self) -> Vec<Strategy> {
        match self {
            StrategyArg::Dc => vec![Strategy::DivideAndConquer],
            StrategyArg::Traditional => vec![Strategy::Traditional],
            StrategyArg::Both => vec![Strategy::DivideAndConquer, Strategy::Traditional],
        }
    }
}

impl SimulationArgs {
    /// Simulates the model's experiment at selected or random poses; also returns a line
    /// describing where the measurements came from.
    fn experiment(
        &self,
        mechanism: &crate::model::Mechanism,
    ) -> anyhow::Result<(crate::measure::simulate::SimulatedExperiment, String)> {
        use crate::measure::simulate::{setup, simulate, simulate_at};
        let options = self.options()?;
        let simulation = setup(mechanism)?;
        let seed = options.seed.unwrap_or(simulation.seed);
        let noise = format!("seed {seed}, noise scale {}", options.noise_scale);
        match self.poses {
            PosesArg::Random => {
                let count = options.poses_per_leg.unwrap_or(simulation.poses_per_leg);
                let experiment = simulate(mechanism, options)?;
                let text = format!(
                    "simulated at random poses: {count} per leg and {count} shared, {noise}"
                );
                Ok((experiment, text))
            }
            PosesArg::Selected => {
                let count = options
                    .poses_per_leg
                    .unwrap_or(mechanism.selection.poses_per_leg);
                let criterion = mechanism.selection.criterion;
                let design = crate::workspace::design::ExperimentDesign::select(
                    mechanism, self.grid, count, criterion, true,
                )?;
                let experiment = simulate_at(mechanism, &design.pose_sets(), options)?;
                let text = format!(
                    "simulated at selected poses ({:?}-optimal from {} feasible candidates, grid {} m): {count} per leg and {count} shared, {noise}",
                    mechanism.selection.criterion, design.candidates, design.spacing
                );
                Ok((experiment, text))
            }
        }
    }

    fn options(&self) -> anyhow::Result<crate::measure::simulate::SimulationOptions> {
        if !(self.noise_scale.is_finite() && self.noise_scale >= 0.0) {
            anyhow::bail!(
                "--noise-scale: expected a non-negative number, found {}",
                self.noise_scale
            );
        }
        check_poses_per_leg(self.poses_per_leg)?;
        Ok(crate::measure::simulate::SimulationOptions {
            seed: self.seed,
            noise_scale: self.noise_scale,
            poses_per_leg: self.poses_per_leg,
        })
    }
}

/// `--poses-per-leg` within 1..=[`MAX_POSES_PER_LEG`](crate::model::mechanism::MAX_POSES_PER_LEG).
fn check_poses_per_leg(count: Option<usize>) -> anyhow::Result<()> {
    use crate::model::mechanism::MAX_POSES_PER_LEG;
    match count {
        Some(n) if !(1..=MAX_POSES_PER_LEG).contains(&n) => {
            anyhow::bail!("--poses-per-leg: expected between 1 and {MAX_POSES_PER_LEG}, found {n}")
        }
        _ => Ok(()),
    }
}

/// Runs a parsed command line.
///
/// # Errors
/// Any error of the library, with context; `main` prints it on one line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Identify(args) => identify::run(&args),
        Command::Select(args) => select::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Workspace(args) => workspace::run(&args),
        Command::Evaluate(args) => evaluate::run(&args),
    }
}
