//! Which factor set to fit, from the rows alone: the smallest corrected Akaike criterion
//! (AICc, [`super::factor_set::FactorSetFit::information_corrected`]) among the sets the rows
//! determine whose predicted σ over the workspace is within the model's tolerance (all the
//! determined ones when none is, or the model declares no tolerance), the fewer factors among
//! equal scores; when the rows are too few to score any set (AICc infinite), the determined set
//! with the fewest factors. A set the identification itself would flag (exit 3: its predicted σ above the
//! tolerance) is not recommended beside one it would not. Checked on simulated printers by `legwise
//! printer study --sets` (docs/printers.md §10): the leave-one-out error and the plain AIC
//! recommend sets with freed tilts or rods on heights alone, whose print errors are several
//! times the six factors'; the correction for few rows does not.

use super::factor_set::FactorSetFit;

/// Relative difference of two scores under which the sets are equal (the same directions in
/// other coordinates score the same to round-off).
pub const SAME_SCORE: f64 = 1e-9;

/// One candidate: whether the rows determine it, its AICc, its number of factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Every factor determined by the rows.
    pub determined: bool,
    /// Its AICc (finite to be recommended).
    pub score: f64,
    /// Its factors.
    pub factors: usize,
    /// Its predicted σ over the workspace is within the model's tolerance (true without a
    /// tolerance or a prediction).
    pub within_tolerance: bool,
}

impl Candidate {
    /// A fitted set as a candidate.
    pub fn of(fit: &FactorSetFit) -> Self {
        Self {
            determined: fit.observability.rank == fit.factors.len(),
            score: fit.information_corrected,
            factors: fit.factors.len(),
            within_tolerance: within_tolerance(fit),
        }
    }
}

/// Whether the set's predicted σ over the workspace is within the model's tolerance (true
/// without either).
pub fn within_tolerance(fit: &FactorSetFit) -> bool {
    fit.predicted
        .as_ref()
        .is_none_or(|p| p.tolerance.is_none_or(|t| p.max <= t))
}

/// The index of the recommended candidate; `None` when none is determined. When the rows are
/// too few to score any determined set (every AICc infinite), the one with the fewest factors.
pub fn recommended(candidates: &[Candidate]) -> Option<usize> {
    let determined = (0..candidates.len()).filter(|&k| candidates[k].determined);
    let mut scored: Vec<usize> = determined
        .clone()
        .filter(|&k| candidates[k].score.is_finite())
        .collect();
    if scored.is_empty() {
        // Too few rows to judge any set (AICc infinite everywhere): the determined set with
        // the fewest factors, within the tolerance if one is.
        scored = determined.collect();
        let within = scored
            .iter()
            .copied()
            .filter(|&k| candidates[k].within_tolerance);
        let within: Vec<usize> = within.collect();
        let eligible = if within.is_empty() { scored } else { within };
        return eligible.into_iter().min_by_key(|&k| candidates[k].factors);
    }
    let within: Vec<usize> = scored
        .iter()
        .copied()
        .filter(|&k| candidates[k].within_tolerance)
        .collect();
    let eligible = if within.is_empty() { scored } else { within };
    let best = eligible
        .iter()
        .map(|&k| candidates[k].score)
        .fold(f64::INFINITY, f64::min);
    let tolerance = SAME_SCORE * best.abs().max(1.0);
    eligible
        .into_iter()
        .filter(|&k| candidates[k].score <= best + tolerance)
        .min_by_key(|&k| candidates[k].factors)
}

#[cfg(test)]
mod tests {
    use super::{recommended, Candidate};

    fn candidate(score: f64, factors: usize) -> Candidate {
        Candidate {
            determined: score.is_finite(),
            score,
            factors,
            within_tolerance: true,
        }
    }

    #[test]
    fn the_lowest_score_wins_and_fewer_factors_break_ties() {
        let sets = [
            candidate(20.0, 6),
            candidate(19.0, 9),
            candidate(f64::INFINITY, 4),
        ];
        assert_eq!(recommended(&sets), Some(1));
        let sets = [candidate(20.0, 9), candidate(20.0 + 1e-12, 6)];
        assert_eq!(
            recommended(&sets),
            Some(1),
            "a tie goes to the fewer factors"
        );
        // Equal to 1e-9 of the score, not of 1: large scores tie at their round-off.
        let sets = [candidate(1000.0, 9), candidate(1000.0 + 1e-7, 6)];
        assert_eq!(recommended(&sets), Some(1));
        let sets = [candidate(1000.0, 9), candidate(1000.0 + 1e-5, 6)];
        assert_eq!(
            recommended(&sets),
            Some(0),
            "1e-8 of the score is a real difference"
        );
        let sets = [candidate(20.0, 6), candidate(20.0, 6)];
        assert_eq!(
            recommended(&sets),
            Some(0),
            "then to the first (the model's own)"
        );
        let blind = Candidate {
            determined: false,
            score: 1.0,
            factors: 3,
            within_tolerance: true,
        };
        assert_eq!(recommended(&[blind]), None);
        // Rows too few to score any set: the fewest factors among the determined ones.
        let unscored = |factors: usize| Candidate {
            determined: true,
            ..candidate(f64::INFINITY, factors)
        };
        let sets = [unscored(6), unscored(4), blind, unscored(9)];
        assert_eq!(recommended(&sets), Some(1));
    }

    /// A set whose predicted σ exceeds the model's tolerance is passed over for one within it,
    /// whatever its score; when none is within, the lowest score among them all.
    #[test]
    fn a_set_beyond_the_tolerance_gives_way_to_one_within_it() {
        let beyond = Candidate {
            within_tolerance: false,
            ..candidate(10.0, 9)
        };
        assert_eq!(recommended(&[candidate(20.0, 6), beyond]), Some(0));
        let also_beyond = Candidate {
            within_tolerance: false,
            ..candidate(20.0, 6)
        };
        assert_eq!(recommended(&[also_beyond, beyond]), Some(1));
        let blind_within = Candidate {
            determined: false,
            ..candidate(5.0, 3)
        };
        assert_eq!(recommended(&[blind_within, beyond]), Some(1));
    }
}
