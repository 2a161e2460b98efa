//! Writing an output file safely: never over an input file, never half-written (a temporary
//! file in the same directory, then a rename).

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// Writes `bytes` to `path` through a temporary file in the same directory, refusing a path
/// that is one of `inputs` (compared after resolving links and relative paths).
///
/// # Errors
/// [`Error::Invalid`] naming the path when it is an input file, a directory, or in a directory
/// that does not exist; [`Error::Io`] when writing or renaming fails.
pub fn write_new(path: &Path, bytes: &[u8], inputs: &[&Path]) -> Result<()> {
    let target = std::fs::canonicalize(path).ok();
    if let Some(target) = &target {
        if inputs
            .iter()
            .any(|input| std::fs::canonicalize(input).ok().as_ref() == Some(target))
        {
            return Err(Error::Invalid(format!(
                "{}: refusing to overwrite an input file with an output",
                path.display()
            )));
        }
        if target.is_dir() {
            return Err(Error::Invalid(format!(
                "{}: is a directory; expected a file name for the output",
                path.display()
            )));
        }
    }
    let directory = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !directory.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: the directory {} does not exist",
            path.display(),
            directory.display()
        )));
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| {
            Error::Invalid(format!(
                "{}: expected a file name for the output",
                path.display()
            ))
        })?;
    let temporary = directory.join(format!(".{name}.{}.tmp", std::process::id()));
    let io = |error| Error::Io {
        path: path.to_path_buf(),
        error,
    };
    let written = std::fs::File::create(&temporary)
        .and_then(|mut file| file.write_all(bytes).and_then(|()| file.sync_all()))
        .and_then(|()| std::fs::rename(&temporary, path));
    if let Err(error) = written {
        let _ = std::fs::remove_file(&temporary);
        return Err(io(error));
    }
    Ok(())
}

/// Creates the directory `dir` (and its parents) for pictures, unless it exists.
///
/// # Errors
/// [`Error::Invalid`] when `dir` exists but is not a directory; [`Error::Io`] when it cannot
/// be created.
pub fn ensure_directory(dir: &Path) -> Result<()> {
    check_directory(dir)?;
    std::fs::create_dir_all(dir).map_err(|error| Error::Io {
        path: dir.to_path_buf(),
        error,
    })
}

/// Checks, before any work, that `dir` is a directory or does not exist yet.
///
/// # Errors
/// [`Error::Invalid`] when `dir` exists but is not a directory.
pub fn check_directory(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: exists and is not a directory; expected a directory for the pictures",
            dir.display()
        )));
    }
    Ok(())
}
