//! A test of the instrument frame's held components: are the values the model holds them at
//! consistent with the measurements?
//!
//! A frame component held at a wrong value is mostly absorbed by the legs' free parameters, and
//! only what they cannot take shows in the residuals; the χ² goodness-of-fit test spreads that
//! rest over all its degrees of freedom and rarely sees it. The likelihood-ratio test
//! concentrates it: identify again with the held frame components freed (when that problem is
//! still full rank) and compare the two fits' χ² against the declared noise. Under a correct
//! held value the drop `χ²_held − χ²_freed` follows a χ² law with as many degrees of freedom as
//! components freed; a drop in its upper tail (p below
//! [`NOISE_TEST_P`](super::statistics::NOISE_TEST_P)) says the held values are wrong
//! (docs/models.md §9.2).

use statrs::distribution::{ChiSquared, ContinuousCDF};

pub use super::result::HeldFrameTest;
use super::result::{Strategy, StrategyResult};
use super::shared_estimate::identify_shared;
use super::statistics::rejects;
use crate::measure::observations::Observations;
use crate::model::Mechanism;

/// The held-frame test of the joint estimate `held` (made with `mechanism` as written), or
/// `None` when there is nothing to test: no held frame component, no declared noise (no χ²),
/// or a freed problem that is rank-deficient (the held components then define the base frame,
/// and no measurement can tell their value) or that cannot be solved.
pub fn held_frame_test(
    mechanism: &Mechanism,
    observations: &Observations,
    held: &StrategyResult,
) -> Option<HeldFrameTest> {
    let held_chi_squared = held.instrument.as_ref()?.noise_test.as_ref()?.chi_squared;
    let instrument = mechanism.instrument.as_ref()?;
    let freed: Vec<usize> = (0..instrument.parameters.len())
        .filter(|&k| {
            let p = &instrument.parameters[k];
            !p.identified && p.name.starts_with("frame_")
        })
        .collect();
    if freed.is_empty() {
        return None;
    }
    let free = mechanism.edited(|parts| {
        if let Some(instrument) = parts.instrument.as_mut() {
            for &k in &freed {
                instrument.parameters[k].identified = true;
            }
        }
    });
    let refit = identify_shared(&free, observations, Strategy::Joint, held.options).ok()?;
    let refit = refit.instrument?;
    let drop = held_chi_squared - refit.noise_test.as_ref()?.chi_squared;
    let p_value = ChiSquared::new(freed.len() as f64).ok()?.sf(drop.max(0.0));
    Some(HeldFrameTest {
        freed: freed
            .iter()
            .map(|&k| instrument.parameters[k].name.clone())
            .collect(),
        chi_squared_drop: drop,
        degrees_of_freedom: freed.len(),
        p_value,
        rejected: rejects(p_value),
        estimates: freed
            .iter()
            .map(|&k| refit.parameters[k].estimate)
            .collect(),
    })
}
