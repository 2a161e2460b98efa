//! What an identification returns: one result type for every strategy, with the estimates of
//! each parameter block (every leg's, and an instrument's when measured through one), the
//! solver runs and the statistics of the fit.

use nalgebra::{DMatrix, DVector};

use super::observability::Observability;
use super::statistics::{LegStatistics, NoiseTest, Outlier};
use crate::model::mechanism::MeasurementNoise;
use crate::model::params::Unit;
use crate::model::Mechanism;
use crate::solver::{SolverKind, SolverOutcome, StopReason};

/// How the parameter blocks are grouped into least-squares problems. The first two group the
/// legs' readings at measured poses; the last two are for measurements through an instrument,
/// whose frame and target offsets are parameter blocks shared by every leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Each leg alone, on the poses labelled with it (Durango et al.).
    DivideAndConquer,
    /// All legs in one problem, on the shared poses only.
    Traditional,
    /// Every leg's parameters and the instrument's identified ones in one problem, each leg's
    /// rows on its own poses (Levenberg–Marquardt steps by the Schur complement on the shared
    /// parameters).
    Joint,
    /// First the instrument alone from a few rows of every leg with the nominal legs, then every
    /// leg on its own with the instrument held at that registration.
    TwoStage,
}

impl Strategy {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Strategy::DivideAndConquer => "divide and conquer",
            Strategy::Traditional => "traditional (all legs)",
            Strategy::Joint => "joint (legs and instrument, Schur complement)",
            Strategy::TwoStage => "two-stage (instrument registered first, then D&C)",
        }
    }

    /// Whether the strategy identifies through an instrument (shared parameter blocks).
    pub fn through_instrument(self) -> bool {
        match self {
            Strategy::DivideAndConquer | Strategy::Traditional => false,
            Strategy::Joint | Strategy::TwoStage => true,
        }
    }
}

/// One parameter's estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterEstimate {
    /// Name as in the model file.
    pub name: String,
    /// SI unit.
    pub unit: Unit,
    /// Nominal value.
    pub nominal: f64,
    /// Identified value (the nominal value for a fixed parameter).
    pub estimate: f64,
    /// Standard deviation `σ̂ √diag((CᵀC)⁻¹)`, `None` if fixed or without redundancy.
    pub std: Option<f64>,
    /// Identified (true) or held fixed.
    pub identified: bool,
    /// The residual degrees of freedom `m − n` of the σ̂ behind [`Self::std`]; `None` without
    /// a std, or when the std is the declared noise's, unscaled (fewer than
    /// [`SCALE_DOF`](super::sandwich::SCALE_DOF) degrees of freedom).
    pub degrees_of_freedom: Option<usize>,
    /// The prior's standard deviation, when the fit took one for the parameter (model file
    /// `prior:`).
    pub prior: Option<f64>,
    /// With a prior, the share of the parameter's information that comes from the data, `1 −
    /// σ_d²/σ_prior²` in `[0, 1]` (`σ_d` the declared noise's σ, not scaled by ŝ): 0 when the
    /// estimate rests on its prior alone, near 1 when the data determine it far better.
    pub data_share: Option<f64>,
}

impl ParameterEstimate {
    /// Half the width of the two-sided 95 % interval, `t(0.975, ν) · std` with Student's t on
    /// the [`degrees_of_freedom`](Self::degrees_of_freedom) ν (σ̂ is estimated from the
    /// residuals, so the normal 1.96 would make the interval too short), or `1.96 · std` for a
    /// std from the declared noise (no ν); `None` without a std.
    pub fn half_width95(&self) -> Option<f64> {
        let std = self.std?;
        Some(match self.degrees_of_freedom {
            Some(dof) => super::statistics::half_width95(std, dof),
            None => super::statistics::NORMAL_975 * std,
        })
    }

    /// Whether the std is the declared noise's, unscaled by the residuals (a std without
    /// degrees of freedom).
    pub fn std_from_declared_noise(&self) -> bool {
        self.std.is_some() && self.degrees_of_freedom.is_none()
    }
}

/// One leg's result.
#[derive(Debug, Clone, PartialEq)]
pub struct LegEstimate {
    /// Leg name.
    pub leg: String,
    /// Every parameter of the leg, in model order.
    pub parameters: Vec<ParameterEstimate>,
    /// Number of residual blocks (measured readings) used.
    pub measurements: usize,
    /// ½‖r‖² at the nominal parameters.
    pub initial_cost: f64,
    /// ½‖r‖² at the estimate.
    pub final_cost: f64,
    /// Residual standard deviation σ̂ = √(‖r‖²/(m − n)), if m > n.
    pub residual_sigma: Option<f64>,
    /// Observability of the identification Jacobian at the estimate.
    pub observability: Observability,
    /// Noise test, outliers and turns of the fit.
    pub statistics: LegStatistics,
    /// Rows left out by `--drop-outliers` (the outliers of the first fit).
    pub dropped: Vec<Outlier>,
    /// What the statistics found, one sentence each (noise rejected, outliers, other turns,
    /// dropped rows).
    pub warnings: Vec<String>,
    /// Covariance σ̂²(CᵀC)⁻¹ of the identified parameters (model order), from the SVD of the
    /// leg's identification Jacobian C; `None` without redundancy (m ≤ n).
    pub covariance: Option<DMatrix<f64>>,
    /// Each measurement's residual at the estimate, measured minus predicted reading, in row order.
    pub residuals: Vec<RowResidual>,
}

/// One measurement's residual at the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowResidual {
    /// Line of the measurement file (1-based, the header is line 1), if read from a file.
    pub line: Option<usize>,
    /// Measured minus predicted reading (rad or m).
    pub residual: f64,
}

/// A robust loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobustLoss {
    /// Huber: quadratic inside `c = 1.345 σ`, linear beyond.
    Huber,
    /// Cauchy (Lorentzian): logarithmic, `c = 2.3849 σ`; a gross outlier gets almost no weight.
    Cauchy,
}

/// How the rows are weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Weighting {
    /// [`Weighting::Noise`] when the fit expects a noise ([`FitOptions::expected_noise`]),
    /// else [`Weighting::Unweighted`]: the default.
    #[default]
    Declared,
    /// Ordinary least squares (the paper's method).
    Unweighted,
    /// Weighted least squares (generalised least squares on the rows' variances), each row by
    /// the inverse of its expected residual variance under the declared noise, evaluated at
    /// the estimate: the weights are re-evaluated and the fit repeated until they agree.
    Noise,
}

/// How each fit treats its rows (the defaults are the paper's plain least squares).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Row weights.
    pub weights: Weighting,
    /// A robust loss (its scale from the declared noise); replaces the weighting.
    pub robust: Option<RobustLoss>,
    /// Refit once without the rows flagged as outliers.
    pub drop_outliers: bool,
    /// The factor on the model's declared noise that the fit expects (1: as declared; a
    /// simulation at `noise_scale` F expects F times the declared noise). It scales what the
    /// statistics and the weights assume, never the model.
    pub noise_scale: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            weights: Weighting::Declared,
            robust: None,
            drop_outliers: false,
            noise_scale: 1.0,
        }
    }
}

impl FitOptions {
    /// The noise the fit expects: the model's declared noise times
    /// [`noise_scale`](Self::noise_scale), `None` when none is declared or all of it is zero.
    pub fn expected_noise(&self, mechanism: &Mechanism) -> Option<MeasurementNoise> {
        let scale = self.noise_scale;
        mechanism
            .noise
            .map(|noise| MeasurementNoise {
                pose: noise.pose.map(|s| s * scale),
                reading: noise.reading * scale,
                scale: noise.scale * scale,
            })
            .filter(|n| n.reading > 0.0 || n.pose.iter().any(|&s| s > 0.0))
    }

    /// These options for `mechanism`: [`Weighting::Declared`] made [`Weighting::Noise`] or
    /// [`Weighting::Unweighted`] by whether the fit expects a noise (a robust loss replaces
    /// the weighting: unweighted).
    pub fn resolved(self, mechanism: &Mechanism) -> FitOptions {
        let weights = match self.weights {
            Weighting::Declared
                if self.robust.is_none() && self.expected_noise(mechanism).is_some() =>
            {
                Weighting::Noise
            }
            Weighting::Declared => Weighting::Unweighted,
            chosen => chosen,
        };
        FitOptions { weights, ..self }
    }
}

/// One solver run (one per leg for divide and conquer, one in all for traditional).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SolverRun {
    /// The legs the run identified.
    pub legs: Vec<String>,
    /// Iterations.
    pub iterations: u64,
    /// Whether the solver converged; `false` means the estimate must not be trusted.
    pub converged: bool,
    /// Why the solver stopped (its `Display` is a sentence for humans).
    pub stop_reason: StopReason,
    /// Gauss–Newton refinement steps taken after the solver converged.
    pub refinement_steps: usize,
    /// ½‖r‖² before.
    #[serde(rename = "cost_before")]
    pub initial_cost: f64,
    /// ½‖r‖² after.
    #[serde(rename = "cost_after")]
    pub final_cost: f64,
    /// Residual evaluations.
    pub residual_evaluations: u64,
    /// Jacobian evaluations.
    pub jacobian_evaluations: u64,
    /// Wall-clock time of the solver run, seconds.
    pub seconds: f64,
}

impl SolverRun {
    /// The run of `outcome` on `legs`, with the residuals `(r0, r)` at the start and at the
    /// estimate (its costs ½‖r‖²), in `seconds`.
    pub fn new(
        legs: Vec<String>,
        outcome: &SolverOutcome,
        (r0, r): (&DVector<f64>, &DVector<f64>),
        seconds: f64,
    ) -> Self {
        SolverRun {
            legs,
            iterations: outcome.iterations,
            converged: outcome.converged,
            stop_reason: outcome.stop_reason,
            refinement_steps: outcome.refinement_steps,
            initial_cost: 0.5 * r0.norm_squared(),
            final_cost: 0.5 * r.norm_squared(),
            residual_evaluations: outcome.residual_evaluations,
            jacobian_evaluations: outcome.jacobian_evaluations,
            seconds,
        }
    }
}

/// The result of one strategy.
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyResult {
    /// The strategy.
    pub strategy: Strategy,
    /// The solver.
    pub solver: SolverKind,
    /// Per-leg estimates, in mechanism order.
    pub legs: Vec<LegEstimate>,
    /// Solver runs.
    pub runs: Vec<SolverRun>,
    /// The fit options.
    pub options: FitOptions,
    /// Warnings about the measurements as a whole (implausible values, duplicate rows).
    pub warnings: Vec<String>,
    /// Through an instrument: its parameters and the fit's statistics as a whole.
    pub instrument: Option<InstrumentEstimate>,
}

impl StrategyResult {
    /// The covariance of every identified parameter in one matrix, with their names (rows and
    /// columns in that order): through an instrument, the joint fit's matrix (the legs'
    /// identified parameters in the order of the result's legs, then the instrument's);
    /// otherwise the legs' blocks on the diagonal, the cross terms between legs zero (each
    /// leg's rows depend on its own parameters alone and are fitted apart, or as separable
    /// blocks of one problem). `None` when a fitted leg or the instrument has none.
    pub fn full_covariance(&self) -> Option<(Vec<String>, DMatrix<f64>)> {
        self.full_covariance_of(false)
    }

    /// [`Self::full_covariance`], through an instrument from the declared noise alone when the
    /// fit has it ([`InstrumentEstimate::declared_covariance`]): the information a next
    /// calibration's prior takes.
    pub fn declared_full_covariance(&self) -> Option<(Vec<String>, DMatrix<f64>)> {
        self.full_covariance_of(true)
    }

    /// The full covariance, the declared noise's through an instrument if `declared` and known.
    fn full_covariance_of(&self, declared: bool) -> Option<(Vec<String>, DMatrix<f64>)> {
        let identified = |ps: &[ParameterEstimate]| -> Vec<String> {
            ps.iter()
                .filter(|p| p.identified)
                .map(|p| p.name.clone())
                .collect()
        };
        let mut parameters: Vec<String> = self
            .legs
            .iter()
            .flat_map(|l| identified(&l.parameters))
            .collect();
        if let Some(instrument) = &self.instrument {
            parameters.extend(identified(&instrument.parameters));
            let matrix = match (declared, &instrument.declared_covariance) {
                (true, Some(matrix)) => matrix,
                _ => instrument.covariance.as_ref()?,
            };
            return (matrix.nrows() == parameters.len()).then(|| (parameters, matrix.clone()));
        }
        let n = parameters.len();
        let mut full = DMatrix::zeros(n, n);
        let mut at = 0;
        for leg in &self.legs {
            let block = leg.covariance.as_ref()?;
            if at + block.nrows() > n {
                return None;
            }
            full.view_mut((at, at), block.shape()).copy_from(block);
            at += block.nrows();
        }
        (at == n).then_some((parameters, full))
    }

    /// Every warning of the result: the data's, then each leg's statistics'.
    pub fn all_warnings(&self) -> Vec<String> {
        let legs = self
            .legs
            .iter()
            .flat_map(|leg| leg.warnings.iter().cloned());
        self.warnings.iter().cloned().chain(legs).collect()
    }

    /// Every parameter estimate of the result: the instrument's first (when measured through
    /// one), then each identified leg's, in model order.
    pub fn parameters(&self) -> impl Iterator<Item = &ParameterEstimate> {
        let instrument = self.instrument.iter().flat_map(|i| &i.parameters);
        instrument.chain(self.legs.iter().flat_map(|l| &l.parameters))
    }
}

/// The instrument's part of a result identified through it: its parameters (a parameter block
/// shared by every leg) and the statistics of the fit as a whole.
#[derive(Debug, Clone, PartialEq)]
pub struct InstrumentEstimate {
    /// Every instrument parameter (frame, then target offsets), the instrument's order.
    pub parameters: Vec<ParameterEstimate>,
    /// Rows (residuals) of the problem.
    pub rows: usize,
    /// Unknowns of the problem (of the last stage for the two-stage strategy).
    pub unknowns: usize,
    /// RMS residual at the estimate (reading units).
    pub rms: f64,
    /// Observability of the whole problem's Jacobian at the start.
    pub observability: Observability,
    /// The χ² test of the residuals against the declared noise (propagated from the target
    /// coordinates through the pose fit), if the model declares one.
    pub noise_test: Option<NoiseTest>,
    /// The residuals flagged as outliers (every observation kind, each on its declared σ;
    /// `identify::shared_outliers`), largest `|t|` first.
    pub outliers: Vec<super::shared_outliers::RowOutlier>,
    /// The threshold on `|t|` (`None` without enough redundancy).
    pub outlier_threshold: Option<f64>,
    /// With `--drop-outliers`: the first fit's outliers whose rows were left out of the refit.
    pub dropped: Vec<super::shared_outliers::RowOutlier>,
    /// The likelihood-ratio test of the frame components the model holds (joint strategy,
    /// when they can be freed and a noise is declared).
    pub held_frame: Option<HeldFrameTest>,
    /// The covariance of every unknown of the fit (the legs' identified parameters in model
    /// order, then the instrument's identified ones), when it has one (the joint strategy).
    pub covariance: Option<nalgebra::DMatrix<f64>>,
    /// The same from the declared noise alone, not scaled by the residuals' ŝ (the joint fit
    /// weighted by the declared noise): what the data determine, the prior a next calibration
    /// takes (`identify --prior`).
    pub declared_covariance: Option<nalgebra::DMatrix<f64>>,
    /// Seen through the forward kinematics: the predicted σ of the first target's position over
    /// the workspace, propagated from [`Self::covariance`].
    pub predicted_position: Option<PredictedPosition>,
}

/// The predicted standard deviation of a target's position over the workspace grid (the
/// square root of the trace of its 3 × 3 covariance at each point), metres.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PredictedPosition {
    /// The target.
    pub target: String,
    /// Grid points it was predicted at.
    pub points: usize,
    /// RMS over the points.
    #[serde(rename = "rms_m")]
    pub rms: f64,
    /// Largest.
    #[serde(rename = "max_m")]
    pub max: f64,
    /// The model's tolerance, if it declares one.
    #[serde(rename = "tolerance_m")]
    pub tolerance: Option<f64>,
}

/// The outcome of the held-frame test ([`super::held_test`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HeldFrameTest {
    /// The frame components held by the model and freed by the test (`frame_x`, …).
    pub freed: Vec<String>,
    /// `χ²_held − χ²_freed`: how much the fit improves when they are freed.
    pub chi_squared_drop: f64,
    /// Degrees of freedom: the number of components freed.
    pub degrees_of_freedom: usize,
    /// Upper-tail probability of the drop.
    pub p_value: f64,
    /// `p_value < NOISE_TEST_P` ([`super::statistics::rejects`]): the held values disagree
    /// with the measurements.
    pub rejected: bool,
    /// The freed fit's estimates of the freed components, in `freed` order.
    pub estimates: Vec<f64>,
}
