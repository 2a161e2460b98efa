//! Range checks of numeric options, with legwise's own "expected … found …" messages.
//!
//! Numeric options are parsed by clap as signed numbers with negative values allowed, so that
//! `--grid -0.02` or `--poses-per-leg -1` reach these checks instead of clap's "unexpected
//! argument '-1'".

use anyhow::bail;

/// A count option within `min..=max`.
///
/// # Errors
/// The value is outside the range.
pub(super) fn count(flag: &str, value: i64, min: usize, max: usize) -> anyhow::Result<usize> {
    match usize::try_from(value) {
        Ok(n) if (min..=max).contains(&n) => Ok(n),
        _ => bail!("{flag}: expected between {min} and {max}, found {value}"),
    }
}

/// A length option that must be finite and positive, in metres.
///
/// # Errors
/// Zero, negative or non-finite.
pub(super) fn positive_metres(flag: &str, value: Option<f64>) -> anyhow::Result<Option<f64>> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => {
            bail!("{flag}: expected a positive number of metres, found {v}")
        }
        _ => Ok(value),
    }
}

/// A factor that must be finite and non-negative.
///
/// # Errors
/// Negative or non-finite.
pub(super) fn non_negative(flag: &str, value: f64) -> anyhow::Result<f64> {
    if !(value.is_finite() && value >= 0.0) {
        bail!("{flag}: expected a non-negative number, found {value}");
    }
    Ok(value)
}

/// `--png` asks for the pictures of `--plots DIR` as PNG: refused without `--plots`.
///
/// # Errors
/// `--png` without `--plots`.
pub(super) fn png_needs_plots(png: bool, plots: Option<&std::path::Path>) -> anyhow::Result<()> {
    if png && plots.is_none() {
        bail!("--png: draws the pictures of --plots DIR as PNG, but no --plots is given; add --plots DIR or drop --png");
    }
    Ok(())
}

/// A seed: an integer from 0 to 2⁶⁴ − 1.
///
/// # Errors
/// Negative or too large.
pub(super) fn seed(flag: &str, value: Option<i128>) -> anyhow::Result<Option<u64>> {
    let Some(v) = value else { return Ok(None) };
    match u64::try_from(v) {
        Ok(seed) => Ok(Some(seed)),
        Err(_) => bail!(
            "{flag}: expected an integer from 0 to {}, found {v}",
            u64::MAX
        ),
    }
}

/// `--poses-per-leg` within 1..=[`MAX_POSES_PER_LEG`](crate::model::mechanism::MAX_POSES_PER_LEG).
pub(super) fn poses_per_leg(value: Option<i64>) -> anyhow::Result<Option<usize>> {
    use crate::model::mechanism::MAX_POSES_PER_LEG;
    value
        .map(|n| count("--poses-per-leg", n, 1, MAX_POSES_PER_LEG))
        .transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_outside_the_range_name_the_flag_and_the_value() {
        assert_eq!(count("--n", 1, 1, 3).unwrap(), 1);
        assert_eq!(count("--n", 3, 1, 3).unwrap(), 3);
        for bad in [-1, 0, 4, i64::MIN] {
            assert_eq!(
                count("--n", bad, 1, 3).unwrap_err().to_string(),
                format!("--n: expected between 1 and 3, found {bad}")
            );
        }
    }

    #[test]
    fn lengths_must_be_positive_and_factors_non_negative() {
        assert_eq!(positive_metres("--g", Some(0.02)).unwrap(), Some(0.02));
        assert_eq!(positive_metres("--g", None).unwrap(), None);
        for bad in [0.0, -0.02, f64::NAN, f64::INFINITY] {
            assert!(positive_metres("--g", Some(bad)).is_err(), "{bad}");
        }
        assert!(non_negative("--s", 0.0).is_ok());
        assert_eq!(
            non_negative("--s", -1.0).unwrap_err().to_string(),
            "--s: expected a non-negative number, found -1"
        );
    }

    #[test]
    fn seeds_cover_the_u64_range_only() {
        assert_eq!(
            seed("--seed", Some(u64::MAX as i128)).unwrap(),
            Some(u64::MAX)
        );
        assert!(seed("--seed", Some(-1)).is_err());
        assert!(seed("--seed", Some(u64::MAX as i128 + 1)).is_err());
    }
}
