//! The human-readable text of a command. It goes to standard output, or to standard error when
//! one of the command's outputs is standard output (so that a CSV or JSON written with `-` stays
//! clean). A closed pipe (`legwise … | head`) ends the text quietly: what remains is dropped and
//! the run ends with its own exit code, never a panic.

use std::fmt::Display;
use std::io::{self, Write};

/// Where the text of a command goes.
#[derive(Debug)]
pub(super) struct Console {
    to_stderr: bool,
    closed: bool,
}

impl Console {
    /// Text to standard output, or to standard error if `output_is_stdout`.
    pub(super) fn new(output_is_stdout: bool) -> Console {
        Console {
            to_stderr: output_is_stdout,
            closed: false,
        }
    }

    /// Writes `text` as it is.
    ///
    /// # Errors
    /// A write error other than a closed pipe (e.g. a full disk behind a redirection).
    pub(super) fn print(&mut self, text: &str) -> anyhow::Result<()> {
        if self.closed {
            return Ok(());
        }
        let (mut stream, name): (Box<dyn Write>, _) = if self.to_stderr {
            (Box::new(io::stderr().lock()), "standard error")
        } else {
            (Box::new(io::stdout().lock()), "standard output")
        };
        let written = stream
            .write_all(text.as_bytes())
            .and_then(|()| stream.flush());
        match written {
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => self.closed = true,
            Err(e) => anyhow::bail!("{name}: {e}"),
            Ok(()) => {}
        }
        Ok(())
    }

    /// Writes `text` and a newline.
    ///
    /// # Errors
    /// As [`Console::print`].
    pub(super) fn line(&mut self, text: impl Display) -> anyhow::Result<()> {
        self.print(&format!("{text}\n"))
    }
}
