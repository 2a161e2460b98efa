//! What to do next, from a fit's own numbers on real data (no truth to compare with): whether
//! the residual agrees with the declared noise, how well left-out rows are predicted, whether
//! the predicted σ over the workspace is within the model's tolerance, which sets the rows
//! cannot determine and which carry factors the data do not support. Each sentence states the
//! figure it rests on; nothing is specific to one mechanism.

use crate::identify::factor_set::FactorSetFit;
use crate::identify::set_choice::{recommended, Candidate};

/// A criterion to one decimal, `inf` when the rows are too few to judge the set.
fn score_text(score: f64) -> String {
    match score.is_finite() {
        true => format!("{score:.1}"),
        false => "inf".to_string(),
    }
}

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
            // With priors the rows carry fewer factors than the set frees.
            let factors = if own.effective_factors < k as f64 - 0.05 {
                format!(
                    "{:.1} factors the rows carry (of {k}, the rest resting on their priors)",
                    own.effective_factors
                )
            } else {
                format!("{k} factors")
            };
            out.push(format!(
                "Only {dof} row(s) beyond the {factors}: a row left out of the fit is \
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
    let candidates: Vec<Candidate> = fits.iter().map(Candidate::of).collect();
    if let (Some(best), true) = (recommended(&candidates), fits.len() > 1) {
        let score = candidates[best].score;
        let equal: Vec<String> = (0..fits.len())
            .filter(|&k| k != best && candidates[k].determined)
            .filter(|&k| (candidates[k].score - score).abs() <= 1e-9 * score.abs().max(1.0))
            .map(|k| format!("`{}`", fits[k].name))
            .collect();
        let also = match equal.is_empty() {
            true => String::new(),
            false => format!(" (as well: {})", equal.join(", ")),
        };
        let mut sentence = match score.is_finite() {
            true => format!(
                "Recommended: `{}`, the lowest AICc of the sets the rows determine ({score:.1}){also}.",
                fits[best].name
            ),
            false => format!(
                "Recommended: `{}`, the determined set with the fewest factors: each set the rows \
                 determine leaves at most one row beyond its factors (its AICc is infinite); more \
                 rows let the rows choose.",
                fits[best].name
            ),
        };
        let beyond: Vec<String> = (0..fits.len())
            .filter(|&k| candidates[k].determined && !candidates[k].within_tolerance)
            .filter(|&k| candidates[k].score < score)
            .map(|k| format!("`{}`", fits[k].name))
            .collect();
        if !beyond.is_empty() {
            sentence.push_str(&format!(
                " {} scores lower, but its predicted σ over the workspace is above the model's \
                 tolerance.",
                beyond.join(", ")
            ));
        }
        let worse: Vec<String> = (0..fits.len())
            .filter(|&k| {
                candidates[k].determined && candidates[k].factors > candidates[best].factors
            })
            .filter(|&k| candidates[k].score > score + 1e-9 * score.abs().max(1.0))
            .map(|k| format!("`{}` ({})", fits[k].name, score_text(candidates[k].score)))
            .collect();
        if !worse.is_empty() {
            sentence.push_str(&format!(
                " More factors score worse: {}; these rows do not support the extra factors.",
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
        .subsequent_indent("    ")
        .word_splitter(textwrap::WordSplitter::NoHyphenation);
    let mut out = String::from("\nWhat next:\n");
    for sentence in sentences {
        out.push_str(&textwrap::fill(sentence, &options));
        out.push('\n');
    }
    out
}
