//! What to do next, from a fit's own numbers on real data (no truth to compare with): whether
//! the residual agrees with the declared noise, how well left-out rows are predicted, whether
//! the predicted σ over the workspace is within the model's tolerance, which sets the rows
//! cannot determine and which carry factors the data do not support. Each sentence states the
//! figure it rests on; nothing is specific to one mechanism.

use crate::identify::factor_set::FactorSetFit;

/// Residual scale (in declared σ) above which the data do not agree with the declared noise.
pub const NOISIER: f64 = 2.0;

/// Residual scale below which the declared noise looks pessimistic (with enough rows).
pub const QUIETER: f64 = 0.5;

/// Degrees of freedom below which the scale says little about the noise.
pub const FEW_DOF: usize = 5;

/// The left-out error over the residual beyond which the fit follows its rows more than it
/// predicts others.
pub const OVERFIT: f64 = 3.0;

/// Sentences on `fits` (the model's own set first, then the other sets, all on the same rows).
pub fn next_steps(fits: &[FactorSetFit]) -> Vec<String> {
    let Some(own) = fits.first() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let k = own.observability.rank;
    let dof = own.degrees_of_freedom;
    let scale = own.scale();
    if dof == 0 {
        out.push(format!(
            "`{}` has as many factors as rows: its residual cannot say whether the data agree \
             with the declared noise. Measure more rows (`legwise select` places them).",
            own.name
        ));
    } else if scale.is_finite() && scale > NOISIER {
        out.push(format!(
            "The residual (RMS {:.3e}) is {scale:.1} times the declared σ: either the \
             measurements are noisier than declared (measure the instrument's repeatability and \
             declare it) or the model misses an error its factors cannot express. More rows tell \
             the two apart: noise averages out, a model error does not.",
            own.rms
        ));
    } else if scale.is_finite() && scale < QUIETER && dof >= FEW_DOF {
        out.push(format!(
            "The residual is {scale:.2} times the declared σ: the declared noise looks \
             pessimistic, and the σ and predicted σ with it."
        ));
    } else if scale.is_finite() {
        out.push(format!(
            "The residual agrees with the declared noise ({scale:.2} times σ on {dof} degree(s) \
             of freedom)."
        ));
    }
    if let Some(left_out) = own.leave_one_out {
        if dof < k || left_out > OVERFIT * own.rms {
            out.push(format!(
                "Only {dof} row(s) beyond the {k} factors: a row left out of the fit is \
                 predicted to {left_out:.3e} RMS, {:.1} times the residual. The residual is no \
                 measure of accuracy here; more rows, placed by `legwise select`, bring the two \
                 together.",
                left_out / own.rms
            ));
        }
    }
    if let Some(p) = &own.predicted {
        match p.tolerance {
            Some(t) if p.max > t => out.push(format!(
                "The predicted σ of `{}` over the workspace reaches {:.3e} (RMS {:.3e}), above \
                 the model's tolerance {t:.3e}: measure more rows where `legwise select` puts \
                 them, or rows of another kind (distances, measured positions) that see what \
                 these cannot.",
                p.target, p.max, p.rms
            )),
            Some(t) => out.push(format!(
                "The predicted σ of `{}` over the workspace is within the model's tolerance \
                 {t:.3e} (max {:.3e}).",
                p.target, p.max
            )),
            None => {}
        }
    }
    for fit in fits.iter().skip(1) {
        if fit.observability.rank < fit.factors.len() {
            out.push(format!(
                "`{}` cannot be determined by these rows (they cannot see {}): hold those \
                 factors, or add rows that see them.",
                fit.name,
                fit.observability.unidentifiable.join(", ")
            ));
        }
    }
    let determined: Vec<&FactorSetFit> = fits
        .iter()
        .filter(|f| f.observability.rank == f.factors.len() && f.leave_one_out.is_some())
        .collect();
    let best = determined.iter().min_by(|a, b| {
        a.leave_one_out
            .partial_cmp(&b.leave_one_out)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    if let (Some(best), true) = (best, determined.len() > 1) {
        let worse: Vec<String> = determined
            .iter()
            .filter(|f| f.factors.len() > best.factors.len())
            .map(|f| {
                format!(
                    "`{}` ({} factors, {:.3e})",
                    f.name,
                    f.factors.len(),
                    f.leave_one_out.unwrap_or(f64::NAN)
                )
            })
            .collect();
        let best_error = best.leave_one_out.unwrap_or(f64::NAN);
        // Sets predicting as well (the same directions in other coordinates) are named with it.
        let equal: Vec<String> = determined
            .iter()
            .filter(|f| f.name != best.name)
            .filter(|f| {
                f.leave_one_out
                    .is_some_and(|e| (e - best_error).abs() <= 1e-6 * best_error)
            })
            .map(|f| format!("`{}`", f.name))
            .collect();
        let also = match equal.is_empty() {
            true => String::new(),
            false => format!(" (as well: {})", equal.join(", ")),
        };
        let mut sentence = format!(
            "Of the sets the rows determine, `{}` predicts left-out rows best ({best_error:.3e} \
             RMS){also}.",
            best.name
        );
        if !worse.is_empty() {
            sentence.push_str(&format!(
                " More factors predict them worse: {}; the rows do not support the extra \
                 factors.",
                worse.join(", ")
            ));
        }
        out.push(sentence);
    }
    out
}

/// The sentences as a paragraph under `What next:`, wrapped to 96 columns, each a bullet.
pub fn next_steps_text(sentences: &[String]) -> String {
    if sentences.is_empty() {
        return String::new();
    }
    let options = textwrap::Options::new(96)
        .initial_indent("  * ")
        .subsequent_indent("    ");
    let mut out = String::from("\nWhat next:\n");
    for sentence in sentences {
        out.push_str(&textwrap::fill(sentence, &options));
        out.push('\n');
    }
    out
}
