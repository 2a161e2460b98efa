//! The YAML parser's messages in a model file's words: the field an error is in, what was
//! expected and what was found there (`line 10 column 13: home.pose.x: expected a number,
//! found `abc``), without the parser's jargon (`expected mapping start`) or its advice to the
//! programmer (`set DuplicateKeyPolicy in Options`).

/// The message for a model file holding nothing but blank lines and comments.
pub(super) const EMPTY: &str = "the file is empty (only blank lines or comments); expected a \
    model: the fields name, urdf, measured, home, legs, parameters and workspace \
    (docs/models.md)";

/// True when `text` holds nothing but blank lines and comments (and perhaps a byte-order mark).
pub(super) fn is_empty(text: &str) -> bool {
    text.trim_start_matches('\u{feff}').lines().all(|line| {
        let line = line.trim();
        line.is_empty() || line.starts_with('#')
    })
}

/// The parser's one-line message `line L column C: MESSAGE` with the field it is in and, for a
/// value of the wrong type, what was expected in words and the value found at that place.
pub(super) fn located(message: &str, field: &str, text: &str) -> String {
    let Some((place, what)) = message
        .split_once(": ")
        .filter(|(p, _)| p.starts_with("line "))
    else {
        return message.to_string();
    };
    // The field, when the parser got into one (not for a syntax error: `legs[0].?`); an
    // unknown field is named by the message, so its place is the field holding it.
    let field = match what.starts_with("unknown field") {
        true => field.rsplit_once('.').map_or("", |(parent, _)| parent),
        false => field,
    };
    let hint = decimal_comma_hint(field);
    let field = match field {
        "" | "." => String::new(),
        field if field.contains('?') => String::new(),
        field => format!("{field}: "),
    };
    let found = place
        .strip_prefix("line ")
        .and_then(|rest| rest.split_once(" column "))
        .and_then(|(l, c)| Some((l.parse::<usize>().ok()?, c.parse::<usize>().ok()?)))
        .and_then(|(line, column)| value_at(text, line, column));
    if let Some(plain) = plain_words(what, found.as_deref()) {
        return format!("{place}: {field}{plain}");
    }
    let expected = [
        ("floating point", "expected a number"),
        ("integer", "expected a whole number"),
        ("u64", "expected a whole number"),
        ("usize", "expected a whole number"),
        ("bool", "expected true or false"),
        ("string scalar", "expected a single value"),
    ]
    .into_iter()
    .find_map(|(said, meant)| what.contains(said).then_some(meant));
    let Some(expected) = expected else {
        return format!("{place}: {field}{what}");
    };
    match found {
        Some(found) if !hint.is_empty() => {
            format!("{place}: {field}{expected}, found {found}{hint}")
        }
        // A negative count or seed: say which whole numbers are meant.
        Some(found) if expected.contains("whole") && found.starts_with("`-") => {
            format!("{place}: {field}expected a whole number from 0 up, found {found}")
        }
        // A number where a real number is expected: the value runs on past the line, which an
        // unclosed flow collection does (`{x: 0.0, y: 1.0` and no `}`).
        Some(found) if expected == "expected a number" && is_number(&found) => format!(
            "{place}: {field}{expected}, found {found} followed by more on the next lines: an \
             unclosed `{{` or `[` on this line?"
        ),
        Some(found) => format!("{place}: {field}{expected}, found {found}"),
        None => format!("{place}: {field}{expected}{hint}"),
    }
}

/// The parser's structural messages in words, with the value `found` at the error's place.
fn plain_words(what: &str, found: Option<&str>) -> Option<String> {
    let found = found.unwrap_or("something else");
    if what.starts_with("expected mapping start") {
        return Some(format!(
            "expected a mapping (`key: value` lines, or `{{key: value, …}}`), found {found}"
        ));
    }
    if what.starts_with("expected sequence start") {
        return Some(format!(
            "expected a list (`[a, b, …]`, or `- a` lines), found {found}"
        ));
    }
    if let Some(rest) = what.strip_prefix("duplicate mapping key: ") {
        let key = rest.split(',').next().unwrap_or(rest).trim();
        return Some(format!(
            "the key `{key}` appears twice in the same mapping; give each key once"
        ));
    }
    if what.starts_with("multiple YAML documents") {
        return Some(
            "a second YAML document starts here (after a `---` line); a model file holds one \
             model"
                .into(),
        );
    }
    if what.starts_with("cannot deserialize null") {
        return Some("expected a value, found nothing (an empty value or `~`)".into());
    }
    if what.starts_with("expected end of mapping after enum variant") {
        return Some(
            "expected one kind (a single key, such as `disc:`), found another key after it".into(),
        );
    }
    None
}

/// For a mapping key that is a number (`home.pose.0`), which a decimal comma makes of
/// `{x: 0,5}`: a hint to write a point.
fn decimal_comma_hint(field: &str) -> &'static str {
    let last = field.rsplit('.').next().unwrap_or_default();
    match !last.is_empty() && last.chars().all(|c| c.is_ascii_digit()) {
        true => " (a decimal comma? numbers take a point, 0.5, and a comma separates values)",
        false => "",
    }
}

/// True for `` `NUMBER` ``.
fn is_number(found: &str) -> bool {
    found
        .strip_prefix('`')
        .and_then(|f| f.strip_suffix('`'))
        .is_some_and(|f| f.parse::<f64>().is_ok())
}

/// The YAML value starting at `line`, `column` (both from 1) of `text`, in words: `` `abc` ``,
/// `a list`, `a mapping` or `nothing`. A place at the colon after a key stands for the value
/// that follows it.
fn value_at(text: &str, line: usize, column: usize) -> Option<String> {
    let rest: String = text
        .lines()
        .nth(line.checked_sub(1)?)?
        .chars()
        .skip(column.checked_sub(1)?)
        .collect();
    let rest = rest.trim_start();
    let rest = rest.strip_prefix(':').unwrap_or(rest).trim_start();
    // A block list item is a dash and a space; `-1` is a number.
    let item = rest == "-" || rest.starts_with("- ") || rest.starts_with("-\t");
    Some(match rest.chars().next() {
        Some('[') => "a list".to_string(),
        Some('-') if item => "a list".to_string(),
        Some('{') => "a mapping".to_string(),
        _ => {
            let end = rest.find([',', '}', ']', '#']).unwrap_or(rest.len());
            match rest[..end].trim() {
                "" => "nothing".to_string(),
                value => format!("`{value}`"),
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_named_by_what_they_look_like() {
        let text = "a: [1, 2]\nb: - 1\nc: -1\nd: {x: 1}\ne:\nf: abc # note\n";
        assert_eq!(value_at(text, 1, 4).as_deref(), Some("a list"));
        assert_eq!(value_at(text, 2, 4).as_deref(), Some("a list"));
        assert_eq!(value_at(text, 3, 4).as_deref(), Some("`-1`"));
        assert_eq!(value_at(text, 4, 4).as_deref(), Some("a mapping"));
        assert_eq!(value_at(text, 5, 2).as_deref(), Some("nothing"));
        assert_eq!(value_at(text, 6, 4).as_deref(), Some("`abc`"));
        assert_eq!(value_at(text, 9, 1), None);
    }

    #[test]
    fn the_parsers_jargon_is_reworded() {
        let text = "home:\n  pose: 3\n";
        assert_eq!(
            located("line 2 column 9: expected mapping start", "home.pose", text),
            "line 2 column 9: home.pose: expected a mapping (`key: value` lines, or `{key: \
             value, …}`), found `3`"
        );
        assert_eq!(
            located(
                "line 1 column 1: duplicate mapping key: name, set DuplicateKeyPolicy in \
                 Options if acceptable",
                "",
                "name: a\nname: b\n"
            ),
            "line 1 column 1: the key `name` appears twice in the same mapping; give each key \
             once"
        );
        assert!(is_empty("\u{feff}# a comment\n\n  \n"));
        assert!(!is_empty("# a comment\nname: x\n"));
    }

    #[test]
    fn a_number_key_suggests_a_decimal_comma() {
        assert_eq!(
            located(
                "line 1 column 13: invalid type: null, expected floating point",
                "pose.0",
                "pose: {x: 0,0, y: 1}\n"
            ),
            "line 1 column 13: pose.0: expected a number, found `0` (a decimal comma? numbers \
             take a point, 0.5, and a comma separates values)"
        );
    }
}
