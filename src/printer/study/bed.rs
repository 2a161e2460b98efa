//! An imported printer's bed and the map its print errors are taken over.

use crate::error::{Error, Result};
use crate::evaluate::accuracy::map_slice;
use crate::model::region::Region;
use crate::model::Mechanism;

/// Heights of the print map's layers, as fractions of the workspace cylinder's height from its
/// bottom (the bed): near the bed, half-way, near the top.
pub const MAP_LAYERS: [f64; 3] = [0.05, 0.5, 0.95];

/// The print-error map of an imported printer: the workspace cylinder's disc at each of
/// [`MAP_LAYERS`], on a lattice of `grid` (m).
///
/// # Errors
/// Not a cylinder workspace; a grid [`map_slice`] refuses.
pub fn print_map(mechanism: &Mechanism, grid: f64) -> Result<Vec<[f64; 6]>> {
    let (centre, _, height) = cylinder(mechanism)?;
    let mut map = Vec::new();
    for layer in MAP_LAYERS {
        let z = centre[2] + (layer - 0.5) * height;
        map.extend(map_slice(mechanism, grid, 1.0, (z, z))?);
    }
    Ok(map)
}

/// The radius of an imported printer's bed disc: its workspace cylinder's.
pub(super) fn bed_radius(mechanism: &Mechanism) -> Result<f64> {
    cylinder(mechanism).map(|(_, radius, _)| radius)
}

/// An imported printer's workspace cylinder: its centre, radius and height (m).
fn cylinder(mechanism: &Mechanism) -> Result<([f64; 3], f64, f64)> {
    match mechanism.workspace.region {
        Region::Cylinder {
            centre,
            radius,
            height,
        } => Ok((centre, radius, height)),
        _ => Err(Error::Model {
            path: mechanism.model_path.clone(),
            field: "workspace.region".into(),
            message: "expected the cylinder of a printer imported by `legwise printer import`"
                .into(),
        }),
    }
}
