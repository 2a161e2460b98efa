//! clap's usage errors on one line, as the command line prints them after `legwise:` and the
//! in-memory entries (the Python module) raise them.

use clap::error::ErrorKind;
use clap::CommandFactory;

use super::args::Cli;

/// clap's usage error `err` on one line: its message, the possible values and its tip, then
/// where the usage is shown (`legwise COMMAND --help`) in place of clap's usage block.
/// `words` are the command line's words after the program's name (the command first).
pub fn usage_line(err: &clap::Error, words: &[String]) -> String {
    let command = command_name(words);
    if let Some(word) = single_dash_word(words).filter(|_| err.kind() == ErrorKind::UnknownArgument)
    {
        return format!(
            "unexpected argument `{word}`: long options take two dashes (`-{word}`); see \
             `{command} --help`"
        );
    }
    let text = err.render().to_string();
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let first = lines.next().unwrap_or("invalid usage");
    let mut line = first.strip_prefix("error: ").unwrap_or(first).to_string();
    for extra in lines {
        if let Some(values) = extra.strip_prefix('[').and_then(|v| v.strip_suffix(']')) {
            line.push_str(&format!(" ({values})"));
        } else if let Some(tip) = extra.strip_prefix("tip: ") {
            line.push_str(&format!("; {tip}"));
        } else if !extra.starts_with("Usage: ") && !extra.starts_with("For more information") {
            line.push_str(&format!(" {extra}"));
        }
    }
    format!("{line}; see `{command} --help`")
}

/// The first word that looks like a long option typed with one dash (`-model`), which clap
/// reads as the short options `-m -o -d …`.
fn single_dash_word(words: &[String]) -> Option<String> {
    words
        .iter()
        .find(|word| {
            word.strip_prefix('-').is_some_and(|rest| {
                rest.len() > 1
                    && rest.starts_with(|c: char| c.is_ascii_lowercase())
                    && rest.chars().all(|c| c.is_ascii_lowercase() || c == '-')
            })
        })
        .cloned()
}

/// `legwise` and the command `words` name first, if it is one.
pub fn command_name(words: &[String]) -> String {
    let given = words.first().map(String::as_str).unwrap_or_default();
    let known = Cli::command();
    let sub = known.get_subcommands().find(|c| c.get_name() == given);
    match sub {
        Some(sub) => format!("legwise {}", sub.get_name()),
        None => "legwise".to_string(),
    }
}
