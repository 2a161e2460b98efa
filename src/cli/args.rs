//! The command line's arguments (clap derive), and the settings that several commands share.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};

use super::checks;
use super::help;
use crate::pipeline::{PoseSource, SimulationSettings};
use crate::solver::SolverKind;

/// Kinematic identification of parallel mechanisms, leg by leg.
#[derive(Debug, Parser)]
#[command(name = "legwise", version, about, after_help = help::TOP)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Identify the parameters of a mechanism from measurements (or from a simulation).
    #[command(after_help = help::IDENTIFY)]
    Identify(IdentifyArgs),
    /// Select the identification poses to measure (observability-optimal, feasible) and write
    /// them as a measurement CSV with empty readings.
    #[command(after_help = help::SELECT)]
    Select(SelectArgs),
    /// Simulate an identification experiment and write it as a measurement CSV.
    #[command(after_help = help::SIMULATE)]
    Simulate(SimulateArgs),
    /// Compute the singularity-free region and its maximal inscribed workspace (MIW), with a picture.
    #[command(after_help = help::WORKSPACE)]
    Workspace(WorkspaceArgs),
    /// How well a model explains measurements (typically held out of the fit): pose errors by
    /// forward kinematics from the readings, and each leg's reading residuals.
    #[command(after_help = help::EVALUATE)]
    Evaluate(EvaluateArgs),
    /// Monte Carlo comparison of the strategies: many simulated experiments, the same draws fed
    /// to divide and conquer and to the traditional strategy (through an instrument: to the
    /// joint and the two-stage identification), with 95 % confidence intervals.
    #[command(after_help = help::MONTECARLO)]
    Montecarlo(MontecarloArgs),
    /// A delta printer's firmware files: import a Klipper printer.cfg as a model and probe CSV,
    /// export a calibrated model as Klipper's SAVE_CONFIG values, write selected touches as the
    /// firmware's probing commands (docs/printers.md).
    #[command(after_help = help::PRINTER)]
    Printer(PrinterArgs),
    /// Fit the model's own parameters and each of its factor sets (`factor_sets:`, e.g. a
    /// firmware's calibration factors) on the same measurements: residual, degrees of freedom,
    /// scale against the declared noise, predicted σ over the workspace, rank, each factor's σ.
    #[command(after_help = help::SETS)]
    Sets(SetsArgs),
    /// How many rows a model needs: the predicted σ of its target over the workspace at
    /// several numbers of selected rows (each as `identify --poses-per-leg N`), as a table.
    #[command(name = "how-many", after_help = help::HOW_MANY)]
    HowMany(HowManyArgs),
}

/// Options of `legwise how-many`.
#[derive(Debug, clap::Args)]
pub struct HowManyArgs {
    /// The model file (YAML), seen through the forward kinematics, with a simulation block.
    #[arg(long)]
    pub model: PathBuf,
    /// The numbers of rows, comma-separated (default: 1/4, 1/2, 3/4, 1, 3/2 and 2 times the
    /// model's `selection.poses_per_leg`).
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub counts: Option<Vec<i64>>,
    /// Seed of the simulated experiments (default: the model's `simulation.seed`).
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<i128>,
    /// Also write the table as JSON to this file (`-`: standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Directory for the picture (created if missing): the predicted σ against the rows.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the picture as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
}

/// Options of `legwise sets`.
#[derive(Debug, clap::Args)]
pub struct SetsArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement CSV (default: the model's simulated experiment).
    #[arg(long)]
    pub measurements: Option<PathBuf>,
    /// Also write the table as JSON to this file (`-`: standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Directory for the pictures (created if missing): each row's residual where it was
    /// measured, before (the nominal model) and after (the model's own set); models seen
    /// through an instrument.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the pictures as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
    /// Check the choice on this many simulated experiments (1 to 100000): each set's true
    /// error over the workspace, how often the rows recommend it, against the best in
    /// hindsight.
    #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["measurements", "plots"])]
    pub trials: Option<i64>,
    /// Seed of the --trials study, 0 to 2^64 − 1; trial i's draws derive from it and i.
    #[arg(
        long,
        default_value_t = 1,
        allow_negative_numbers = true,
        requires = "trials"
    )]
    pub seed: i128,
}

/// Options of `legwise printer`.
#[derive(Debug, clap::Args)]
pub struct PrinterArgs {
    /// Import, export or points.
    #[command(subcommand)]
    pub command: PrinterCommand,
}

/// The subcommands of `legwise printer`.
#[derive(Debug, Subcommand)]
pub enum PrinterCommand {
    /// Read a Klipper printer.cfg (SAVE_CONFIG block included), a RepRapFirmware config.g
    /// (config-override.g over it) or a Marlin M503 report with a probe log, and write
    /// DIR/printer.yaml, DIR/printer.urdf and DIR/probe.csv (the probe's touches).
    Import(PrinterImportArgs),
    /// Write a calibrated imported model as the firmware's values (Klipper's SAVE_CONFIG block,
    /// RepRapFirmware's or Marlin's M665/M666 lines), with what the firmware cannot express
    /// (µm RMS over the bed).
    Export(PrinterExportArgs),
    /// Write the touches `legwise select` picked for an imported printer as the firmware's
    /// probing commands (RepRapFirmware's bed.g, Marlin's G30 lines, Klipper's
    /// [delta_calibrate] points), whose log `printer import` reads back.
    Points(PrinterPointsArgs),
    /// Compare, on simulated printers, legwise's calibration (its selected touches, its fit,
    /// exported through the firmware's values) with the firmware's own (its points, its
    /// factors), by the print error each leaves.
    Study(PrinterStudyArgs),
}

/// Options of `legwise printer import`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("firmware").required(true).args(["klipper", "rrf", "marlin"])))]
pub struct PrinterImportArgs {
    /// The Klipper printer.cfg of a linear delta.
    #[arg(long, value_name = "printer.cfg")]
    pub klipper: Option<PathBuf>,
    /// A RepRapFirmware config.g (M665, M666, M92, G31).
    #[arg(long, value_name = "config.g")]
    pub rrf: Option<PathBuf>,
    /// RepRapFirmware's config-override.g, read over --rrf's file (its values win).
    #[arg(long = "override", value_name = "config-override.g", requires = "rrf")]
    pub overrides: Option<PathBuf>,
    /// A Marlin M503 report (M665, M666, M92, M851).
    #[arg(long, value_name = "m503.txt")]
    pub marlin: Option<PathBuf>,
    /// The console log of a bed probe (RepRapFirmware: G30 P… X… Y… Z-99999 lines and the
    /// "bed probe heights:" reply, or G30 S-1 and "Stopped at height"; Marlin: "Bed X: Y: Z:"
    /// lines of G30 or G29 V3).
    #[arg(long, value_name = "log.txt", conflicts_with = "klipper")]
    pub probes: Option<PathBuf>,
    /// Directory for printer.yaml, printer.urdf and probe.csv (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// σ of the probe's height, m (the model's `noise.z`).
    #[arg(long, default_value_t = crate::printer::delta_model::DEFAULT_PROBE_NOISE, allow_negative_numbers = true)]
    pub probe_noise: f64,
    /// σ of a DELTA_ANALYZE distance, m (with distances in the file).
    #[arg(long, default_value_t = crate::printer::delta_model::DEFAULT_DISTANCE_NOISE, allow_negative_numbers = true)]
    pub distance_noise: f64,
    /// Prior σ of each rod's length, m: heights alone identify the rods on it (0 holds them;
    /// with distances in the file they are identified without a prior).
    #[arg(long, default_value_t = crate::printer::delta_model::DEFAULT_ROD_PRIOR, allow_negative_numbers = true)]
    pub rod_prior: f64,
    /// Prior σ of each carriage's gain (its travel per step against the firmware's step
    /// setting), identified on it where the file gives the step settings (0 holds them).
    #[arg(long, default_value_t = crate::printer::delta_model::DEFAULT_GAIN_PRIOR, allow_negative_numbers = true)]
    pub gain_prior: f64,
}

/// Options of `legwise printer export`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("firmware").required(true).args(["klipper", "rrf", "marlin"])))]
pub struct PrinterExportArgs {
    /// Export for Klipper: a SAVE_CONFIG block.
    #[arg(long)]
    pub klipper: bool,
    /// Export for RepRapFirmware: M665 and M666 lines (with the bed tilt A B).
    #[arg(long)]
    pub rrf: bool,
    /// Export for Marlin: M665 and M666 lines and M500.
    #[arg(long)]
    pub marlin: bool,
    /// The calibrated model (`legwise identify --calibrated cal.yaml` on an imported printer).
    #[arg(long, value_name = "cal.yaml")]
    pub calibrated: PathBuf,
    /// Where to write the values (`-`: standard output).
    #[arg(long, value_name = "cal.cfg")]
    pub out: PathBuf,
    /// Radius of the bed disc the fit covers, m (default: the model's workspace radius).
    #[arg(long, allow_negative_numbers = true)]
    pub bed_radius: Option<f64>,
    /// The firmware file the printer was imported from (printer.cfg, config.g or the M503
    /// report): its step settings (`rotation_distance`, `M92`) are written scaled by the
    /// calibrated gains. Without it the gains cannot be exported and count in the loss.
    #[arg(long, value_name = "FILE")]
    pub firmware_config: Option<PathBuf>,
}

/// Options of `legwise printer points`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("firmware").required(true).args(["klipper", "rrf", "marlin"])))]
pub struct PrinterPointsArgs {
    /// The Klipper printer.cfg the model was imported from (its [delta_calibrate] radius).
    #[arg(long, value_name = "printer.cfg")]
    pub klipper: Option<PathBuf>,
    /// The RepRapFirmware config.g the model was imported from (its G31 X Y probe offset).
    #[arg(long, value_name = "config.g")]
    pub rrf: Option<PathBuf>,
    /// RepRapFirmware's config-override.g, read over --rrf's file (its values win).
    #[arg(long = "override", value_name = "config-override.g", requires = "rrf")]
    pub overrides: Option<PathBuf>,
    /// The Marlin M503 report the model was imported from (its M851 X Y probe offset).
    #[arg(long, value_name = "m503.txt")]
    pub marlin: Option<PathBuf>,
    /// The imported model (`legwise printer import --out DIR`: DIR/printer.yaml).
    #[arg(long, value_name = "printer.yaml")]
    pub model: PathBuf,
    /// The selection (`legwise select --model DIR/printer.yaml --out SELECTED.csv`).
    #[arg(long, value_name = "SELECTED.csv")]
    pub selected: PathBuf,
    /// Where to write the commands (`-`: standard output).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// Options of `legwise printer study`.
#[derive(Debug, clap::Args)]
pub struct PrinterStudyArgs {
    /// Against Klipper's DELTA_CALIBRATE: its seven points at the model's bed radius (its
    /// [delta_calibrate] radius), the set `klipper-6`; legwise's fit exported as Klipper values.
    /// Without it, legwise's fit (and with --sets the model's factor sets) alone.
    #[arg(long)]
    pub klipper: bool,
    /// The printer's model: imported (`legwise printer import --out DIR`: DIR/printer.yaml),
    /// or any model seen through a probe (`instrument.kinematics: forward`) with a cylinder
    /// workspace.
    #[arg(long, value_name = "printer.yaml")]
    pub model: PathBuf,
    /// Number of simulated printers (1 to 100000).
    #[arg(long, default_value_t = 100, allow_negative_numbers = true)]
    pub printers: i64,
    /// Study seed, 0 to 2^64 − 1; printer i's draws derive from it and i.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    pub seed: i128,
    /// legwise's touches (default: the model's `selection.poses_per_leg`).
    #[arg(long, allow_negative_numbers = true)]
    pub touches: Option<i64>,
    /// σ of the printers' lengths about the model's (towers, rods, carriage offsets, effector
    /// joints, the bed's height), m.
    #[arg(long, default_value_t = 3e-4, allow_negative_numbers = true)]
    pub spread_length: f64,
    /// σ of the bed's tilt, rad.
    #[arg(long, default_value_t = 1e-3, allow_negative_numbers = true)]
    pub spread_angle: f64,
    /// σ of the actuator gains (steps per mm), relative.
    #[arg(long, default_value_t = 1e-3, allow_negative_numbers = true)]
    pub spread_gain: f64,
    /// Grid spacing of the print-error map over the workspace, m.
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub map: f64,
    /// Also fit every factor set of the model on legwise's touches: each set's print error,
    /// and how the set recommended by the touches' leave-one-out error does against the best
    /// in hindsight.
    #[arg(long)]
    pub sets: bool,
    /// Write every printer's errors and the summary as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// Options of `legwise montecarlo`.
#[derive(Debug, clap::Args)]
pub struct MontecarloArgs {
    /// The model file (YAML) with a simulation block.
    #[arg(long)]
    pub model: PathBuf,
    /// Number of trials (2 to 1000000).
    #[arg(long, allow_negative_numbers = true)]
    pub trials: i64,
    /// Study seed, 0 to 2^64 − 1 (default: the model's `simulation.seed`); each trial's draws
    /// derive from it and the trial's index.
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<i128>,
    /// Least-squares solver of every fit.
    #[arg(long, value_enum, default_value_t = SolverArg::Lm)]
    pub solver: SolverArg,
    /// Multiplies every simulated noise standard deviation (0 = noise-free).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    pub noise_scale: f64,
    /// Poses per leg (default: the model's `selection.poses_per_leg`).
    #[arg(long, allow_negative_numbers = true)]
    pub poses_per_leg: Option<i64>,
    /// Candidate grid spacing of the pose selection, metres (default: the model's `workspace.grid`).
    #[arg(long, allow_negative_numbers = true)]
    pub grid: Option<f64>,
    /// A forward model's commanded poses, measured in every trial instead of selected ones: a
    /// CSV with a `pose.<coordinate>` column per measured coordinate (as `legwise select`
    /// writes; other columns ignored), e.g. a firmware's probe points.
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
    /// Grid spacing of the accuracy map, metres.
    #[arg(long, value_name = "GRID_M", default_value_t = crate::study::montecarlo::DEFAULT_MAP_GRID, allow_negative_numbers = true)]
    pub map: f64,
    /// Fraction of the workspace region the accuracy map covers (shrunk about its centre).
    #[arg(long, default_value_t = 0.95, allow_negative_numbers = true)]
    pub map_scale: f64,
    /// Also write the study as JSON to this file, every trial's values included (`-`: standard
    /// output; the terminal report then goes to standard error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Directory for the pictures (created if missing): the error distributions per strategy.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the pictures as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
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

/// Options of `legwise workspace`.
#[derive(Debug, clap::Args)]
pub struct WorkspaceArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Where to write the picture, SVG or PNG by the extension (default:
    /// `<model name>-workspace.svg`, or `.png` with `--png`; `-`: standard output).
    #[arg(long, visible_alias = "svg")]
    pub out: Option<PathBuf>,
    /// Draw the picture as PNG instead of SVG (the default name, or standard output).
    #[arg(long)]
    pub png: bool,
    /// A pose file to draw on the picture (measurement CSV layout; readings may be empty).
    #[arg(long)]
    pub poses: Option<PathBuf>,
    /// Rays cast to trace the region's boundary (16 to 100000).
    #[arg(long, default_value_t = 1440, allow_negative_numbers = true)]
    pub rays: i64,
}

/// Options of `legwise identify`.
#[derive(Debug, clap::Args)]
pub struct IdentifyArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Measurement CSV (`-`: standard input); without it, the model's simulation block is
    /// simulated.
    #[arg(long)]
    pub measurements: Option<PathBuf>,
    /// Least-squares solver.
    #[arg(long, value_enum, default_value_t = SolverArg::Lm)]
    pub solver: SolverArg,
    /// Divide and conquer, traditional (all legs on shared poses), or both.
    #[arg(long, value_enum, default_value_t = StrategyArg::Dc)]
    pub strategy: StrategyArg,
    /// Also write the report as JSON to this file (`-`: standard output; the terminal report
    /// then goes to standard error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Row weights: none (ordinary least squares, the paper's method) or noise (each row by the
    /// inverse of its expected residual variance under the model's `noise` block, evaluated at
    /// the estimate) [default: noise when the model declares a noise, else none].
    #[arg(long, value_enum)]
    pub weights: Option<WeightsArg>,
    /// A robust loss inside the fit (scaled by the model's `noise` block): huber or cauchy.
    /// Not with `--drop-outliers` (the loss weighs outliers down; the other drops them).
    #[arg(long, value_enum, conflicts_with = "drop_outliers")]
    pub robust: Option<RobustArg>,
    /// Refit once without the rows flagged as outliers, and list them.
    #[arg(long)]
    pub drop_outliers: bool,
    /// Simulation overrides.
    #[command(flatten)]
    pub simulation: SimulationArgs,
    /// Write the calibrated model (identified values in place of nominal ones) to this YAML
    /// file, and its URDF beside it (same name, extension `urdf`).
    #[arg(long, value_name = "OUT.yaml")]
    pub calibrated: Option<PathBuf>,
    /// A previous calibration as the prior of this fit: the estimates and covariance a
    /// calibrated model written by --calibrated carries (the joint fit through an instrument).
    #[arg(long, value_name = "CAL.yaml")]
    pub prior: Option<PathBuf>,
    /// Simulation only: the accuracy map (model IK commands, real mechanism moves) over a grid
    /// of this spacing (metres), before and after identification.
    #[arg(long, value_name = "GRID_M", allow_negative_numbers = true)]
    pub map: Option<f64>,
    /// Fraction of the workspace region the accuracy map covers (shrunk about its centre)
    /// [default: 0.95].
    #[arg(long, allow_negative_numbers = true)]
    pub map_scale: Option<f64>,
    /// Simulation only: write the pictures to this directory (created if missing): the
    /// parameter errors before and after, and with `--map` the accuracy map.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Draw the pictures as PNG instead of SVG.
    #[arg(long)]
    pub png: bool,
}

/// `--weights`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum WeightsArg {
    /// Unweighted.
    None,
    /// By the declared measurement noise.
    Noise,
}

/// `--robust`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RobustArg {
    /// Huber's loss (quadratic near zero, linear beyond 1.345 σ).
    Huber,
    /// Cauchy's loss (logarithmic beyond 2.385 σ: gross outliers get almost no weight).
    Cauchy,
}

/// Options of `legwise simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// The model file (YAML).
    #[arg(long)]
    pub model: PathBuf,
    /// Where to write the measurement CSV (`-`: standard output).
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
    /// Where to write the poses (measurement CSV layout, readings empty; `-`: standard output).
    #[arg(long)]
    pub out: PathBuf,
    /// Per-leg sets (dc), one shared set (traditional), or both.
    #[arg(long, value_enum, default_value_t = StrategyArg::Dc)]
    pub strategy: StrategyArg,
    /// Candidate grid spacing, metres (default: the model's `workspace.grid`).
    #[arg(long, allow_negative_numbers = true)]
    pub grid: Option<f64>,
    /// Poses per leg (default: the model's `selection.poses_per_leg`).
    #[arg(long, allow_negative_numbers = true)]
    pub poses_per_leg: Option<i64>,
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

/// Where simulated identification poses come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PosesArg {
    /// Observability-optimal poses selected from the candidate grid (the paper's protocol).
    Selected,
    /// A seeded random spread over the usable workspace.
    Random,
}

/// Simulation overrides (none is the model's simulation block as written).
#[derive(Debug, Clone, clap::Args)]
pub struct SimulationArgs {
    /// Where the simulated poses come from [default: selected].
    #[arg(long, value_enum)]
    pub poses: Option<PosesArg>,
    /// Candidate grid spacing for selected poses, metres (default: the model's `workspace.grid`).
    #[arg(long, allow_negative_numbers = true)]
    pub grid: Option<f64>,
    /// Random seed, 0 to 2^64 − 1 (default: the model's `simulation.seed`).
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<i128>,
    /// Multiplies every simulated noise standard deviation (0 = noise-free) [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    pub noise_scale: Option<f64>,
    /// Poses per leg (default: the model's `simulation.poses_per_leg`).
    #[arg(long, allow_negative_numbers = true)]
    pub poses_per_leg: Option<i64>,
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

/// The fraction of the region the accuracy map covers when `--map-scale` is not given.
pub(super) const DEFAULT_MAP_SCALE: f64 = 0.95;

impl IdentifyArgs {
    /// `--map-scale`, or its default; refused without `--map`, which it would not change.
    pub(super) fn map_scale(&self) -> anyhow::Result<f64> {
        match (self.map, self.map_scale) {
            (None, Some(_)) => anyhow::bail!(
                "--map-scale: the fraction of the region the accuracy map covers, but no --map \
                 asks for a map; add --map GRID_M or drop --map-scale"
            ),
            (_, scale) => Ok(scale.unwrap_or(DEFAULT_MAP_SCALE)),
        }
    }
}

impl SolverArg {
    pub(super) fn kind(self) -> SolverKind {
        match self {
            SolverArg::Lm => SolverKind::LevenbergMarquardt,
            SolverArg::Gn => SolverKind::GaussNewton,
        }
    }
}

impl SimulationArgs {
    /// The simulation settings, range-checked (`--grid` refused with random poses, which do
    /// not use it).
    pub(super) fn settings(&self) -> anyhow::Result<SimulationSettings> {
        checks::positive_metres("--grid", self.grid)?;
        if self.grid.is_some() && self.poses == Some(PosesArg::Random) {
            anyhow::bail!(
                "--grid: the candidate grid of selected poses, but --poses random draws them \
                 without one; drop --grid (or --poses random)"
            );
        }
        let options = crate::measure::simulate::SimulationOptions {
            seed: checks::seed("--seed", self.seed)?,
            noise_scale: checks::non_negative("--noise-scale", self.noise_scale.unwrap_or(1.0))?,
            poses_per_leg: checks::poses_per_leg(self.poses_per_leg)?,
        };
        Ok(SimulationSettings {
            options,
            poses: match self.poses.unwrap_or(PosesArg::Selected) {
                PosesArg::Selected => PoseSource::Selected,
                PosesArg::Random => PoseSource::Random,
            },
            grid: self.grid,
        })
    }

    /// The first simulation option given on the command line, if any.
    pub(super) fn first_given(&self) -> Option<&'static str> {
        [
            (self.poses.is_some(), "--poses"),
            (self.grid.is_some(), "--grid"),
            (self.seed.is_some(), "--seed"),
            (self.noise_scale.is_some(), "--noise-scale"),
            (self.poses_per_leg.is_some(), "--poses-per-leg"),
        ]
        .into_iter()
        .find_map(|(given, flag)| given.then_some(flag))
    }
}
