//! The table of hostile cases (`tests/data/hostile/cases.txt`): one case a line, seven columns
//! separated by ` | `: id, arguments (`-`: none), fixture edits (`-`: none), expected exit code, a text the message
//! must hold, the class the sweep found, and a note (`open: …` for a case not fixed yet, which
//! is skipped). Lines starting with `#` and blank lines are comments.

/// One case of the table.
#[derive(Debug, Clone)]
pub(crate) struct Case {
    /// The table's line number, for messages.
    pub(crate) line: usize,
    /// A unique name (`yaml.gain-nan`).
    pub(crate) id: String,
    /// The arguments after `legwise`, placeholders (`{dir}`, `{crate}`) not yet filled.
    pub(crate) args: Vec<String>,
    /// The fixture edits, applied in order in the case's directory (see `fixture.rs`).
    pub(crate) edits: Vec<String>,
    /// The exit code the case must end with.
    pub(crate) exit: i32,
    /// A text standard error (exit 2) or standard output and error (exit 0, 3) must hold.
    pub(crate) message: String,
    /// What the sweep found before the fixes: clear, unclear, silent or crash.
    pub(crate) found: String,
    /// Free text; `open: REASON` marks a case whose fix is elsewhere (it is skipped).
    pub(crate) note: String,
}

impl Case {
    /// The reason a case is skipped: a known problem whose fix belongs to another part.
    pub(crate) fn open(&self) -> Option<&str> {
        self.note.strip_prefix("open:").map(str::trim)
    }
}

/// The cases of the table text; panics naming the line of a malformed one.
pub(crate) fn parse(text: &str) -> Vec<Case> {
    let mut cases: Vec<Case> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index + 1;
        if raw.trim().is_empty() || raw.trim_start().starts_with('#') {
            continue;
        }
        let columns: Vec<&str> = raw.split(" | ").map(str::trim).collect();
        let [id, args, fixture, exit, message, found, note] = columns[..] else {
            panic!(
                "cases.txt line {line}: expected 7 columns, found {}",
                columns.len()
            );
        };
        assert!(
            ["clear", "unclear", "silent", "crash"].contains(&found),
            "cases.txt line {line}: found `{found}`; expected clear, unclear, silent or crash"
        );
        assert!(
            !cases.iter().any(|c| c.id == id),
            "cases.txt line {line}: id `{id}` appears twice"
        );
        cases.push(Case {
            line,
            id: id.to_string(),
            args: match args {
                "-" => Vec::new(),
                args => words(args, line),
            },
            edits: match fixture {
                "-" | "" => Vec::new(),
                edits => edits.split(" && ").map(str::to_string).collect(),
            },
            exit: exit
                .parse()
                .unwrap_or_else(|_| panic!("cases.txt line {line}: exit `{exit}`")),
            message: unescape(message),
            found: found.to_string(),
            note: note.to_string(),
        });
    }
    cases
}

/// The words of an argument list: split at spaces, with double quotes around a word holding
/// spaces (`""` is an empty argument), escapes as [`unescape`].
fn words(text: &str, line: usize) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let (mut quoted, mut started) = (false, false);
    for c in text.chars() {
        match c {
            '"' => (quoted, started) = (!quoted, true),
            ' ' if !quoted => {
                if started {
                    words.push(unescape(&std::mem::take(&mut word)));
                }
                started = false;
            }
            c => {
                word.push(c);
                started = true;
            }
        }
    }
    assert!(!quoted, "cases.txt line {line}: unbalanced quote");
    if started {
        words.push(unescape(&word));
    }
    words
}

/// `\n`, `\r`, `\t`, `\\` and `\u{HEX}` replaced by the characters they stand for.
pub(crate) fn unescape(text: &str) -> String {
    let mut out = String::new();
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('n') => out.push('\n'),
            Some('r') => out.push('\r'),
            Some('t') => out.push('\t'),
            Some('\\') => out.push('\\'),
            Some('u') => {
                let hex: String = chars.by_ref().skip(1).take_while(|&c| c != '}').collect();
                let code = u32::from_str_radix(&hex, 16).expect("\\u{HEX}");
                out.push(char::from_u32(code).expect("a character"));
            }
            Some(other) => {
                out.push('\\');
                out.push(other);
            }
            None => out.push('\\'),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_syntax() {
        let cases = parse(
            "# comment\n\na | identify --model \"my m.yaml\" \"\" | m.yaml: a => b && x.csv: crlf \
             | 2 | line 3\\n | clear | open: later\n",
        );
        assert_eq!(cases.len(), 1);
        let case = &cases[0];
        assert_eq!(case.line, 3);
        assert_eq!(case.args, ["identify", "--model", "my m.yaml", ""]);
        assert_eq!(case.edits, ["m.yaml: a => b", "x.csv: crlf"]);
        assert_eq!((case.exit, case.message.as_str()), (2, "line 3\n"));
        assert_eq!(case.open(), Some("later"));
        assert_eq!(unescape("\\u{feff}x\\ty"), "\u{feff}x\ty");
    }
}
