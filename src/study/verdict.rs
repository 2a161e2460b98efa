//! The sentence a Monte Carlo study's paired comparison supports, and the millimetres it is
//! written in.

use super::arm::Arm;
use super::stats::Estimate;

/// The sentence a paired difference `first − second` (metres, RMS position error over the
/// map) supports: which arm is more accurate and by how much, or no significant difference.
pub fn verdict_sentence(
    first: Arm,
    second: Arm,
    equal_poses: bool,
    difference: &Estimate,
) -> String {
    let mm = difference.scaled(1e3);
    let second_name = if equal_poses {
        "traditional at an equal number of poses".to_string()
    } else {
        second.name().to_string()
    };
    let tail = "of RMS position error over the map (mean paired difference, 95 % CI)";
    if mm.below_zero() {
        format!(
            "{} is more accurate than {second_name} by {} mm [{}, {}] {tail}.",
            first.name(),
            millimetres(-mm.value),
            millimetres(-mm.high),
            millimetres(-mm.low)
        )
    } else if mm.above_zero() {
        format!(
            "{} is more accurate than {} by {} mm [{}, {}] {tail}.",
            capitalised(&second_name),
            first.name(),
            millimetres(mm.value),
            millimetres(mm.low),
            millimetres(mm.high)
        )
    } else {
        format!(
            "No significant difference between {} and {second_name}: the mean paired difference \
             ({} − {}) of RMS position error over the map is {} mm [{}, {}] (95 % CI).",
            first.name(),
            first.name(),
            second.name(),
            millimetres(mm.value),
            millimetres(mm.low),
            millimetres(mm.high),
        )
    }
}

/// `text` with its first letter in upper case.
fn capitalised(text: &str) -> String {
    let mut chars = text.chars();
    chars
        .next()
        .map_or_else(String::new, |c| c.to_uppercase().chain(chars).collect())
}

/// Millimetres with four significant digits (`0.01234`, `1.234`; `1.234e-7` below a
/// micrometre's thousandth).
pub fn millimetres(value: f64) -> String {
    if value == 0.0 || !value.is_finite() {
        return format!("{value}");
    }
    let magnitude = value.abs().log10().floor() as i32;
    if magnitude < -6 {
        return format!("{value:.3e}");
    }
    let decimals = (3 - magnitude).max(0) as usize;
    format!("{value:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::arm::INSTRUMENT_ARMS;

    fn interval(value: f64, low: f64, high: f64) -> Estimate {
        Estimate { value, low, high }
    }

    #[test]
    fn the_sentence_follows_the_sign_of_the_interval() {
        let (dc, equal) = (Arm::DivideAndConquer, Arm::TraditionalEqualPoses);
        let better = verdict_sentence(dc, equal, true, &interval(-2e-5, -3e-5, -1e-5));
        assert!(
            better.starts_with("D&C is more accurate than traditional at an equal number of poses by 0.02000 mm [0.01000, 0.03000]"),
            "{better}"
        );
        let worse = verdict_sentence(dc, equal, true, &interval(2e-5, 1e-5, 3e-5));
        assert!(
            worse.starts_with("Traditional at an equal number of poses is more accurate than D&C by 0.02000 mm [0.01000, 0.03000]"),
            "{worse}"
        );
        let neither = verdict_sentence(dc, Arm::Traditional, false, &interval(1e-6, -1e-5, 1.2e-5));
        assert!(
            neither.starts_with("No significant difference between D&C and traditional:"),
            "{neither}"
        );
        assert!(
            neither.contains("0.001000 mm [-0.01000, 0.01200]"),
            "{neither}"
        );
    }

    #[test]
    fn the_instrument_arms_are_named_in_the_sentence() {
        let (joint, two_stage) = (Arm::Joint, Arm::TwoStage);
        let better = verdict_sentence(joint, two_stage, false, &interval(-2e-3, -3e-3, -1e-3));
        assert!(
            better.starts_with("joint is more accurate than two-stage by 2.000 mm [1.000, 3.000]"),
            "{better}"
        );
        let worse = verdict_sentence(joint, two_stage, false, &interval(2e-3, 1e-3, 3e-3));
        assert!(
            worse.starts_with("Two-stage is more accurate than joint by 2.000 mm"),
            "{worse}"
        );
        assert_eq!(INSTRUMENT_ARMS.map(Arm::key), ["joint", "two_stage"]);
    }
}
