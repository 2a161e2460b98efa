//! The rows of an observation file ([`super::observations`]) seen together, once each row is
//! read: a row entered twice is refused, and distance rows, which name two rows by their ids,
//! are resolved to those rows.

use std::collections::HashMap;
use std::path::Path;

use super::observed::{repeated_pair, DistanceRow, ObservedRow};
use super::rows;
use crate::error::Result;

/// A forward model's rows must differ: the same touch entered twice (under two ids, or none)
/// counts the same measurement twice and makes the standard deviations too small.
///
/// # Errors
/// The first row that repeats an earlier one exactly (target coordinates, readings and
/// measured pose, bit for bit), naming both lines.
pub(super) fn repeated_rows(path: &Path, rows: &[ObservedRow]) -> Result<()> {
    let mut seen: HashMap<Vec<u64>, usize> = HashMap::with_capacity(rows.len());
    for (i, row) in rows.iter().enumerate() {
        // Each part tagged by its length, so that rows of different kinds never share a key.
        let mut key = vec![row.observed.len() as u64];
        key.extend(row.observed.iter().map(|v| v.to_bits()));
        key.extend(
            row.readings
                .iter()
                .map(|r| r.map_or(u64::MAX, f64::to_bits)),
        );
        key.extend(row.pose.iter().flatten().map(|v| v.to_bits()));
        if let Some(&first) = seen.get(&key) {
            let name = |r: &ObservedRow| {
                let line = r
                    .line
                    .map_or(String::from("a row"), |l| format!("line {l}"));
                match &r.id {
                    Some(id) => format!("{line} (id `{id}`)"),
                    None => line,
                }
            };
            let id = row
                .id
                .as_ref()
                .map_or(String::new(), |id| format!(" (id `{id}`)"));
            return Err(rows::fail(
                path,
                format!("line {}{id}", row.line.unwrap_or(i + 2)),
                format!(
                    "the row repeats {} exactly (the same target coordinates, readings and \
                     measured pose): a touch entered twice counts one measurement twice and \
                     makes the standard deviations too small; keep one of them",
                    name(&rows[first])
                ),
            ));
        }
        seen.insert(key, i);
    }
    Ok(())
}

/// A distance row as read, its rows still named by their ids.
pub(super) struct PendingDistance {
    line: usize,
    ids: [String; 2],
    value: f64,
}

/// The cells of a distance row: two row ids and a positive distance in metres.
pub(super) fn distance_row(
    path: &Path,
    line: usize,
    header: &[String],
    columns: [usize; 3],
    (from, to, distance): (&str, &str, &str),
) -> Result<PendingDistance> {
    for (column, text) in [(columns[0], from), (columns[1], to)] {
        if text.is_empty() {
            return Err(rows::fail(
                path,
                format!("line {line}, column `{}`", header[column]),
                "missing value; expected the id of a row (its `id` cell)".into(),
            ));
        }
    }
    let value = rows::number(path, line, "distance", distance, "metres")?.unwrap_or_default();
    if value <= 0.0 {
        return Err(rows::fail(
            path,
            format!("line {line}, column `distance`"),
            format!("expected a positive distance in metres, found {value}"),
        ));
    }
    Ok(PendingDistance {
        line,
        ids: [from.to_string(), to.to_string()],
        value,
    })
}

/// The distances with their rows found by id; a row without coordinates must be named by one.
pub(super) fn resolve_distances(
    path: &Path,
    rows: &[ObservedRow],
    pending: Vec<PendingDistance>,
) -> Result<Vec<DistanceRow>> {
    for (i, row) in rows.iter().enumerate() {
        if let Some(id) = &row.id {
            if rows[..i].iter().any(|r| r.id.as_ref() == Some(id)) {
                return Err(rows::fail(
                    path,
                    format!("line {}, column `id`", row.line.unwrap_or(i + 2)),
                    format!("`{id}` names an earlier row too: ids must be unique"),
                ));
            }
        }
    }
    let distances = pending
        .into_iter()
        .map(|d| {
            let find = |k: usize| {
                rows.iter()
                    .position(|r| r.id.as_ref() == Some(&d.ids[k]))
                    .ok_or_else(|| {
                        rows::fail(
                            path,
                            format!("line {}, column `{}`", d.line, ["from", "to"][k]),
                            format!("no row has the id `{}`", d.ids[k]),
                        )
                    })
            };
            let pair = [find(0)?, find(1)?];
            for (k, &r) in pair.iter().enumerate() {
                if rows[r].readings.iter().any(Option::is_none) {
                    return Err(rows::fail(
                        path,
                        format!("line {}, column `{}`", d.line, ["from", "to"][k]),
                        format!(
                            "row `{}` (line {}) lacks a reading: a distance's rows need every \
                             leg's reading (their forward kinematics)",
                            d.ids[k],
                            rows[r].line.unwrap_or(r + 2)
                        ),
                    ));
                }
            }
            if pair[0] == pair[1] {
                return Err(rows::fail(
                    path,
                    format!("line {}, column `to`", d.line),
                    format!(
                        "a distance joins two different rows, not `{}` to itself",
                        d.ids[0]
                    ),
                ));
            }
            Ok(DistanceRow {
                line: Some(d.line),
                rows: pair,
                value: d.value,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some((k, first)) = repeated_pair(&distances) {
        let (d, earlier) = (&distances[k], &distances[first]);
        let id = |r: usize| rows[r].id.clone().unwrap_or_default();
        let reversed = match d.rows == earlier.rows {
            true => "",
            false => ", from and to reversed",
        };
        return Err(rows::fail(
            path,
            format!("line {}, column `from`", d.line.unwrap_or_default()),
            format!(
                "the distance between `{}` and `{}` is given already at line {}{reversed}: a \
                 distance entered twice counts one measurement twice; keep one of them (or \
                 their mean)",
                id(d.rows[0]),
                id(d.rows[1]),
                earlier.line.unwrap_or_default()
            ),
        ));
    }
    for (i, row) in rows.iter().enumerate() {
        let named = distances.iter().any(|d| d.rows.contains(&i));
        if row.observed.is_empty() && row.pose.is_none() && !named {
            return Err(rows::fail(
                path,
                format!("line {}", row.line.unwrap_or(i + 2)),
                "the row has readings but no target coordinates and no distance names it: \
                 nothing to fit"
                    .into(),
            ));
        }
    }
    Ok(distances)
}
