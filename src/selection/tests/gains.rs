//! The gains shared by the engines: D gains from M⁻¹ against re-evaluated determinants, the
//! tie rules of `argmax` and of the chunked best-swap scan.

// The best-swap values are the offered ones, compared exactly.
#![allow(clippy::float_cmp)]

use super::*;
use crate::selection::gains::{addition, gram_value, removal, BestSwap};
use crate::selection::pool::argmax;
use crate::selection::Pool;

/// ln det of the information matrix of `design` (no ridge), from scratch.
fn ln_det_of(pool: &Pool, design: &[usize]) -> f64 {
    gram_value(&pool.gram(design, false), Criterion::D)
}

/// The first index of the largest value, written out (the reference for `argmax`'s users).
fn best_trial(values: impl Iterator<Item = (usize, f64)>) -> usize {
    let mut best = (usize::MAX, f64::NEG_INFINITY);
    for (index, value) in values {
        if value > best.1 {
            best = (index, value);
        }
    }
    best.0
}

/// The D step up and down (determinant lemma on M⁻¹) pick what re-evaluating every trial
/// determinant picks, for single rows and for blocks of two and three rows; the A and E steps
/// pick the best re-evaluated trial of their own criterion.
#[test]
fn additions_and_removals_are_the_best_trial_designs() {
    for (seed, b) in [(0, 1), (1, 2), (2, 3)] {
        let candidates = random_pool(900 + seed, 30, b, 6);
        let pool = Pool::new(&candidates, &options(8)).unwrap();
        let design: Vec<usize> = (0..8).collect();
        let eligible: Vec<bool> = (0..pool.k).map(|j| j >= 8).collect();
        let order: Vec<usize> = (0..8).collect();
        for criterion in [Criterion::D, Criterion::A, Criterion::E] {
            let value = |design: &[usize]| gram_value(&pool.gram(design, false), criterion);
            let best_addition = best_trial((8..pool.k).map(|j| {
                let mut trial = design.clone();
                trial.push(j);
                (j, value(&trial))
            }));
            let added = addition(&pool, &design, &eligible, criterion).unwrap();
            assert_eq!(added, best_addition, "b = {b}, {criterion:?} addition");
            let best_removal = best_trial(order.iter().map(|&pos| {
                let mut trial = design.clone();
                trial.remove(pos);
                (pos, value(&trial))
            }));
            let removed = removal(&pool, &design, &order, criterion).unwrap();
            assert_eq!(removed, best_removal, "b = {b}, {criterion:?} removal");
        }
        // The chosen D addition gains what the determinants say (not just the same index).
        let added = addition(&pool, &design, &eligible, Criterion::D).unwrap();
        let mut trial = design.clone();
        trial.push(added);
        assert!(ln_det_of(&pool, &trial) > ln_det_of(&pool, &design));
    }
}

/// Without a nonsingular design there is no D gain: no addition or removal is proposed.
#[test]
fn a_singular_design_has_no_d_step() {
    let candidates = random_pool(910, 20, 1, 4);
    let pool = Pool::new(&candidates, &options(6)).unwrap();
    let design = [0, 1, 2];
    let eligible: Vec<bool> = (0..pool.k).map(|j| j >= 3).collect();
    assert_eq!(addition(&pool, &design, &eligible, Criterion::D), None);
    assert_eq!(removal(&pool, &design, &[0, 1, 2], Criterion::D), None);
}

#[test]
fn argmax_takes_the_first_of_the_largest_scores() {
    assert_eq!(
        argmax([(3, 1.0), (5, 2.0), (7, 2.0), (9, -1.0)].into_iter()),
        Some(5)
    );
    assert_eq!(
        argmax([(4, f64::NEG_INFINITY), (6, f64::NEG_INFINITY)].into_iter()),
        Some(4)
    );
    assert_eq!(argmax(std::iter::empty()), None);
}

/// A scan split into chunks offers swaps out of the unsplit order: a tie goes to the earlier
/// position rank, then the lower candidate index, whatever the order of the offers; a swap
/// must beat the threshold strictly, and NaN never wins.
#[test]
fn the_best_swap_breaks_ties_in_the_unsplit_scan_order() {
    let mut best = BestSwap::above(1.0);
    best.offer(1.0, 0, (0, 0));
    best.offer(f64::NAN, 0, (0, 1));
    assert_eq!(best.swap(), None);
    assert_eq!(best.value(), 1.0);
    best.offer(2.0, 3, (4, 10));
    best.offer(2.0, 3, (4, 12));
    assert_eq!(best.swap(), Some((4, 10)));
    best.offer(2.0, 3, (4, 7));
    assert_eq!(best.swap(), Some((4, 7)));
    best.offer(2.0, 1, (2, 20));
    assert_eq!(best.swap(), Some((2, 20)));
    best.offer(f64::NAN, 0, (0, 0));
    best.offer(1.5, 0, (0, 0));
    assert_eq!(best.swap(), Some((2, 20)));
    best.offer(2.5, 9, (9, 30));
    assert_eq!((best.swap(), best.value()), (Some((9, 30)), 2.5));
}
