//! The constructor of a problem seen through the forward kinematics
//! (`instrument.kinematics: forward`): its forward rows (every row with target coordinates or
//! named by a distance), its distances, and the residual blocks of the rows' measured platform
//! poses (`instrument.poses`), before the forward rows' residuals.

use std::sync::Arc;

use super::forward_rows::{Forward, ForwardDistance, ForwardRow};
use super::sighted::Sighted;
use super::IdentificationProblem;
use crate::error::{Error, Result};
use crate::identify::residual::ResidualBlock;
use crate::kinematics::kernel::LegKernel;
use crate::measure::observations::{instrument_of, Observations};
use crate::model::Mechanism;

impl<'a> IdentificationProblem<'a> {
    /// The problem of forward rows: every row's readings of all legs predict what the
    /// instrument saw (`problem/forward.rs`); the unknowns as [`Self::through_instrument`].
    pub(super) fn forward(
        mechanism: &'a Mechanism,
        observations: &Observations,
        legs: &[usize],
    ) -> Result<Self> {
        let instrument = instrument_of(mechanism)?;
        observations.check_distances()?;
        // The rows the forward kinematics closes: those with target coordinates, and those a
        // distance names (a row of a measured pose alone is not closed).
        let named = |source: usize| {
            let mut pairs = observations.distances.iter().flat_map(|d| d.rows);
            pairs.any(|r| r == source)
        };
        let closed: Vec<usize> = (0..observations.rows.len())
            .filter(|&i| !observations.rows[i].observed.is_empty() || named(i))
            .collect();
        // Each measured pose's legs with a reading (and a slot): ordinary residual blocks.
        let (mut blocks, mut block_sources) = (Vec::new(), Vec::new());
        for (source, row) in observations.rows.iter().enumerate() {
            let Some(pose) = row.pose else { continue };
            for (leg, reading) in row.readings.iter().enumerate() {
                if let (Some(reading), true) = (reading, legs.contains(&leg)) {
                    blocks.push(ResidualBlock {
                        leg,
                        pose,
                        reading: *reading,
                        line: row.line,
                    });
                    block_sources.push(source);
                }
            }
        }
        let rows = closed
            .iter()
            .map(|&source| {
                let row = &observations.rows[source];
                let readings = row.readings.iter().enumerate().map(|(l, r)| {
                    r.ok_or_else(|| {
                        let at = row
                            .line
                            .map_or(format!("row {source}"), |l| format!("line {l}"));
                        Error::Invalid(format!(
                            "{at}: no reading of leg `{}`: the forward kinematics needs every \
                             leg's reading at every row",
                            mechanism.legs[l].name
                        ))
                    })
                });
                let coordinates = instrument.observed_len();
                let observed = row.observed.len();
                if row.readings.len() != mechanism.legs.len()
                    || (observed != 0 && observed != coordinates)
                {
                    return Err(Error::Invalid(format!(
                        "row {source}: {} readings for the {} legs and {observed} target \
                         coordinates (expected {coordinates}, or none for a row only distances \
                         use)",
                        row.readings.len(),
                        mechanism.legs.len()
                    )));
                }
                Ok(ForwardRow {
                    source,
                    line: row.line,
                    readings: readings.collect::<Result<_>>()?,
                    observed: row.observed.clone(),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let sighted = Sighted {
            instrument,
            shared: instrument.identified(),
            held: instrument.nominal(),
            rows: Arc::new(Vec::new()),
        };
        let rows_count = observations.rows.len();
        let forward_row = |r: usize| closed.binary_search(&r).unwrap_or_default();
        let distances = observations
            .distances
            .iter()
            .enumerate()
            .map(|(k, d)| ForwardDistance {
                source: rows_count + k,
                rows: d.rows.map(forward_row),
                value: d.value,
                line: d.line,
            })
            .collect();
        let mut problem = Self::assemble(mechanism, legs, blocks, Some(sighted));
        let kernels = mechanism.legs.iter().map(LegKernel::recognise).collect();
        problem.forward = Some(Forward::new(rows, distances, block_sources, kernels));
        Ok(problem)
    }
}
