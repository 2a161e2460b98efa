//! The observations of a model with an `instrument` block as data ([`super::observations`]
//! reads and writes them): the rows, the distance rows, and the columns a file of them has.

use std::collections::HashMap;
use std::path::PathBuf;

use super::rows;
use crate::error::{Error, Result};
use crate::model::instrument::Instrument;
use crate::model::Mechanism;

/// One row: the targets as the instrument reports them, and the readings taken there.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservedRow {
    /// Line in the source file (1-based, the header is line 1), if read from a file.
    pub line: Option<usize>,
    /// The leg whose identification set the row belongs to; `None` for a row shared by all.
    pub leg: Option<usize>,
    /// Every target's coordinates in the instrument frame, in column order (metres, radians).
    pub observed: Vec<f64>,
    /// Raw reading of each leg's actuated joint, `None` when not read.
    pub readings: Vec<Option<f64>>,
    /// The row's label in the `id` column (forward models), which distances name.
    pub id: Option<String>,
    /// The platform pose measured at the row in the base frame `[x, y, z, roll, pitch, yaw]`
    /// (the coordinates the model does not measure at home), if the model's `instrument.poses`
    /// lets rows carry one: each leg's reading is then predicted from it too.
    pub pose: Option<[f64; 6]>,
}

/// A measured distance between one target's positions at two rows (forward models: the
/// model's `instrument.distances`).
#[derive(Debug, Clone, PartialEq)]
pub struct DistanceRow {
    /// Line in the source file, if read from one.
    pub line: Option<usize>,
    /// The two rows (indices into [`Observations::rows`]).
    pub rows: [usize; 2],
    /// The measured distance, metres.
    pub value: f64,
}

/// A set of instrument measurements.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Observations {
    /// The file the measurements came from, if any.
    pub source: Option<PathBuf>,
    /// The rows, in file order.
    pub rows: Vec<ObservedRow>,
    /// Measured distances between rows, in file order (forward models).
    pub distances: Vec<DistanceRow>,
}

impl Observations {
    /// Checks every distance row: it joins two different rows of these observations and
    /// measures a finite length, and no two join the same rows (either way round) (the reader
    /// checks a file's; observations made in memory are checked here before use).
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the first bad distance (its line, or its index) and what it
    /// holds.
    pub fn check_distances(&self) -> Result<()> {
        let count = self.rows.len();
        for (k, d) in self.distances.iter().enumerate() {
            let [a, b] = d.rows;
            if a >= count || b >= count || a == b || !d.value.is_finite() {
                let at = d
                    .line
                    .map_or(format!("distance {k}"), |l| format!("line {l}"));
                return Err(Error::Invalid(format!(
                    "{at}: a distance joins two different rows of the {count} and measures a \
                     finite length; found rows {a} and {b}, {} m",
                    d.value
                )));
            }
        }
        if let Some((k, first)) = repeated_pair(&self.distances) {
            let [a, b] = self.distances[k].rows;
            return Err(Error::Invalid(format!(
                "distance {k}: joins rows {a} and {b}, as distance {first} does: a distance \
                 given twice counts one measurement twice; keep one of them"
            )));
        }
        Ok(())
    }

    /// The rows of leg `leg` with its reading: the rows labelled with the leg, or, if no row
    /// is, the shared rows where its reading is present (as [`super::MeasurementSet::leg_blocks`]).
    /// Each item is the row's index in [`Self::rows`] (the rows of several legs with the same
    /// index are the same measurement: a shared row), the row and the reading.
    pub fn indexed_leg_rows(&self, leg: usize) -> Vec<(usize, &ObservedRow, f64)> {
        // The label of the leg's rows: the leg, or none (the shared rows).
        let label = self.rows.iter().any(|r| r.leg == Some(leg)).then_some(leg);
        self.rows
            .iter()
            .enumerate()
            .filter(|(_, r)| r.leg == label)
            .filter_map(|(i, r)| r.readings[leg].map(|reading| (i, r, reading)))
            .collect()
    }
}

/// The instrument of `mechanism`, or an error naming the model file.
///
/// # Errors
/// [`Error::Model`] if the model has no `instrument` block.
pub fn instrument_of(mechanism: &Mechanism) -> Result<&Instrument> {
    mechanism.instrument.as_ref().ok_or_else(|| Error::Model {
        path: mechanism.model_path.clone(),
        field: "instrument".into(),
        message: "missing: target measurements need an instrument block".into(),
    })
}

/// The optional columns of the commanded platform pose (`pose.x, pose.y, …`), ignored on
/// reading.
pub(super) fn commanded_columns(mechanism: &Mechanism) -> Vec<String> {
    mechanism
        .measured_names()
        .iter()
        .map(|c| format!("pose.{c}"))
        .collect()
}

/// The optional columns of a forward model: the rows' `id`, with distances the distance
/// rows' `from`, `to` and `distance`, and with measured poses the model's pose coordinates.
pub(super) fn forward_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    let mut columns = Vec::new();
    if instrument.forward {
        columns.push("id".to_string());
    }
    if instrument.distances.is_some() {
        columns.extend(["from", "to", "distance"].map(String::from));
    }
    columns.extend(measured_pose_columns(mechanism, instrument));
    columns
}

/// The columns of a row's measured platform pose (the model's coordinates, unprefixed), with
/// `instrument.poses`; none without.
pub(super) fn measured_pose_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    match instrument.poses {
        Some(_) => mechanism
            .measured_names()
            .iter()
            .map(|c| c.to_string())
            .collect(),
        None => Vec::new(),
    }
}

pub(super) fn expected_columns(mechanism: &Mechanism, instrument: &Instrument) -> Vec<String> {
    rows::columns(mechanism, instrument.columns())
}

/// The first distance (its index) that joins the same two rows as an earlier one (the earlier
/// one's index), either way round.
pub(super) fn repeated_pair(distances: &[DistanceRow]) -> Option<(usize, usize)> {
    let mut seen: HashMap<[usize; 2], usize> = HashMap::with_capacity(distances.len());
    for (k, d) in distances.iter().enumerate() {
        let [a, b] = d.rows;
        if let Some(&first) = seen.get(&[a.min(b), a.max(b)]) {
            return Some((k, first));
        }
        seen.insert([a.min(b), a.max(b)], k);
    }
    None
}
