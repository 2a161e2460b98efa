//! The exchange's guard against round-off cycles: a design it has been at is never taken
//! again, whatever the engine proposes.

use super::*;
use crate::selection::driver::{run, Engine, Step};
use crate::selection::Pool;

/// An engine whose every proposal is a swap between candidates 0 and 1, the one in the design
/// for the other: what round-off can make of two equivalent candidates when each swap's
/// computed ratio lands above the acceptance (1 ± 1e-12 against 1 + ACCEPT).
struct SwapsBackAndForth {
    proposals: usize,
}

impl Engine for SwapsBackAndForth {
    fn name(&self) -> &'static str {
        "back and forth"
    }

    fn greedy_pick(
        &mut self,
        design: &[usize],
        eligible: &[bool],
    ) -> Result<usize, SelectionError> {
        // 0, 2, 3, …: candidate 1 stays out, for the swaps
        Ok((0..eligible.len())
            .find(|&j| j != 1 && eligible[j] && !design.contains(&j))
            .expect("an eligible candidate"))
    }

    fn best_swap(&mut self, step: &Step<'_>) -> Result<Option<(usize, usize)>, SelectionError> {
        self.proposals += 1;
        let (from, to) = match step.design.iter().position(|&j| j == 0) {
            Some(pos) => (pos, 1),
            None => (
                step.design.iter().position(|&j| j == 1).expect("0 or 1 in"),
                0,
            ),
        };
        Ok(Some((from, to)))
    }

    // No excursions: the driver's guard alone must end the exchange.
    fn best_addition(&mut self, _: (&Pool, Criterion), _: &[usize], _: &[bool]) -> Option<usize> {
        None
    }
}

#[test]
fn the_exchange_never_returns_to_a_design_it_has_left() {
    let candidates = random_pool(990, 12, 1, 3);
    let o = options(4);
    let pool = Pool::new(&candidates, &o).unwrap();
    let mut engine = SwapsBackAndForth { proposals: 0 };
    let selection = run(&pool, &o, &mut engine).unwrap();
    // Greedy 0, 2, 3, 4; 0 swapped for 1; swapping back would return to the greedy design:
    // refused, that sweep and the next (which then has no improvement), and no excursion.
    assert_eq!(selection.exchanges, 1, "{selection:?}");
    assert!(selection.sweeps < o.max_sweeps, "{selection:?}");
    assert!(engine.proposals <= 3, "{} proposals", engine.proposals);
}
