//! Where each residual of a problem comes from, for the messages that name a row: its line in
//! the measurement file (or its index), what it measures, and the measurement it belongs to
//! (the residuals of one measurement — a shared row read by several legs, a row of a measured
//! pose — are dropped together).

use super::IdentificationProblem;

/// One residual's origin.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResidualPlace {
    /// Line of the measurement file, if read from one.
    pub line: Option<usize>,
    /// What it measures, e.g. "`z.nozzle`", "distance", "leg `leg2`'s reading".
    pub what: String,
    /// The measurement it belongs to (an index shared by the residuals of one row).
    pub measurement: usize,
    /// Whether it is a prior's row (no measurement: never an outlier, never dropped).
    pub prior: bool,
}

impl ResidualPlace {
    /// `line 12, `z.nozzle`` (or `row 12, …` for data made in memory).
    pub fn text(&self) -> String {
        match self.line {
            Some(line) => format!("line {line}, {}", self.what),
            None => format!("row {}, {}", self.measurement + 1, self.what),
        }
    }
}

impl IdentificationProblem<'_> {
    /// Where each residual comes from, in the problem's row order: the blocks (a leg's reading
    /// at a measured or sighted pose), then a forward problem's rows (each reported target
    /// coordinate) and distances, then the priors' rows.
    pub fn residual_places(&self) -> Vec<ResidualPlace> {
        let mut places: Vec<ResidualPlace> = self
            .blocks
            .iter()
            .enumerate()
            .map(|(i, block)| {
                let measurement = match (&self.forward, &self.sighted) {
                    (Some(forward), _) => forward.block_sources[i],
                    (None, Some(sighted)) => sighted.rows[i].source,
                    (None, None) => i,
                };
                ResidualPlace {
                    line: block.line,
                    what: format!("leg `{}`'s reading", self.mechanism.legs[block.leg].name),
                    measurement,
                    prior: false,
                }
            })
            .collect();
        if let (Some(forward), Some(sighted)) = (&self.forward, &self.sighted) {
            let columns = sighted.instrument.columns();
            for row in forward.rows.iter().filter(|r| !r.observed.is_empty()) {
                places.extend(columns.iter().map(|c| ResidualPlace {
                    line: row.line,
                    what: format!("`{c}`"),
                    measurement: row.source,
                    prior: false,
                }));
            }
            places.extend(forward.distances.iter().map(|d| ResidualPlace {
                line: d.line,
                what: "distance".into(),
                measurement: d.source,
                prior: false,
            }));
        }
        let fresh = places.iter().map(|p| p.measurement + 1).max().unwrap_or(0);
        places.extend(
            self.prior_rows()
                .iter()
                .enumerate()
                .map(|(k, p)| ResidualPlace {
                    line: None,
                    what: format!("the prior of {}", p.name),
                    measurement: fresh + k,
                    prior: true,
                }),
        );
        places
    }
}
