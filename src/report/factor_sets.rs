//! The factor-set table (`legwise sets`): per set its residual, degrees of freedom, scale
//! against the declared noise, predicted σ over the workspace and rank answer; then each set's
//! factors with their σ. SI units throughout.

use std::fmt::Write as _;

use serde_json::{json, Value};

use crate::identify::factor_set::FactorSetFit;

/// The table as text; `title` names the model and the measurements.
pub fn factor_sets_text(title: &str, fits: &[FactorSetFit]) -> String {
    let mut out = format!("{title}\n\n");
    let _ = writeln!(
        out,
        "{:<14} {:>7} {:>5} {:>12} {:>12} {:>8} {:>9} {:>26}  rank",
        "set",
        "factors",
        "dof",
        "RMS resid.",
        "left out",
        "scale",
        "AICc",
        "predicted σ RMS / max (m)"
    );
    for fit in fits {
        let predicted = fit.predicted.as_ref().map_or("-".to_string(), |p| {
            format!("{:.3e} / {:.3e}", p.rms, p.max)
        });
        let n = fit.factors.len();
        let rank = match fit.observability.rank == n {
            true => "full".to_string(),
            false => format!(
                "{} of {n}: cannot see {}",
                fit.observability.rank,
                fit.observability.unidentifiable.join(", ")
            ),
        };
        let left_out = fit.leave_one_out.map_or(f64::NAN, |v| v);
        let _ = writeln!(
            out,
            "{:<14} {:>7} {:>5} {:>12.3e} {:>12} {:>8} {:>9} {:>26}  {rank}",
            fit.name,
            n,
            fit.degrees_of_freedom,
            fit.rms,
            number(left_out, 3),
            number(fit.scale(), 3),
            aic(fit.information_corrected),
            predicted
        );
    }
    out.push_str(
        "\nRMS resid., left out: the residuals' RMS and that of each row's leave-one-out \
         prediction error, in the measurements' units (m, rad; - where a row alone sees a \
         factor). scale: the residual's RMS in declared σ (about 1 when the data agree \
         with the noise and the set explains them). AICc: Akaike's χ² + 2k corrected for few rows, \
         + 2k(k + 1)/(rows − k − 1) (k factors; lower is better on the same rows; inf: too \
         few rows to judge the set). σ below is the declared noise's, not scaled by it.\n",
    );
    for fit in fits {
        let note = fit
            .note
            .as_deref()
            .map_or(String::new(), |n| format!(" ({n})"));
        let _ = writeln!(out, "\n{}{note}:", fit.name);
        for f in &fit.factors {
            let prior = f.prior.map_or(String::new(), |sigma| {
                let share = f.data_share().map_or(String::new(), |s| {
                    format!(", {:.0} % of its information from the data", 100.0 * s)
                });
                format!(", prior ±{sigma:.2e}{share}")
            });
            let _ = writeln!(
                out,
                "  {:<14} {:>16.9e} ± {:<10} {}  (nominal {:.9e}, moved {:.3e}{prior})",
                f.name,
                f.estimate,
                number(f.sigma, 2),
                f.unit,
                f.nominal,
                f.estimate - f.nominal
            );
        }
        if !fit.resting_on_prior.is_empty() {
            let _ = writeln!(
                out,
                "  the data alone cannot see {}: it rests on the priors (k = {:.2} effective \
                 factors)",
                fit.resting_on_prior.join("; "),
                fit.effective_factors
            );
        }
    }
    out.push_str(&super::next_steps::next_steps_text(
        &super::next_steps::next_steps(fits),
    ));
    out
}

/// An information criterion to one decimal, `inf` when the rows cannot judge the set, `-`
/// without a declared noise.
fn aic(v: f64) -> String {
    match v.is_finite() {
        true => format!("{v:.1}"),
        false if v == f64::INFINITY => "inf".to_string(),
        false => "-".to_string(),
    }
}

/// `v` in scientific notation with `digits` decimals, `-` when not finite.
fn number(v: f64, digits: usize) -> String {
    match v.is_finite() {
        true => format!("{v:.digits$e}"),
        false => "-".to_string(),
    }
}

/// The table as JSON.
pub fn factor_sets_json(fits: &[FactorSetFit]) -> Value {
    let finite = |v: f64| v.is_finite().then_some(v);
    Value::Array(
        fits.iter()
            .map(|fit| {
                json!({
                    "name": fit.name,
                    "note": fit.note,
                    "rows": fit.rows,
                    "degrees_of_freedom": fit.degrees_of_freedom,
                    "rms": fit.rms,
                    "chi_square": finite(fit.chi_square),
                    "scale": finite(fit.scale()),
                    "leave_one_out": fit.leave_one_out,
                    "information": finite(fit.information),
                    "information_corrected": finite(fit.information_corrected),
                    "rank": fit.observability.rank,
                    "unidentifiable": fit.observability.unidentifiable,
                    "predicted": fit.predicted.as_ref().map(|p| json!({
                        "target": p.target, "points": p.points, "rms": p.rms, "max": p.max,
                    })),
                    "factors": fit.factors.iter().map(|f| json!({
                        "name": f.name,
                        "unit": f.unit.to_string(),
                        "nominal": f.nominal,
                        "estimate": f.estimate,
                        "sigma": finite(f.sigma),
                        "prior": f.prior,
                        "data_share": f.data_share(),
                    })).collect::<Vec<_>>(),
                    "effective_factors": fit.effective_factors,
                    "resting_on_prior": fit.resting_on_prior,
                })
            })
            .collect(),
    )
}
