//! Reading a model or URDF file: only a regular file of bounded size is read, so that a device
//! (`/dev/zero`), a FIFO or a directory gives a message saying what it is instead of a hang or a
//! misleading "not found".

use std::io::{Error, ErrorKind};
use std::path::Path;

/// Largest model or URDF file read, bytes (such files are a few kilobytes).
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Reads a regular UTF-8 text file of at most [`MAX_FILE_BYTES`].
///
/// # Errors
/// The operating system's error (e.g. not found, permission denied), or an
/// [`ErrorKind::InvalidInput`] error saying the path is not a regular file (and what it is) or
/// is too large.
pub fn read_text(path: &Path) -> std::io::Result<String> {
    let metadata = std::fs::metadata(path)?;
    if !metadata.is_file() {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "not a regular file (it is {}); expected a text file",
                describe(&metadata.file_type())
            ),
        ));
    }
    if metadata.len() > MAX_FILE_BYTES {
        return Err(Error::new(
            ErrorKind::InvalidInput,
            format!(
                "the file holds {} bytes; at most {MAX_FILE_BYTES} are read",
                metadata.len()
            ),
        ));
    }
    std::fs::read_to_string(path)
}

/// [`read_text`] with its error as the crate's [`crate::error::Error::Io`] naming `path`: for
/// every text input (model files, firmware configurations, probe logs, selections).
///
/// # Errors
/// As [`read_text`].
pub fn read_text_file(path: &Path) -> crate::error::Result<String> {
    read_text(path).map_err(|error| crate::error::Error::Io {
        path: path.to_path_buf(),
        error,
    })
}

/// What kind of file system object a non-regular file is, for messages.
fn describe(file_type: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_directory_is_named_as_such() {
        let dir = std::env::temp_dir();
        let err = read_text(&dir).expect_err("a directory is not read");
        assert_eq!(err.kind(), ErrorKind::InvalidInput);
        assert_eq!(
            err.to_string(),
            "not a regular file (it is a directory); expected a text file"
        );
    }
}
