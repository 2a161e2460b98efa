//! Shared helpers for the integration tests.
use std::path::PathBuf;

use argmin::core::{Jacobian, Operator};
use legwise::model::Mechanism;
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// Absolute path of a file in the crate.
pub(crate) fn crate_path(relative: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// Loads a bundled model by file name (`5r.yaml`).
pub(crate) fn bundled(name: &str) -> Mechanism {
    Mechanism::load(&crate_path(&format!("models/{name}"))).expect("bundled model loads")
}

/// Every bundled model (`models/*.yaml`).
#[allow(dead_code)]
pub(crate) fn bundled_models() -> Vec<Mechanism> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(crate_path("models"))
        .expect("models/ exists")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    paths.sort();
    paths
        .iter()
        .map(|p| Mechanism::load(p).expect("bundled model loads"))
        .collect()
}

/// Any argmin least-squares problem seen by the `levenberg-marquardt` crate (a MINPACK port, the
/// test oracle), with its current parameters.
pub(crate) struct Minpack<P>(pub(crate) P, pub(crate) DVector<f64>);

impl<P> levenberg_marquardt::LeastSquaresProblem<f64, Dyn, Dyn> for Minpack<P>
where
    P: Operator<Param = DVector<f64>, Output = DVector<f64>>
        + Jacobian<Param = DVector<f64>, Jacobian = DMatrix<f64>>,
{
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;
    fn set_params(&mut self, x: &DVector<f64>) {
        self.1.copy_from(x);
    }
    fn params(&self) -> DVector<f64> {
        self.1.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        self.0.apply(&self.1).ok()
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.0.jacobian(&self.1).ok()
    }
}

/// The contents of every `<text>` element of an SVG, trimmed.
pub(crate) fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|chunk| {
            let start = chunk.find('>')? + 1;
            let end = chunk.find("</text>")?;
            Some(chunk[start..end].trim().to_string())
        })
        .collect()
}

/// Every column of `jacobian` matches central differences of `problem`'s residuals at `x`
/// (steps 1e-6 (1 + |x_j|)) to 1e-6 of the column's largest entry (at least 1e-3); `what`
/// names the case in the message.
pub(crate) fn assert_central_differences<P>(
    problem: &P,
    x: &DVector<f64>,
    jacobian: &DMatrix<f64>,
    what: &str,
) where
    P: Operator<Param = DVector<f64>, Output = DVector<f64>>,
{
    for j in 0..x.len() {
        let h = 1e-6 * (1.0 + x[j].abs());
        let (mut plus, mut minus) = (x.clone(), x.clone());
        plus[j] += h;
        minus[j] -= h;
        let central = (problem.apply(&plus).unwrap() - problem.apply(&minus).unwrap()) / (2.0 * h);
        let gap = (jacobian.column(j) - &central).amax();
        let scale = central.amax().max(1e-3);
        assert!(
            gap <= 1e-6 * scale,
            "{what}, column {j}: gap {gap:e} (scale {scale:e})"
        );
    }
}

/// The fit options of ordinary (unweighted) least squares, the paper's method: what the tests
/// of the unweighted formulas ask for, the default being weighted by a declared noise.
#[allow(dead_code)]
pub(crate) fn unweighted() -> legwise::identify::estimate::FitOptions {
    legwise::identify::estimate::FitOptions {
        weights: legwise::identify::estimate::Weighting::Unweighted,
        ..Default::default()
    }
}

/// [`legwise::identify::estimate::identify`] by ordinary least squares ([`unweighted`]).
#[allow(dead_code)]
pub(crate) fn identify_unweighted(
    mechanism: &Mechanism,
    data: &legwise::measure::MeasurementSet,
    strategy: legwise::identify::estimate::Strategy,
    solver: legwise::solver::SolverKind,
) -> legwise::error::Result<legwise::identify::estimate::StrategyResult> {
    legwise::identify::estimate::identify_with(mechanism, data, strategy, solver, unweighted())
}

/// The numeric attribute `attribute` (`y`, `font-size`) of the first `<text>` element of `svg`
/// whose text starts with `start`.
pub(crate) fn svg_text_attribute(svg: &str, start: &str, attribute: &str) -> f64 {
    let element = svg
        .split("<text")
        .find(|c| {
            c.split('>')
                .nth(1)
                .is_some_and(|t| t.trim_start().starts_with(start))
        })
        .unwrap_or_else(|| panic!("no text `{start}`"));
    element
        .split(&format!(" {attribute}=\""))
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .and_then(|value| value.parse().ok())
        .unwrap_or_else(|| panic!("text `{start}`: no numeric {attribute}"))
}

/// `mechanism` with the named leg and instrument parameters identified (`identified`) or held.
pub(crate) fn with_identified(
    mechanism: &Mechanism,
    names: &[&str],
    identified: bool,
) -> Mechanism {
    mechanism.edited(|parts| {
        for leg in &mut parts.legs {
            for p in &mut leg.params {
                if names.contains(&p.name.as_str()) {
                    p.identified = identified;
                }
            }
        }
        if let Some(instrument) = parts.instrument.as_mut() {
            for p in &mut instrument.parameters {
                if names.contains(&p.name.as_str()) {
                    p.identified = identified;
                }
            }
        }
    })
}

/// `mechanism` without any prior (every parameter's `prior:` removed): a freed parameter is
/// then fitted on the data alone.
pub(crate) fn without_priors(mechanism: &Mechanism) -> Mechanism {
    mechanism.edited(|parts| {
        for p in parts.legs.iter_mut().flat_map(|l| l.params.iter_mut()) {
            p.prior = None;
        }
    })
}
