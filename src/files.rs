//! Output files, one way for every command and for library users: each output is checked
//! when the run starts, before the long work, and written atomically.
//!
//! An output is checked when the command starts, before the long work: its directory must exist
//! and take a new file, it must not be a directory or a read-only file, and it must not be one
//! of the run's inputs
//! (compared after canonicalisation, and by device and inode, so `./m.csv`, a symbolic link or a
//! hard link to the measurement file are all caught). It is written to a temporary file in the
//! same directory, flushed to disk and renamed over the target, so a run that fails or is killed
//! while writing leaves the old file whole. `-` (or the file that is already standard output,
//! such as `/dev/stdout`) means standard output; other special files (`/dev/null`, a named pipe)
//! are written in place. A closed standard output (`legwise … | head`) is not an error: the
//! rest of the output is dropped.

use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::report::plots::Format;

/// An [`Error::Invalid`] with a formatted message.
macro_rules! invalid {
    ($($arg:tt)*) => {
        Error::Invalid(format!($($arg)*))
    };
}

/// One input of a run, which no output may overwrite.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// What it is, for messages: "model file", "URDF", "measurement file".
    pub role: &'a str,
    /// Its path as the user (or the model file) gave it.
    pub path: &'a Path,
}

/// Where an output goes.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Target {
    /// Standard output.
    Stdout,
    /// A regular file, written to a temporary file beside it and renamed. The path is the
    /// canonical one (a symbolic link is followed, not replaced).
    File(PathBuf),
    /// An existing special file (device, named pipe): written in place.
    Special(PathBuf),
}

/// A checked output path.
#[derive(Debug, Clone)]
pub struct Output {
    /// The option that named it, e.g. `--out`.
    flag: &'static str,
    /// The path as given.
    given: PathBuf,
    /// Where it is written.
    target: Target,
}

impl Output {
    /// `--calibrated OUT.yaml`: the model file and the URDF beside it (extension `urdf`),
    /// checked against the inputs and against the JSON report's path `json`.
    ///
    /// # Errors
    /// `-` (the URDF is written beside the file), `OUT.urdf`, a path the JSON report would also
    /// write, or as [`Self::prepare`].
    pub fn prepare_calibrated(
        out: &Path,
        json: Option<&Path>,
        inputs: &[Input<'_>],
    ) -> Result<(Output, Output)> {
        if let Some(json) = json {
            let urdf = out.with_extension("urdf");
            if [out, &urdf].iter().any(|p| same_destination(p, json)) {
                return Err(invalid!(
                    "{}: --calibrated and --json would write the same file; choose another path",
                    json.display()
                ));
            }
        }
        if out.as_os_str() == "-" {
            return Err(invalid!(
                "--calibrated: expected a file path (the URDF is written beside it), found `-`"
            ));
        }
        let urdf = crate::report::calibrated::urdf_path(out)?;
        Ok((
            Output::prepare("--calibrated", out, inputs)?,
            Output::prepare("--calibrated", &urdf, inputs)?,
        ))
    }

    /// As [`Self::prepare`] for an optional path (`None` when the flag was not given).
    ///
    /// # Errors
    /// As [`Self::prepare`].
    pub fn prepare_optional(
        flag: &'static str,
        path: Option<&Path>,
        inputs: &[Input<'_>],
    ) -> Result<Option<Output>> {
        path.map(|path| Self::prepare(flag, path, inputs))
            .transpose()
    }

    /// Checks the output `path` given to `flag` against the run's `inputs`.
    ///
    /// # Errors
    /// The path is a directory, its directory does not exist or cannot take a new file, or it
    /// is one of the inputs; each message names the path (and the input).
    pub fn prepare(flag: &'static str, path: &Path, inputs: &[Input<'_>]) -> Result<Output> {
        let target = resolve(flag, path)?;
        let output = Output {
            flag,
            given: path.to_path_buf(),
            target,
        };
        match inputs.iter().find(|input| output.is_input(input.path)) {
            Some(input) => Err(invalid!(
                "{}: {flag} would overwrite the {} {} (an input of this run); choose another path",
                path.display(),
                input.role,
                input.path.display()
            )),
            None => Ok(output),
        }
    }

    /// True when the output goes to standard output (then the human-readable text goes to
    /// standard error, so that the output stays clean).
    pub fn is_stdout(&self) -> bool {
        self.target == Target::Stdout
    }

    /// The output as given, for messages (`standard output` for `-`).
    pub fn name(&self) -> String {
        match self.target {
            Target::Stdout => "standard output".into(),
            _ => self.given.display().to_string(),
        }
    }

    /// Writes `contents` (the `what`, e.g. "measurement CSV", for messages).
    ///
    /// # Errors
    /// The file cannot be created, written or renamed; the message names the path. A closed
    /// standard output is not an error.
    pub fn write(&self, what: &str, contents: &[u8]) -> Result<()> {
        let fail = |error: io::Error| {
            invalid!(
                "{}: cannot write the {what}: {}",
                self.given.display(),
                plain(&error)
            )
        };
        match &self.target {
            Target::Stdout => {
                let mut stdout = io::stdout().lock();
                match stdout.write_all(contents).and_then(|()| stdout.flush()) {
                    Err(e) if e.kind() != io::ErrorKind::BrokenPipe => Err(invalid!(
                        "{} ({}): cannot write the {what}: {e}",
                        self.flag,
                        self.name()
                    )),
                    _ => Ok(()),
                }
            }
            Target::Special(path) => fs::OpenOptions::new()
                .write(true)
                .open(path)
                .and_then(|mut file| file.write_all(contents))
                .or_else(|e| match e.kind() {
                    io::ErrorKind::BrokenPipe => Ok(()),
                    _ => Err(e),
                })
                .map_err(fail),
            Target::File(path) => replace(path, contents).map_err(fail),
        }
    }

    /// True when the output is the file `input`.
    fn is_input(&self, input: &Path) -> bool {
        let Target::File(output) = &self.target else {
            return false;
        };
        if fs::canonicalize(input).is_ok_and(|input| &input == output) {
            return true;
        }
        match (fs::metadata(output), fs::metadata(input)) {
            (Ok(a), Ok(b)) => same_file(&a, &b),
            _ => false,
        }
    }
}

/// Resolves and checks an output path.
fn resolve(flag: &str, path: &Path) -> Result<Target> {
    let shown = path.display();
    if path.as_os_str() == "-" {
        return Ok(Target::Stdout);
    }
    if path.to_string_lossy().ends_with(std::path::is_separator) {
        return Err(invalid!(
            "{shown}: {flag}: expected a file path, found a directory path (it ends in a \
             separator)"
        ));
    }
    if let Ok(metadata) = fs::metadata(path) {
        if is_stdout(&metadata) {
            return Ok(Target::Stdout);
        }
        if metadata.is_dir() {
            return Err(invalid!(
                "{shown}: {flag}: is a directory; expected a file path"
            ));
        }
        if !metadata.is_file() {
            return Ok(Target::Special(path.to_path_buf()));
        }
        if metadata.permissions().readonly() {
            // The rename would replace it all the same; a read-only file says "keep me".
            return Err(invalid!(
                "{shown}: {flag}: the file is read-only; expected a writable file or a new path"
            ));
        }
        let canonical = fs::canonicalize(path).map_err(|e| invalid!("{shown}: {flag}: {e}"))?;
        probe(flag, path, &canonical)?;
        return Ok(Target::File(canonical));
    }
    let name = path
        .file_name()
        .ok_or_else(|| invalid!("{shown}: {flag}: expected a file path"))?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match fs::metadata(parent) {
        Err(_) => {
            return Err(invalid!(
                "{shown}: {flag}: the directory {} does not exist",
                parent.display()
            ))
        }
        Ok(m) if !m.is_dir() => {
            return Err(invalid!(
                "{shown}: {flag}: {} is not a directory",
                parent.display()
            ))
        }
        Ok(_) => {}
    }
    let canonical = fs::canonicalize(parent)
        .map_err(|e| invalid!("{shown}: {flag}: {e}"))?
        .join(name);
    probe(flag, path, &canonical)?;
    Ok(Target::File(canonical))
}

/// Checks that the directory of `canonical` takes a new file, by creating (and removing) one.
fn probe(flag: &str, path: &Path, canonical: &Path) -> Result<()> {
    let directory = canonical.parent().unwrap_or(Path::new("/"));
    temporary_in(directory, canonical).map(drop).map_err(|e| {
        invalid!(
            "{}: {flag}: cannot create a file in {}: {}",
            path.display(),
            directory.display(),
            plain(&e)
        )
    })
}

/// The operating system's message of `error`, without the temporary file's name that tempfile
/// appends (`… at path "/dir/.name.XXXXXX.tmp"`): the user never named that file.
fn plain(error: &io::Error) -> String {
    let message = error.to_string();
    match message.rsplit_once(" at path \"") {
        Some((os_message, _)) => os_message.to_string(),
        None => message,
    }
}

/// A temporary file beside `target`, named after it (`.name.XXXXXX.tmp`).
fn temporary_in(directory: &Path, target: &Path) -> io::Result<tempfile::NamedTempFile> {
    let prefix = format!(
        ".{}.",
        target.file_name().unwrap_or_default().to_string_lossy()
    );
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // The usual permissions of a new file (less the umask), not the temporary file's 0600.
        builder.permissions(fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(directory)
}

/// Writes `contents` to a temporary file beside `path`, flushes it to disk and renames it over
/// `path`, keeping the permissions of a file it replaces.
fn replace(path: &Path, contents: &[u8]) -> io::Result<()> {
    let directory = path.parent().unwrap_or(Path::new("/"));
    let mut temporary = temporary_in(directory, path)?;
    temporary.write_all(contents)?;
    if let Ok(old) = fs::metadata(path) {
        temporary.as_file().set_permissions(old.permissions())?;
    }
    temporary.as_file().sync_all()?;
    temporary.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// True when `metadata` is that of the file already open as standard output.
fn is_stdout(metadata: &fs::Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd;
        io::stdout()
            .as_fd()
            .try_clone_to_owned()
            .map(fs::File::from)
            .and_then(|file| file.metadata())
            .is_ok_and(|stdout| same_file(&stdout, metadata))
    }
    #[cfg(not(unix))]
    {
        let _ = metadata;
        false
    }
}

/// True when both are the same file (device and inode).
fn same_file(a: &fs::Metadata, b: &fs::Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        a.dev() == b.dev() && a.ino() == b.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (a, b);
        false
    }
}

/// Whether two output paths name the same file (their directories compared canonically).
fn same_destination(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| {
        let parent = p.parent().filter(|d| !d.as_os_str().is_empty());
        let dir = parent.unwrap_or(Path::new(".")).canonicalize().ok();
        (dir, p.file_name().map(|n| n.to_os_string()))
    };
    resolve(a) == resolve(b)
}

/// SVG, or PNG with `--png`.
pub fn format(png: bool) -> Format {
    if png {
        Format::Png
    } else {
        Format::Svg
    }
}

/// Creates the `--plots` directory `dir` if missing and checks one output per picture `names`
/// (without extension) in it, before any work; none without `dir`.
///
/// # Errors
/// `dir` exists and is not a directory or cannot be created; a picture would overwrite an
/// input or cannot be written there.
pub fn prepare(
    dir: Option<&Path>,
    names: &[&str],
    format: Format,
    inputs: &[Input<'_>],
) -> Result<Vec<Output>> {
    let Some(dir) = dir else {
        return Ok(Vec::new());
    };
    if dir.exists() && !dir.is_dir() {
        return Err(invalid!(
            "{}: --plots expects a directory, found a file; choose another path",
            dir.display()
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| {
        invalid!(
            "{}: --plots: cannot create the directory: {e}",
            dir.display()
        )
    })?;
    names
        .iter()
        .map(|name| {
            let path = dir.join(format!("{name}.{}", format.extension()));
            Output::prepare("--plots", &path, inputs)
        })
        .collect()
}
