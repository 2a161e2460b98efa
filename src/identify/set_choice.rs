//! Which factor set to fit, from the rows alone: the smallest corrected Akaike criterion
//! (AICc, [`super::factor_set::FactorSetFit::information_corrected`]) among the sets the rows
//! determine, the fewer factors among equal scores. Checked on simulated printers by `legwise
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
}

impl Candidate {
    /// A fitted set as a candidate.
    pub fn of(fit: &FactorSetFit) -> Self {
        Self {
            determined: fit.observability.rank == fit.factors.len(),
            score: fit.information_corrected,
            factors: fit.factors.len(),
        }
    }
}

/// The index of the recommended candidate; `None` when none is determined with a finite score.
pub fn recommended(candidates: &[Candidate]) -> Option<usize> {
    let eligible: Vec<usize> = (0..candidates.len())
        .filter(|&k| candidates[k].determined && candidates[k].score.is_finite())
        .collect();
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
        };
        assert_eq!(recommended(&[blind, candidate(f64::INFINITY, 2)]), None);
    }
}
