//! G-code lines as RepRapFirmware's `config.g` and Marlin's `M503` report write them: a command
//! (`M665`, `G30`, …) and its parameters (a letter and a number, or numbers separated by `:`),
//! separated by blanks.
//!
//! A `;` starts a comment to the end of the line; `(…)` comments are removed; a quoted string
//! (`M550 P"my printer"`) is one parameter whose text is not read. Serial-console prefixes
//! (`echo:`, `Recv:`, `>>>`, a leading `12:03:44` time) are removed, so a host's log of an
//! `M503` or a bed probe reads as the commands it shows. Letters are read in upper case.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// One parameter of a command: its text and where it was read.
#[derive(Debug, Clone, PartialEq)]
pub struct Word {
    /// The text after the letter (`360.5`, `360:361:359`, `"name"`).
    pub text: String,
    /// The file.
    pub path: PathBuf,
    /// 1-based line number.
    pub line: usize,
}

impl Word {
    /// The parameter as one finite number.
    ///
    /// # Errors
    /// Not a number, naming file, line, command and letter.
    pub fn number(&self, command: &str, letter: char) -> Result<f64> {
        match self.text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(Error::Invalid(format!(
                "{}: line {}: {command} {letter}: expected a number, found `{}`",
                self.path.display(),
                self.line,
                self.text
            ))),
        }
    }

    /// The parameter as numbers separated by `:` (RepRapFirmware's `M665 L360:361:359`).
    ///
    /// # Errors
    /// A part that is not a number.
    pub fn numbers(&self, command: &str, letter: char) -> Result<Vec<f64>> {
        self.text
            .split(':')
            .map(|part| {
                Word {
                    text: part.trim().to_string(),
                    ..self.clone()
                }
                .number(command, letter)
            })
            .collect()
    }
}

/// One command line.
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// `G30`, `M665`, … (upper case; `G0`, `G00` → `G0`).
    pub name: String,
    /// Its parameters in order: the letter and its text.
    pub words: Vec<(char, String)>,
    /// 1-based line number.
    pub line: usize,
}

impl Command {
    /// The text of parameter `letter`, if present.
    pub fn get(&self, letter: char) -> Option<&str> {
        self.words
            .iter()
            .rev()
            .find(|(l, _)| *l == letter)
            .map(|(_, t)| t.as_str())
    }

    /// Parameter `letter` as a number, if present.
    ///
    /// # Errors
    /// Present but not a number (naming `path`, the line, the command and the letter).
    pub fn number(&self, path: &Path, letter: char) -> Result<Option<f64>> {
        self.get(letter)
            .map(|text| {
                Word {
                    text: text.to_string(),
                    path: path.to_path_buf(),
                    line: self.line,
                }
                .number(&self.name, letter)
            })
            .transpose()
    }
}

/// `raw` without the prefixes a serial console or host adds.
fn strip_console(raw: &str) -> &str {
    let mut text = raw.trim();
    loop {
        let before = text;
        for prefix in ["Recv:", "Send:", "echo:", ">>>", "<<<"] {
            if let Some(rest) = text.strip_prefix(prefix) {
                text = rest.trim_start();
            }
        }
        // A leading time `12:03:44` (Duet Web Control's console).
        let bytes = text.as_bytes();
        if bytes.len() > 8
            && bytes[2] == b':'
            && bytes[5] == b':'
            && text[..8].chars().all(|c| c.is_ascii_digit() || c == ':')
        {
            text = text[8..].trim_start();
        }
        if text == before {
            return text;
        }
    }
}

/// `raw` without its comments (`;` to the end, `(…)`), the console prefixes removed.
pub fn code_of(raw: &str) -> String {
    let text = strip_console(raw);
    let mut out = String::new();
    let mut quoted = false;
    let mut paren = false;
    for c in text.chars() {
        match c {
            '"' if !paren => {
                quoted = !quoted;
                out.push(c);
            }
            ';' if !quoted && !paren => break,
            '(' if !quoted => paren = true,
            ')' if paren => paren = false,
            _ if paren => {}
            _ => out.push(c),
        }
    }
    out.trim().to_string()
}

/// The command on `raw` (line `line`), or `None` if the line is not a `G`/`M` command (a reply,
/// a comment, a blank).
pub fn parse_command(raw: &str, line: usize) -> Option<Command> {
    let code = code_of(raw);
    let mut chars = code.chars().peekable();
    // An optional line number `N12` and its checksum are not parameters.
    let letter = chars.next()?.to_ascii_uppercase();
    if letter != 'G' && letter != 'M' {
        return None;
    }
    let digits: String = std::iter::from_fn(|| chars.next_if(char::is_ascii_digit)).collect();
    let number: u32 = digits.parse().ok()?;
    // `G29.1` and the like: a sub-command is part of the name.
    let mut name = format!("{letter}{number}");
    if chars.peek() == Some(&'.') {
        chars.next();
        let sub: String = std::iter::from_fn(|| chars.next_if(char::is_ascii_digit)).collect();
        name = format!("{name}.{sub}");
    }
    if chars.peek().is_some_and(|c| !c.is_whitespace()) {
        // `M665L360` is valid G-code, but `Mxyz` is not a command.
        if !chars.peek().is_some_and(char::is_ascii_alphabetic) {
            return None;
        }
    }
    let rest: String = chars.collect();
    let mut words = Vec::new();
    let mut it = rest.trim().chars().peekable();
    while let Some(c) = it.next() {
        if c.is_whitespace() || c == '*' {
            if c == '*' {
                // A checksum ends the line.
                break;
            }
            continue;
        }
        let letter = c.to_ascii_uppercase();
        // The text runs to the next blank outside quotes: `R18O` is `R` = `18O` (an error
        // when read as a number), never `R18` and a stray `O`.
        let mut text = String::new();
        let mut quoted = false;
        while let Some(&d) = it.peek() {
            if !quoted && (d.is_whitespace() || d == '*') {
                break;
            }
            if d == '"' {
                quoted = !quoted;
            }
            text.push(d);
            it.next();
        }
        words.push((letter, text));
    }
    Some(Command { name, words, line })
}

/// The parameters of the configuration commands of one or more files, each parameter the last
/// value given (a later file's over an earlier one's, a later line's over an earlier one's), as
/// the firmware applies them: `M665 L360 R180` then `M665 R181` leaves `L360 R181`.
#[derive(Debug, Clone, Default)]
pub struct Settings {
    values: BTreeMap<(String, char), Word>,
    seen: BTreeMap<String, (PathBuf, usize)>,
    /// The files read, in order.
    pub paths: Vec<PathBuf>,
}

impl Settings {
    /// Applies the commands `names` of file `path` (its text `text`) over the settings so far.
    pub fn apply(&mut self, path: &Path, text: &str, names: &[&str]) {
        self.paths.push(path.to_path_buf());
        for (index, raw) in text.lines().enumerate() {
            let Some(command) = parse_command(raw, index + 1) else {
                continue;
            };
            if !names.contains(&command.name.as_str()) {
                continue;
            }
            self.seen
                .insert(command.name.clone(), (path.to_path_buf(), index + 1));
            for (letter, text) in &command.words {
                self.values.insert(
                    (command.name.clone(), *letter),
                    Word {
                        text: text.clone(),
                        path: path.to_path_buf(),
                        line: index + 1,
                    },
                );
            }
        }
    }

    /// Reads `path` and applies its commands `names`.
    ///
    /// # Errors
    /// The file cannot be read.
    pub fn read(&mut self, path: &Path, names: &[&str]) -> Result<()> {
        let text = crate::model::source::read_text_file(path)?;
        self.apply(path, &text, names);
        Ok(())
    }

    /// Parameter `letter` of `command`, the last given.
    pub fn get(&self, command: &str, letter: char) -> Option<&Word> {
        self.values.get(&(command.to_string(), letter))
    }

    /// Parameter `letter` of `command` as a number, if given.
    ///
    /// # Errors
    /// Not a number.
    pub fn number(&self, command: &str, letter: char) -> Result<Option<f64>> {
        self.get(command, letter)
            .map(|w| w.number(command, letter))
            .transpose()
    }

    /// Parameter `letter` of `command` as a number; its absence is an error saying what it is.
    ///
    /// # Errors
    /// Missing (naming the files, the command's last line if any, the command and the letter) or
    /// not a number.
    pub fn require(&self, command: &str, letter: char, what: &str, firmware: &str) -> Result<f64> {
        self.number(command, letter)?
            .ok_or_else(|| self.missing(command, letter, what, firmware))
    }

    /// The error for a missing parameter.
    pub fn missing(&self, command: &str, letter: char, what: &str, firmware: &str) -> Error {
        match self.seen.get(command) {
            Some((path, line)) => Error::Invalid(format!(
                "{}: line {line}: {command}: missing `{letter}` ({what}); {firmware} needs it and legwise does not guess it",
                path.display()
            )),
            None => Error::Invalid(format!(
                "{}: no {command} line: expected one with `{letter}` ({what}); {firmware} needs it and legwise does not guess it",
                self.paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" + ")
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_comments_and_console_prefixes() {
        let c = parse_command("M665 L360.5:361 R180 H300 ; delta", 3).unwrap();
        assert_eq!(c.name, "M665");
        assert_eq!(c.get('L'), Some("360.5:361"));
        assert_eq!(c.get('H'), Some("300"));
        assert_eq!(c.line, 3);
        let c = parse_command("echo:  M666 X-0.25 Y0.00 Z-1.2e-1", 1).unwrap();
        assert_eq!(c.get('X'), Some("-0.25"));
        assert_eq!(c.get('Z'), Some("-1.2e-1"));
        let c = parse_command("Recv: echo:  M92 X80.00 Y80.00", 1).unwrap();
        assert_eq!(c.name, "M92");
        let c = parse_command("12:03:44 G30 P0 X0 Y84.9 Z-99999", 1).unwrap();
        assert_eq!((c.name.as_str(), c.get('Y')), ("G30", Some("84.9")));
        let c = parse_command("M550 P\"my; printer\" (a comment) ; more", 1).unwrap();
        assert_eq!(c.get('P'), Some("\"my; printer\""));
        assert_eq!(c.words.len(), 1);
        assert!(parse_command("; G30 P0", 1).is_none());
        assert!(parse_command("Stopped at height 0.123 mm", 1).is_none());
        assert!(parse_command("Bed X: 10.00 Y: 0.00 Z: 0.120", 1).is_none());
    }

    #[test]
    fn the_last_value_of_each_parameter_wins() {
        let mut s = Settings::default();
        s.apply(
            Path::new("config.g"),
            "M665 L360 R180 H300\nM665 R181\n",
            &["M665"],
        );
        s.apply(Path::new("config-override.g"), "M665 H299.5\n", &["M665"]);
        assert_eq!(s.number("M665", 'L').unwrap(), Some(360.0));
        assert_eq!(s.number("M665", 'R').unwrap(), Some(181.0));
        let h = s.get("M665", 'H').unwrap();
        assert_eq!((h.text.as_str(), h.line), ("299.5", 1));
        assert_eq!(h.path, Path::new("config-override.g"));
        let err = s.require("M666", 'X', "x", "RepRapFirmware").unwrap_err();
        assert!(
            err.to_string()
                .contains("config.g + config-override.g: no M666 line"),
            "{err}"
        );
    }
}
