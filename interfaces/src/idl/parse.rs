//! XML to a small element tree with positions, then to the raw definitions that
//! validation resolves. Structure errors (unknown elements or attributes, missing
//! attributes, malformed XML) are found here; meaning errors in `validate`.

use std::path::Path;

use quick_xml::events::Event;
use quick_xml::reader::Reader;

use super::diagnostic::{Diagnostic, Position, closest};

/// Nesting deeper than any valid definition: refused before it costs stack or memory.
const MAX_DEPTH: usize = 16;

/// An attribute value and where it was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Spanned {
    pub value: String,
    pub position: Position,
}

/// One `<data>`, `<field>` or `<arg>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawField {
    pub name: Spanned,
    pub ty: Spanned,
    pub array_size: Option<Spanned>,
    pub unit: Option<String>,
    pub description: Option<String>,
    pub values: Vec<RawValue>,
}

/// One `<value>` of a String field: a word the field may hold.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawValue {
    pub name: Spanned,
    pub description: Option<String>,
}

/// One `<primitive>` of a type library.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawPrimitive {
    pub name: Spanned,
    pub ros2: Spanned,
}

/// One `<struct>` of a type library.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawStruct {
    pub name: Spanned,
    pub description: Option<String>,
    pub fields: Vec<RawField>,
    pub position: Position,
}

/// A `<types>` document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawTypes {
    pub version: Spanned,
    pub primitives: Vec<RawPrimitive>,
    pub structs: Vec<RawStruct>,
}

/// One `<command>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawCommand {
    pub name: Spanned,
    pub description: Option<String>,
    pub args: Vec<RawField>,
    pub reply: Vec<RawField>,
}

/// An `<interface>` document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct RawInterface {
    pub name: Spanned,
    pub version: Spanned,
    pub description: Option<String>,
    pub types_file: Option<Spanned>,
    pub publish: Vec<RawField>,
    pub commands: Vec<RawCommand>,
    pub position: Position,
}

/// What a file holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum RawDocument {
    Types(RawTypes),
    Interface(RawInterface),
}

#[derive(Debug)]
struct Attr {
    name: String,
    value: String,
    position: Position,
}

#[derive(Debug)]
struct Element {
    name: String,
    position: Position,
    attrs: Vec<Attr>,
    children: Vec<Element>,
    text: String,
}

/// Parses one definition file.
pub(super) fn parse_document(source: &str, file: &Path) -> Result<RawDocument, Diagnostic> {
    let root = build_tree(source, file)?;
    let cx = Cx { file };
    match root.name.as_str() {
        "interface" => cx.interface(&root).map(RawDocument::Interface),
        "types" => cx.types(&root).map(RawDocument::Types),
        other => Err(cx
            .error(root.position, format!("unknown root element `<{other}>`"))
            .with_hint("a definition file holds one `<interface>` or one `<types>` element")),
    }
}

fn build_tree(source: &str, file: &Path) -> Result<Element, Diagnostic> {
    let mut reader = Reader::from_str(source);
    reader.config_mut().check_end_names = true;
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let xml_error = |reader: &Reader<&[u8]>, err: &dyn std::fmt::Display| {
        let offset = usize::try_from(reader.error_position()).unwrap_or(usize::MAX);
        Diagnostic::error(
            file,
            Position::of_offset(source, offset),
            format!("malformed XML: {err}"),
        )
    };
    loop {
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(err) => return Err(xml_error(&reader, &err)),
        };
        let end = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
        match event {
            Event::Start(start) | Event::Empty(start) => {
                let is_empty = source.get(..end).is_some_and(|s| s.ends_with("/>"));
                let tag_len = start.len() + if is_empty { 3 } else { 2 };
                let tag_start = end.saturating_sub(tag_len);
                let element = element_of(source, file, &start, tag_start)?;
                if root.is_some() && stack.is_empty() {
                    return Err(Diagnostic::error(
                        file,
                        element.position,
                        format!("a second root element `<{}>`", element.name),
                    )
                    .with_hint("a definition file holds exactly one root element"));
                }
                if stack.len() >= MAX_DEPTH {
                    return Err(Diagnostic::error(
                        file,
                        element.position,
                        format!("elements nested more than {MAX_DEPTH} deep"),
                    ));
                }
                if is_empty {
                    attach(&mut stack, &mut root, element);
                } else {
                    stack.push(element);
                }
            }
            Event::End(_) => {
                if let Some(done) = stack.pop() {
                    attach(&mut stack, &mut root, done);
                }
            }
            Event::Text(text) => {
                let content = text.xml10_content();
                push_text(&mut stack, source, file, end, &content)?;
            }
            Event::CData(cdata) => {
                let content = cdata.xml10_content();
                push_text(&mut stack, source, file, end, &content)?;
            }
            Event::GeneralRef(reference) => {
                let resolved = match reference.resolve_char_ref() {
                    Ok(Some(c)) => c.to_string(),
                    Ok(None) => match &*reference {
                        "lt" => "<".to_owned(),
                        "gt" => ">".to_owned(),
                        "amp" => "&".to_owned(),
                        "quot" => "\"".to_owned(),
                        "apos" => "'".to_owned(),
                        other => {
                            return Err(Diagnostic::error(
                                file,
                                Position::of_offset(source, end),
                                format!("unknown entity `&{other};`"),
                            ));
                        }
                    },
                    Err(err) => return Err(xml_error(&reader, &err)),
                };
                push_text(&mut stack, source, file, end, &resolved)?;
            }
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(Diagnostic::error(
            file,
            open.position,
            format!("`<{}>` is never closed", open.name),
        ));
    }
    root.ok_or_else(|| {
        Diagnostic::error(
            file,
            Position::of_offset(source, source.len()),
            "no root element",
        )
        .with_hint("a definition file holds one `<interface>` or one `<types>` element")
    })
}

fn attach(stack: &mut [Element], root: &mut Option<Element>, element: Element) {
    match stack.last_mut() {
        Some(parent) => parent.children.push(element),
        None => *root = Some(element),
    }
}

fn push_text(
    stack: &mut [Element],
    source: &str,
    file: &Path,
    end: usize,
    text: &str,
) -> Result<(), Diagnostic> {
    match stack.last_mut() {
        Some(parent) => parent.text.push_str(text),
        None if text.trim().is_empty() => {}
        None => {
            return Err(Diagnostic::error(
                file,
                Position::of_offset(source, end.saturating_sub(text.len())),
                "text outside the root element",
            ));
        }
    }
    Ok(())
}

fn element_of(
    source: &str,
    file: &Path,
    start: &quick_xml::events::BytesStart<'_>,
    tag_start: usize,
) -> Result<Element, Diagnostic> {
    let position = Position::of_offset(source, tag_start);
    let name = start.name().as_ref().to_owned();
    let raw_tag = source.get(tag_start..).unwrap_or("");
    let mut cursor = 1 + name.len();
    let mut attrs = Vec::new();
    for attr in start.attributes() {
        let attr = attr.map_err(|err| {
            Diagnostic::error(
                file,
                position,
                format!("malformed attribute in `<{name}>`: {err}"),
            )
        })?;
        let key = attr.key.as_ref().to_owned();
        let value = attr
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| {
                Diagnostic::error(
                    file,
                    position,
                    format!("bad value of `{key}` in `<{name}>`: {err}"),
                )
            })?
            .into_owned();
        let offset = match find_attribute(raw_tag, cursor, &key) {
            Some(at) => {
                cursor = at + key.len();
                tag_start + at
            }
            None => tag_start,
        };
        attrs.push(Attr {
            name: key,
            value,
            position: Position::of_offset(source, offset),
        });
    }
    Ok(Element {
        name,
        position,
        attrs,
        children: Vec::new(),
        text: String::new(),
    })
}

/// Interpretation of the tree, with the file for diagnostics.
struct Cx<'a> {
    file: &'a Path,
}

impl Cx<'_> {
    fn error(&self, position: Position, message: impl Into<String>) -> Diagnostic {
        Diagnostic::error(self.file, position, message)
    }

    /// Checks that `element` has only `allowed` attributes and every one of `required`.
    fn attributes(
        &self,
        element: &Element,
        allowed: &[&str],
        required: &[&str],
    ) -> Result<(), Diagnostic> {
        for (i, attr) in element.attrs.iter().enumerate() {
            if !allowed.contains(&attr.name.as_str()) {
                let mut d = self.error(
                    attr.position,
                    format!("unknown attribute `{}` on `<{}>`", attr.name, element.name),
                );
                d = match closest(&attr.name, allowed.iter().copied()) {
                    Some(near) => d.with_hint(format!("did you mean `{near}`?")),
                    None => d.with_hint(format!("`<{}>` takes {}", element.name, list(allowed))),
                };
                return Err(d);
            }
            if element.attrs[..i].iter().any(|a| a.name == attr.name) {
                return Err(self.error(
                    attr.position,
                    format!(
                        "attribute `{}` given twice on `<{}>`",
                        attr.name, element.name
                    ),
                ));
            }
        }
        for name in required {
            if !element.attrs.iter().any(|a| a.name == *name) {
                return Err(self.error(
                    element.position,
                    format!("`<{}>` needs a `{name}` attribute", element.name),
                ));
            }
        }
        Ok(())
    }

    fn no_text(&self, element: &Element) -> Result<(), Diagnostic> {
        if element.text.trim().is_empty() {
            Ok(())
        } else {
            Err(self
                .error(
                    element.position,
                    format!(
                        "`<{}>` holds text; only elements belong there",
                        element.name
                    ),
                )
                .with_hint("put prose in a `<description>` or `<comment>` element"))
        }
    }

    fn unknown_child(&self, parent: &Element, child: &Element, allowed: &[&str]) -> Diagnostic {
        let d = self.error(
            child.position,
            format!("unknown element `<{}>` in `<{}>`", child.name, parent.name),
        );
        match closest(&child.name, allowed.iter().copied()) {
            Some(near) => d.with_hint(format!("did you mean `<{near}>`?")),
            None => d.with_hint(format!("`<{}>` holds {}", parent.name, list(allowed))),
        }
    }

    fn prose(&self, element: &Element) -> Result<String, Diagnostic> {
        self.attributes(element, &[], &[])?;
        if let Some(child) = element.children.first() {
            return Err(self.error(
                child.position,
                format!(
                    "`<{}>` inside `<{}>`: it holds only text",
                    child.name, element.name
                ),
            ));
        }
        Ok(tidy(&element.text))
    }

    fn types(&self, root: &Element) -> Result<RawTypes, Diagnostic> {
        self.attributes(root, &["version"], &["version"])?;
        self.no_text(root)?;
        let mut primitives = Vec::new();
        let mut structs = Vec::new();
        let allowed = ["description", "comment", "primitive", "struct"];
        for child in &root.children {
            match child.name.as_str() {
                "description" | "comment" => {
                    self.prose(child)?;
                }
                "primitive" => {
                    self.attributes(child, &["name", "ros2"], &["name", "ros2"])?;
                    self.leaf(child)?;
                    primitives.push(RawPrimitive {
                        name: attr(child, "name"),
                        ros2: attr(child, "ros2"),
                    });
                }
                "struct" => structs.push(self.structure(child)?),
                _ => return Err(self.unknown_child(root, child, &allowed)),
            }
        }
        Ok(RawTypes {
            version: attr(root, "version"),
            primitives,
            structs,
        })
    }

    fn structure(&self, element: &Element) -> Result<RawStruct, Diagnostic> {
        self.attributes(element, &["name"], &["name"])?;
        self.no_text(element)?;
        let mut description = None;
        let mut fields = Vec::new();
        for child in &element.children {
            match child.name.as_str() {
                "description" => description = Some(self.prose(child)?),
                "comment" => {
                    self.prose(child)?;
                }
                "field" => fields.push(self.field(child)?),
                _ => {
                    return Err(self.unknown_child(
                        element,
                        child,
                        &["description", "comment", "field"],
                    ));
                }
            }
        }
        Ok(RawStruct {
            name: attr(element, "name"),
            description,
            fields,
            position: element.position,
        })
    }

    fn leaf(&self, element: &Element) -> Result<(), Diagnostic> {
        self.no_text(element)?;
        match element.children.first() {
            Some(child) => Err(self.error(
                child.position,
                format!(
                    "`<{}>` inside `<{}>`, which holds nothing",
                    child.name, element.name
                ),
            )),
            None => Ok(()),
        }
    }

    fn field(&self, element: &Element) -> Result<RawField, Diagnostic> {
        self.attributes(
            element,
            &["name", "type", "array_size", "unit", "description"],
            &["name", "type"],
        )?;
        self.no_text(element)?;
        let mut values = Vec::new();
        for child in &element.children {
            match child.name.as_str() {
                "value" => {
                    self.attributes(child, &["name", "description"], &["name"])?;
                    self.leaf(child)?;
                    values.push(RawValue {
                        name: attr(child, "name"),
                        description: opt_attr(child, "description").map(|s| s.value),
                    });
                }
                "comment" => {
                    self.prose(child)?;
                }
                _ => return Err(self.unknown_child(element, child, &["value", "comment"])),
            }
        }
        Ok(RawField {
            name: attr(element, "name"),
            ty: attr(element, "type"),
            array_size: opt_attr(element, "array_size"),
            unit: opt_attr(element, "unit").map(|s| s.value),
            description: opt_attr(element, "description").map(|s| s.value),
            values,
        })
    }

    fn fields(&self, element: &Element, tag: &str) -> Result<Vec<RawField>, Diagnostic> {
        self.attributes(element, &[], &[])?;
        self.no_text(element)?;
        let mut fields = Vec::new();
        for child in &element.children {
            if child.name == tag {
                fields.push(self.field(child)?);
            } else if child.name == "comment" {
                self.prose(child)?;
            } else {
                return Err(self.unknown_child(element, child, &[tag, "comment"]));
            }
        }
        Ok(fields)
    }

    fn interface(&self, root: &Element) -> Result<RawInterface, Diagnostic> {
        self.attributes(root, &["name", "version"], &["name", "version"])?;
        self.no_text(root)?;
        let mut description: Vec<String> = Vec::new();
        let mut types_file = None;
        let mut publish: Option<Vec<RawField>> = None;
        let mut commands = Vec::new();
        let allowed = ["description", "comment", "types", "publish", "command"];
        for child in &root.children {
            match child.name.as_str() {
                "description" | "comment" => description.push(self.prose(child)?),
                "types" => {
                    if types_file.is_some() {
                        return Err(self.error(child.position, "a second `<types>` element"));
                    }
                    self.attributes(child, &["filename"], &["filename"])?;
                    self.leaf(child)?;
                    types_file = Some(attr(child, "filename"));
                }
                "publish" => {
                    if publish.is_some() {
                        return Err(self
                            .error(child.position, "a second `<publish>` element")
                            .with_hint("an interface publishes one sample type: put every `<data>` in one `<publish>`"));
                    }
                    publish = Some(self.fields(child, "data")?);
                }
                "command" => commands.push(self.command(child)?),
                _ => return Err(self.unknown_child(root, child, &allowed)),
            }
        }
        let description: Vec<String> = description.into_iter().filter(|d| !d.is_empty()).collect();
        Ok(RawInterface {
            name: attr(root, "name"),
            version: attr(root, "version"),
            description: (!description.is_empty()).then(|| description.join("\n\n")),
            types_file,
            publish: publish.unwrap_or_default(),
            commands,
            position: root.position,
        })
    }

    fn command(&self, element: &Element) -> Result<RawCommand, Diagnostic> {
        self.attributes(element, &["name"], &["name"])?;
        self.no_text(element)?;
        let mut description = None;
        let mut args = Vec::new();
        let mut reply: Option<Vec<RawField>> = None;
        for child in &element.children {
            match child.name.as_str() {
                "description" => description = Some(self.prose(child)?),
                "comment" => {
                    self.prose(child)?;
                }
                "arg" => args.push(self.field(child)?),
                "reply" => {
                    if reply.is_some() {
                        return Err(self.error(child.position, "a second `<reply>` element"));
                    }
                    reply = Some(self.fields(child, "data")?);
                }
                _ => {
                    return Err(self.unknown_child(
                        element,
                        child,
                        &["description", "comment", "arg", "reply"],
                    ));
                }
            }
        }
        Ok(RawCommand {
            name: attr(element, "name"),
            description,
            args,
            reply: reply.unwrap_or_default(),
        })
    }
}

/// The byte offset in `tag` of attribute `key` at or after `from`: the key preceded by
/// white space and followed by `=` (so a value that contains the key does not match).
fn find_attribute(tag: &str, from: usize, key: &str) -> Option<usize> {
    let mut from = from;
    while let Some(rel) = tag.get(from..)?.find(key) {
        let at = from + rel;
        let before_ok = tag
            .get(..at)
            .and_then(|b| b.chars().next_back())
            .is_some_and(char::is_whitespace);
        let after_ok = tag
            .get(at + key.len()..)
            .and_then(|a| a.trim_start().chars().next())
            == Some('=');
        if before_ok && after_ok {
            return Some(at);
        }
        from = at + key.len();
    }
    None
}

fn attr(element: &Element, name: &str) -> Spanned {
    opt_attr(element, name).unwrap_or(Spanned {
        value: String::new(),
        position: element.position,
    })
}

fn opt_attr(element: &Element, name: &str) -> Option<Spanned> {
    element
        .attrs
        .iter()
        .find(|a| a.name == name)
        .map(|a| Spanned {
            value: a.value.clone(),
            position: a.position,
        })
}

fn list(names: &[&str]) -> String {
    if names.is_empty() {
        return "nothing".to_owned();
    }
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Prose as written, without the indentation of the XML around it.
fn tidy(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .collect::<Vec<_>>()
        .join("\n")
        .trim()
        .to_owned()
}
