//! A test observer: what argmin hands an observer at each iteration (the cost and the solver's
//! key values), kept for the tests to check.

use std::cell::RefCell;
use std::rc::Rc;

use argmin::core::observers::Observe;
use argmin::core::{Error, State, KV};

/// The cost after each iteration and the key values the solver reported for it.
#[derive(Default)]
pub(crate) struct Iterations(pub(crate) Rc<RefCell<Vec<(f64, KV)>>>);

impl<I: State<Float = f64>> Observe<I> for Iterations {
    fn observe_iter(&mut self, state: &I, kv: &KV) -> Result<(), Error> {
        self.0.borrow_mut().push((state.get_cost(), kv.clone()));
        Ok(())
    }
}

/// The float value of `key` in `kv`.
pub(crate) fn float(kv: &KV, key: &str) -> f64 {
    kv.get(key)
        .and_then(|v| v.get_float())
        .unwrap_or_else(|| panic!("no float `{key}` in {kv:?}"))
}

/// The unsigned value of `key` in `kv`.
pub(crate) fn count(kv: &KV, key: &str) -> u64 {
    kv.get(key)
        .and_then(|v| v.get_uint())
        .unwrap_or_else(|| panic!("no count `{key}` in {kv:?}"))
}
