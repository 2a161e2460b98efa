//! The streaming pre-scan of a URDF (quick-xml), before urdf-rs reads it: the XML is
//! well-formed, nests at most [`MAX_XML_DEPTH`] elements, has a `<robot>` root, and each
//! `<joint>` is one urdf-rs reads as written. urdf-rs reports a missing attribute or a bad
//! number without a line or a joint, and silently ignores what it does not know: a misspelt
//! `<orign>` or `xzy=` gave a zero origin, found much later as a home configuration that does
//! not close. Records where each `<link>` and `<joint>` is declared.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

/// Deepest element nesting accepted. A URDF nests a handful of levels
/// (`robot/link/visual/geometry/mesh`); urdf-rs parses recursively, so an absurdly deep
/// document would overflow the stack instead of failing.
pub const MAX_XML_DEPTH: usize = 100;

/// Largest magnitude of a joint origin's component (metres, radians), as in the model file.
const MAX_MAGNITUDE: f64 = 1e6;

/// The elements a `<joint>` may hold (the URDF specification's).
const JOINT_ELEMENTS: [&str; 9] = [
    "origin",
    "parent",
    "child",
    "axis",
    "limit",
    "calibration",
    "dynamics",
    "mimic",
    "safety_controller",
];

/// The joint types urdf-rs reads (legwise's chains take the first four).
const JOINT_TYPES: [&str; 7] = [
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
];

/// A `<link>` or `<joint>` child of `<robot>`: its name and line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Declaration {
    pub(super) name: String,
    pub(super) line: usize,
}

/// Where the links and joints are declared, in document order.
#[derive(Debug, Default)]
pub(super) struct Declarations {
    pub(super) links: Vec<Declaration>,
    pub(super) joints: Vec<Declaration>,
    /// The moving joints without an `<axis>` element (urdf-rs gives them the axis x).
    pub(super) implicit_axes: Vec<String>,
}

/// The `<joint>` being read: its name, line, whether it moves, and whether it named its links
/// and its axis.
struct OpenJoint {
    name: String,
    line: usize,
    moving: bool,
    parent: bool,
    child: bool,
    axis: bool,
}

impl OpenJoint {
    /// A joint read to its end must have named its parent and child links; a moving one
    /// without an axis is noted in `declarations`.
    fn close(self, declarations: &mut Declarations) -> Result<(), String> {
        if self.moving && !self.axis {
            declarations.implicit_axes.push(self.name.clone());
        }
        for (role, given) in [("parent", self.parent), ("child", self.child)] {
            if !given {
                return Err(format!(
                    "line {}: joint `{}` has no <{role} link=\"…\"/>; every joint names its \
                     parent and child links",
                    self.line, self.name
                ));
            }
        }
        Ok(())
    }
}

/// 1-based line numbers of increasing byte offsets, counted incrementally (linear in the text,
/// however many elements it holds).
struct Lines<'a> {
    text: &'a [u8],
    offset: usize,
    line: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        Self {
            text: text.as_bytes(),
            offset: 0,
            line: 1,
        }
    }

    /// The line of byte `position` (positions before the last one asked give that one's line).
    fn at(&mut self, position: u64) -> usize {
        let end = usize::try_from(position)
            .unwrap_or(usize::MAX)
            .min(self.text.len());
        if end > self.offset {
            self.line += self.text[self.offset..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            self.offset = end;
        }
        self.line
    }
}

/// Streams through the XML once (see the module's documentation).
pub(super) fn scan(text: &str) -> Result<Declarations, String> {
    let mut reader = Reader::from_str(text);
    let mut lines = Lines::new(text);
    let mut depth = 0usize;
    let mut declarations = Declarations::default();
    let mut root = false;
    let mut joint: Option<OpenJoint> = None;
    loop {
        let start = reader.buffer_position();
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(err) => {
                let line = lines.at(reader.error_position());
                return Err(format!("line {line}: not well-formed XML: {err}"));
            }
        };
        match event {
            Event::Start(ref element) | Event::Empty(ref element) => {
                let line = lines.at(start);
                let name = String::from_utf8_lossy(element.name().as_ref()).into_owned();
                if depth >= MAX_XML_DEPTH {
                    return Err(format!(
                        "line {line}: element <{name}> is nested {} levels deep; at most \
                         {MAX_XML_DEPTH} are accepted (a URDF needs fewer than 10)",
                        depth + 1
                    ));
                }
                let empty = matches!(event, Event::Empty(_));
                if depth == 0 {
                    let what = match root {
                        true => format!("a second top-level element <{name}> after </robot>"),
                        false if name != "robot" => format!("the top-level element is <{name}>"),
                        false => String::new(),
                    };
                    if !what.is_empty() {
                        return Err(format!(
                            "line {line}: {what}; expected one <robot> element holding the \
                             links and joints (a URDF)"
                        ));
                    }
                    root = true;
                }
                if depth == 1 && name == "joint" {
                    let open = open_joint(element, line)?;
                    match empty {
                        true => open.close(&mut declarations)?,
                        false => joint = Some(open),
                    }
                }
                if let (2, Some(open)) = (depth, joint.as_mut()) {
                    joint_element(element, &name, line, open)?;
                }
                record(element, depth, line, &mut declarations)?;
                if !empty {
                    depth += 1;
                }
            }
            Event::End(_) => {
                depth = depth.saturating_sub(1);
                if depth == 1 {
                    if let Some(open) = joint.take() {
                        open.close(&mut declarations)?;
                    }
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if depth > 0 {
        return Err(format!(
            "line {}: not well-formed XML: {depth} element(s) not closed at the end of the file",
            lines.at(text.len() as u64)
        ));
    }
    if !root {
        return Err(
            match text.trim_start_matches('\u{feff}').trim().is_empty() {
                true => {
                    "the file is empty; expected a URDF: a <robot> element holding the links and \
                     joints"
                        .into()
                }
                false => "no XML element in the file; expected a URDF: a <robot> element holding \
                      the links and joints"
                    .into(),
            },
        );
    }
    Ok(declarations)
}

/// A `<joint>` element's name and type, checked.
fn open_joint(element: &BytesStart<'_>, line: usize) -> Result<OpenJoint, String> {
    let name = attribute(element, "name", line)?
        .ok_or_else(|| format!("line {line}: a <joint> without a name attribute"))?;
    let kind = attribute(element, "type", line)?.ok_or_else(|| {
        format!(
            "line {line}: joint `{name}` has no type attribute; expected revolute, continuous, \
             prismatic or fixed"
        )
    })?;
    if !JOINT_TYPES.contains(&kind.as_str()) {
        return Err(format!(
            "line {line}: joint `{name}` has type `{kind}`; expected revolute, continuous, \
             prismatic or fixed"
        ));
    }
    Ok(OpenJoint {
        name,
        line,
        moving: ["revolute", "continuous", "prismatic"].contains(&kind.as_str()),
        parent: false,
        child: false,
        axis: false,
    })
}

/// An element of `<joint>` (`name`, on `line`): one the URDF defines, with the attributes
/// urdf-rs reads and numbers where it reads numbers.
fn joint_element(
    element: &BytesStart<'_>,
    name: &str,
    line: usize,
    joint: &mut OpenJoint,
) -> Result<(), String> {
    let at = format!("line {line}: joint `{}`", joint.name);
    if !JOINT_ELEMENTS.contains(&name) {
        return Err(format!(
            "{at}: unknown element <{name}>; expected one of {}",
            JOINT_ELEMENTS.join(", ")
        ));
    }
    let (allowed, vectors, numbers): (&[&str], &[&str], &[&str]) = match name {
        "origin" => (&["xyz", "rpy"], &["xyz", "rpy"], &[]),
        "axis" => (&["xyz"], &["xyz"], &[]),
        "limit" => (
            &["lower", "upper", "effort", "velocity"],
            &[],
            &["lower", "upper", "effort", "velocity"],
        ),
        "parent" | "child" => (&["link"], &[], &[]),
        _ => return Ok(()),
    };
    joint.parent |= name == "parent";
    joint.child |= name == "child";
    joint.axis |= name == "axis";
    for item in element.attributes() {
        let item = item.map_err(|err| format!("line {line}: not well-formed XML: {err}"))?;
        let key = String::from_utf8_lossy(item.key.as_ref()).into_owned();
        if !allowed.contains(&key.as_str()) {
            return Err(format!(
                "{at}: <{name}> has an unknown attribute `{key}`; expected {}",
                allowed.join(", ")
            ));
        }
        let value = item
            .unescape_value()
            .map_err(|err| format!("line {line}: not well-formed XML: {err}"))?;
        let found = || format!("<{name} {key}=\"{value}\">");
        if vectors.contains(&key.as_str()) {
            let parts: Vec<Option<f64>> =
                value.split_whitespace().map(|v| v.parse().ok()).collect();
            if parts.len() != 3 || parts.iter().any(Option::is_none) {
                return Err(format!(
                    "{at}: {}: expected three numbers separated by spaces",
                    found()
                ));
            }
            if let Some(v) = parts.iter().flatten().find(|v| v.abs() > MAX_MAGNITUDE) {
                return Err(format!(
                    "{at}: {}: {v:e} is not a plausible value; legwise reads metres and \
                     radians, and expects magnitudes up to {MAX_MAGNITUDE:e}",
                    found()
                ));
            }
        }
        if numbers.contains(&key.as_str()) && value.trim().parse::<f64>().is_err() {
            return Err(format!("{at}: {}: expected a number", found()));
        }
    }
    Ok(())
}

/// The value of attribute `key` of `element`, if any.
fn attribute(element: &BytesStart<'_>, key: &str, line: usize) -> Result<Option<String>, String> {
    element
        .try_get_attribute(key)
        .map_err(|err| format!("line {line}: not well-formed XML: {err}"))?
        .map(|attribute| attribute.unescape_value().map(|v| v.into_owned()))
        .transpose()
        .map_err(|err| format!("line {line}: not well-formed XML: {err}"))
}

/// Records a `<link>` or `<joint>` child of the root element (at `depth` 1) with its line.
fn record(
    element: &BytesStart<'_>,
    depth: usize,
    line: usize,
    declarations: &mut Declarations,
) -> Result<(), String> {
    let list = match (depth, element.name().as_ref()) {
        (1, b"link") => &mut declarations.links,
        (1, b"joint") => &mut declarations.joints,
        _ => return Ok(()),
    };
    if let Some(name) = attribute(element, "name", line)? {
        list.push(Declaration { name, line });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::scan;

    fn joint(inner: &str) -> String {
        format!(
            "<robot name=\"r\">\n<link name=\"a\"/><link name=\"b\"/>\n<joint name=\"J\" \
             type=\"revolute\">\n{inner}\n</joint>\n</robot>\n"
        )
    }

    #[test]
    fn a_joint_is_read_as_written_or_refused_with_its_line() {
        let links = "<parent link=\"a\"/><child link=\"b\"/>";
        assert!(scan(&joint(links)).is_ok());
        let misspelt = joint(&format!("{links}<orign xyz=\"1 0 0\"/>"));
        assert_eq!(
            scan(&misspelt).unwrap_err(),
            "line 4: joint `J`: unknown element <orign>; expected one of origin, parent, child, \
             axis, limit, calibration, dynamics, mimic, safety_controller"
        );
        let bad_number = joint(&format!("{links}<origin xyz=\"0.75m 0 0\"/>"));
        assert_eq!(
            scan(&bad_number).unwrap_err(),
            "line 4: joint `J`: <origin xyz=\"0.75m 0 0\">: expected three numbers separated by \
             spaces"
        );
        assert!(scan(&joint("<parent link=\"a\"/>"))
            .unwrap_err()
            .contains("joint `J` has no <child link="));
    }

    #[test]
    fn the_document_is_one_robot() {
        assert!(scan("").unwrap_err().starts_with("the file is empty"));
        assert!(scan("{\"robot\": 1}")
            .unwrap_err()
            .starts_with("no XML element"));
        assert_eq!(
            scan("<robt name=\"r\"></robt>").unwrap_err(),
            "line 1: the top-level element is <robt>; expected one <robot> element holding the \
             links and joints (a URDF)"
        );
    }
}
