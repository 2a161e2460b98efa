//! A previous calibration as the prior of a new fit (`legwise identify --prior FILE`): the
//! estimates and covariance a calibrated model file carries (its `calibration:` block, written
//! by `identify --calibrated`), read, checked and attached to the model whose fit takes it.

use std::path::{Path, PathBuf};

use nalgebra::DMatrix;

use super::file::ModelFile;
use crate::error::{Error, Result};

/// Relative asymmetry `|Σ_ij − Σ_ji|` (of the larger diagonal term) a covariance may have.
const SYMMETRY: f64 = 1e-9;

/// A calibration's estimates and their covariance, taken as a prior.
#[derive(Debug, Clone, PartialEq)]
pub struct PriorCovariance {
    /// The calibration file.
    pub source: PathBuf,
    /// The parameters, by name.
    pub parameters: Vec<String>,
    /// Their estimates: the prior's mean, SI units.
    pub estimates: Vec<f64>,
    /// Their covariance: the prior's, SI units.
    pub covariance: DMatrix<f64>,
}

impl PriorCovariance {
    /// The `calibration:` block of the model file at `path`.
    ///
    /// # Errors
    /// The file cannot be read as a model file; it has no `calibration:` block; its sizes
    /// disagree; a value is not finite; the covariance is not symmetric with a positive
    /// diagonal.
    pub fn read(path: &Path) -> Result<Self> {
        let file = ModelFile::read(path)?;
        let error = |field: &str, message: String| Error::Model {
            path: path.to_path_buf(),
            field: format!("calibration{field}"),
            message,
        };
        let block = file.calibration.ok_or_else(|| {
            error(
                "",
                "expected the calibration a calibrated model carries (`legwise identify \
                 --calibrated` writes it: the parameters, their estimates and covariance), \
                 found none"
                    .into(),
            )
        })?;
        let n = block.parameters.len();
        if n == 0 || block.estimates.len() != n || block.covariance.len() != n {
            return Err(error(
                "",
                format!(
                    "expected as many estimates and covariance rows as parameters ({n}), found \
                     {} and {}",
                    block.estimates.len(),
                    block.covariance.len()
                ),
            ));
        }
        for (i, row) in block.covariance.iter().enumerate() {
            if row.len() != n {
                return Err(error(
                    &format!(".covariance[{i}]"),
                    format!("expected {n} values, found {}", row.len()),
                ));
            }
        }
        if let Some(i) = block.estimates.iter().position(|v| !v.is_finite()) {
            return Err(error(
                &format!(".estimates[{i}]"),
                "expected a finite number".into(),
            ));
        }
        let covariance = DMatrix::from_fn(n, n, |i, j| block.covariance[i][j]);
        for i in 0..n {
            if !(covariance[(i, i)] > 0.0 && covariance[(i, i)].is_finite()) {
                return Err(error(
                    &format!(".covariance[{i}][{i}]"),
                    format!(
                        "expected a positive variance for `{}`, found {}",
                        block.parameters[i],
                        covariance[(i, i)]
                    ),
                ));
            }
            for j in 0..i {
                let scale = covariance[(i, i)].max(covariance[(j, j)]);
                let gap = (covariance[(i, j)] - covariance[(j, i)]).abs();
                if gap.is_nan() || gap > SYMMETRY * scale {
                    return Err(error(
                        &format!(".covariance[{i}][{j}]"),
                        format!(
                            "expected a symmetric covariance, found {} against {} at [{j}][{i}]",
                            covariance[(i, j)],
                            covariance[(j, i)]
                        ),
                    ));
                }
            }
        }
        Ok(Self {
            source: path.to_path_buf(),
            parameters: block.parameters,
            estimates: block.estimates,
            covariance,
        })
    }
}
