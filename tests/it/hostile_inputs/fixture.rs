//! A case's directory: every bundled model and URDF (`models/`) and the base measurement files
//! (`tests/data/hostile/*.csv`, one seeded simulation of each model) copied in, then the case's
//! edits applied. An edit is `FILE: OPERATION`:
//!
//! * `FROM => TO`: the first occurrence of `FROM` replaced (it must be there); `FROM =>* TO`:
//!   every occurrence;
//! * `:= TEXT` (after the name, as `FILE := TEXT`): the whole file;
//! * `append TEXT`, `prepend TEXT`; `crlf` (every line ending CRLF); `repeat N` (the last line
//!   written N more times); `cut FROM` (the file from FROM on removed);
//! * `scale COLUMN FACTOR` (the non-empty cells of a CSV column multiplied), `drop COLUMN`;
//! * `rm`, `mkdir`, `readonly`, `copy SOURCE`, `symlink TARGET`;
//! * `stdin: FILE` feeds FILE to the command's standard input.
//!
//! Texts take the escapes of `table::unescape` and the placeholders `{dir}` (the case's
//! directory) and `{crate}`.
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use super::table::unescape;
use crate::support::crate_path;

/// Fills the placeholders of a text.
pub(crate) fn fill(text: &str, dir: &Path) -> String {
    text.replace("{dir}", &dir.display().to_string())
        .replace("{crate}", env!("CARGO_MANIFEST_DIR"))
}

/// Copies the bundled models and the base measurement files into `dir`.
pub(crate) fn populate(dir: &Path) {
    fs::create_dir_all(dir).unwrap();
    for source in ["models", "tests/data/hostile"] {
        for entry in fs::read_dir(crate_path(source)).unwrap() {
            let path = entry.unwrap().path();
            let keep = path
                .extension()
                .is_some_and(|e| ["yaml", "urdf", "csv"].contains(&e.to_str().unwrap()));
            if keep {
                fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
            }
        }
    }
}

/// Applies the edits in `dir`; returns the file to feed to standard input, if any. A malformed
/// edit, or a `FROM` not found, is an error naming it.
pub(crate) fn apply(dir: &Path, edits: &[String]) -> Result<Option<PathBuf>, String> {
    let mut stdin = None;
    for edit in edits {
        let (name, operation) = edit
            .split_once(':')
            .ok_or_else(|| format!("edit `{edit}`: expected FILE: OPERATION"))?;
        let path = dir.join(name.trim());
        if name.trim() == "stdin" {
            stdin = Some(dir.join(operation.trim()));
            continue;
        }
        let operation = fill(operation, dir);
        edit_file(&path, &operation).map_err(|e| format!("edit `{edit}`: {e}"))?;
    }
    Ok(stdin)
}

/// One edit of the file at `path`.
fn edit_file(path: &Path, operation: &str) -> Result<(), String> {
    let read = || fs::read_to_string(path).map_err(|e| e.to_string());
    let write = |text: String| fs::write(path, text).map_err(|e| e.to_string());
    if let Some(text) = operation.strip_prefix('=') {
        return write(unescape(text.strip_prefix(' ').unwrap_or(text)));
    }
    // One space after the colon; `FROM =>` (nothing after the arrow) deletes.
    let operation = operation.strip_prefix(' ').unwrap_or(operation).trim_end();
    let operation = match operation.ends_with(" =>") || operation.ends_with(" =>*") {
        true => format!("{operation} "),
        false => operation.to_string(),
    };
    for (arrow, all) in [(" =>* ", true), (" => ", false)] {
        if let Some((from, to)) = operation.split_once(arrow) {
            let (from, to) = (unescape(from), unescape(to));
            let text = read()?;
            if !text.contains(&from) {
                return Err(format!("`{from}` is not in the file"));
            }
            return write(match all {
                true => text.replace(&from, &to),
                false => text.replacen(&from, &to, 1),
            });
        }
    }
    let (verb, argument) = operation.split_once(' ').unwrap_or((&operation, ""));
    match verb {
        "append" => write(read()? + &unescape(argument)),
        "prepend" => write(unescape(argument) + &read()?),
        "crlf" => write(read()?.replace('\n', "\r\n")),
        "cut" => {
            let text = read()?;
            let at = text
                .find(&unescape(argument))
                .ok_or("`cut FROM`: not found")?;
            write(text[..at].to_string() + "\n")
        }
        "repeat" => {
            let times: usize = argument.parse().map_err(|_| "repeat N".to_string())?;
            let text = read()?;
            let last = text.lines().last().unwrap_or_default().to_string() + "\n";
            write(text + &last.repeat(times))
        }
        "scale" => {
            let (column, factor) = argument.split_once(' ').ok_or("scale COLUMN FACTOR")?;
            let factor: f64 = factor.parse().map_err(|_| "scale FACTOR".to_string())?;
            write(csv_map(&read()?, column, |cell| {
                match cell.parse::<f64>() {
                    Ok(v) => Some((v * factor).to_string()),
                    Err(_) => Some(cell.to_string()),
                }
            })?)
        }
        "drop" => write(csv_map(&read()?, argument, |_| None)?),
        "rm" => fs::remove_file(path).map_err(|e| e.to_string()),
        "mkdir" => fs::create_dir_all(path).map_err(|e| e.to_string()),
        "readonly" => {
            let mut permissions = fs::metadata(path).map_err(|e| e.to_string())?.permissions();
            permissions.set_readonly(true);
            fs::set_permissions(path, permissions).map_err(|e| e.to_string())
        }
        "copy" => fs::copy(path.parent().unwrap().join(argument), path)
            .map(drop)
            .map_err(|e| e.to_string()),
        #[cfg(unix)]
        "symlink" => std::os::unix::fs::symlink(argument, path).map_err(|e| e.to_string()),
        other => Err(format!("unknown operation `{other}`")),
    }
}

/// A comma-separated text with the non-empty cells of `column` (by its header) mapped, or the
/// column dropped where `map` gives `None`.
fn csv_map(
    text: &str,
    column: &str,
    map: impl Fn(&str) -> Option<String>,
) -> Result<String, String> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let index = header
        .iter()
        .position(|h| *h == column)
        .ok_or_else(|| format!("no column `{column}`"))?;
    let mut out = String::new();
    for (n, line) in text.lines().enumerate() {
        let cells: Vec<String> = line
            .split(',')
            .enumerate()
            .filter_map(|(i, cell)| match (i == index, n == 0 || cell.is_empty()) {
                (false, _) => Some(cell.to_string()),
                (true, true) => map("").map(|_| cell.to_string()),
                (true, false) => map(cell),
            })
            .collect();
        out += &(cells.join(",") + "\n");
    }
    Ok(out)
}

/// Every file and directory under `dir` (relative path → contents and whether read-only; a
/// directory as `None`), to tell whether a run changed anything.
pub(crate) fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (Option<Vec<u8>>, bool)> {
    let mut found = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(current) = stack.pop() {
        for entry in fs::read_dir(&current).unwrap() {
            let path = entry.unwrap().path();
            let relative = path.strip_prefix(dir).unwrap().to_path_buf();
            let metadata = fs::symlink_metadata(&path).unwrap();
            let readonly = metadata.permissions().readonly();
            if metadata.is_dir() {
                stack.push(path);
                found.insert(relative, (None, readonly));
            } else {
                found.insert(
                    relative,
                    (Some(fs::read(&path).unwrap_or_default()), readonly),
                );
            }
        }
    }
    found
}
