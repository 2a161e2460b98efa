//! What a run is asked to do: the strategies, the solver and the fit, how to simulate when no
//! measurements are given, and the accuracy map. Plain data, independent of the model.

use crate::identify::result::{FitOptions, Strategy};
use crate::measure::simulate::SimulationOptions;
use crate::solver::SolverKind;

/// Everything a run is asked to do besides the model and the measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The strategies to run, in order; empty: the model's default (divide and conquer, or
    /// through an instrument the joint identification and the two-stage one to compare).
    pub strategies: Vec<Strategy>,
    /// The least-squares solver (a model with an instrument block uses Levenberg–Marquardt).
    pub solver: SolverKind,
    /// How each fit treats its rows. Its `noise_scale` is the simulation's when simulating.
    pub fit: FitOptions,
    /// How to simulate the measurements when none are given.
    pub simulation: SimulationSettings,
    /// The accuracy map before and after (simulation only: it needs the real parameters).
    pub map: Option<MapSettings>,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            strategies: Vec::new(),
            solver: SolverKind::LevenbergMarquardt,
            fit: FitOptions::default(),
            simulation: SimulationSettings::default(),
            map: None,
        }
    }
}

/// How a run simulates its measurements.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SimulationSettings {
    /// Seed, noise scale and poses per leg (the model's simulation block where unset).
    pub options: SimulationOptions,
    /// Where the simulated poses come from.
    pub poses: PoseSource,
    /// Candidate grid spacing of the pose selection, metres (default: the model's
    /// `workspace.grid`).
    pub grid: Option<f64>,
}

/// Where simulated identification poses come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PoseSource {
    /// Observability-optimal poses selected from the candidate grid (the paper's protocol).
    #[default]
    Selected,
    /// A seeded random spread over the usable workspace.
    Random,
}

/// The accuracy map's grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSettings {
    /// Grid spacing, metres.
    pub grid_m: f64,
    /// Fraction of the workspace region covered (shrunk about its centre).
    pub scale: f64,
}

impl Settings {
    /// The strategies to run on `mechanism`: [`Self::strategies`], or the model's default.
    pub fn strategies_for(&self, mechanism: &crate::model::Mechanism) -> Vec<Strategy> {
        if !self.strategies.is_empty() {
            self.strategies.clone()
        } else if mechanism.forward_instrument().is_some() {
            // Forward rows couple every leg: identified together, or not at all.
            vec![Strategy::Joint]
        } else if mechanism.instrument.is_some() && !mechanism.has_priors() {
            vec![Strategy::Joint, Strategy::TwoStage]
        } else if mechanism.instrument.is_some() {
            // The two-stage comparison fits without priors: the joint fit alone.
            vec![Strategy::Joint]
        } else {
            vec![Strategy::DivideAndConquer]
        }
    }
}
