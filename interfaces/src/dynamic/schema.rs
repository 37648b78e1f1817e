//! Parsing a ros2msg schema as MCAP's ros2 profile stores it: the main .msg text, then for
//! each dependency a line of `=` characters, a line `MSG: package/Type` and its .msg text.

use std::collections::{BTreeMap, BTreeSet};

use super::builtin;
use super::error::{SchemaError, SchemaErrorKind};
use super::literal::{comment_start, parse_literal};
use super::types::{
    ArrayKind, BaseType, ConstantDef, FieldDef, FieldType, MessageDefinition, Primitive, TypeName,
    is_identifier,
};

/// A parsed schema: the root message type and every type it refers to.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageSchema {
    schema_name: String,
    root: TypeName,
    definitions: BTreeMap<TypeName, MessageDefinition>,
}

impl MessageSchema {
    /// Parses `text`, the schema data of an MCAP schema record named `schema_name`
    /// (`package/msg/Type`; its package is where unqualified type names of the main text
    /// are looked up).
    pub fn parse(schema_name: &str, text: &str) -> Result<Self, SchemaError> {
        let error = |line: Option<usize>, kind: SchemaErrorKind| SchemaError {
            schema: schema_name.to_owned(),
            line,
            kind,
        };
        let root = TypeName::parse(schema_name.trim())
            .ok_or_else(|| error(None, SchemaErrorKind::InvalidTypeName(schema_name.into())))?;
        let sections = split_sections(&root, text).map_err(|(line, kind)| error(line, kind))?;
        let definitions = Parser::default()
            .run(&root, sections)
            .map_err(|(line, kind)| error(line, kind))?;
        Ok(Self {
            schema_name: schema_name.to_owned(),
            root,
            definitions,
        })
    }

    /// The schema name given to [`MessageSchema::parse`], for messages.
    pub fn schema_name(&self) -> &str {
        &self.schema_name
    }

    /// The name of the message the schema describes.
    pub fn root(&self) -> &TypeName {
        &self.root
    }

    /// The definition of `name`, if the schema has it.
    pub fn definition(&self, name: &TypeName) -> Option<&MessageDefinition> {
        self.definitions.get(name)
    }

    /// Every definition, sorted by name.
    pub fn definitions(&self) -> impl Iterator<Item = &MessageDefinition> {
        self.definitions.values()
    }
}

type Located<T> = Result<T, (Option<usize>, SchemaErrorKind)>;

/// A line of text with its 1-based line number.
type Line<'a> = (usize, &'a str);

struct Section<'a> {
    name: TypeName,
    /// Where the `MSG:` header is (none for the main text and the built-in definitions).
    header_line: Option<usize>,
    /// The text split at `---` lines: one part for a message, more for services and actions.
    parts: Vec<Vec<Line<'a>>>,
}

fn is_separator(line: &str) -> bool {
    let line = line.trim();
    line.len() >= 3 && line.bytes().all(|b| b == b'=')
}

fn split_sections<'a>(root: &TypeName, text: &'a str) -> Located<Vec<Section<'a>>> {
    let mut sections = vec![Section {
        name: root.clone(),
        header_line: None,
        parts: vec![Vec::new()],
    }];
    let mut expecting_header = false;
    for (index, raw) in text.lines().enumerate() {
        let number = index + 1;
        if is_separator(raw) {
            expecting_header = true;
            continue;
        }
        if expecting_header {
            let line = raw.trim();
            if line.is_empty() {
                continue;
            }
            let name = line
                .strip_prefix("MSG:")
                .map(str::trim)
                .and_then(TypeName::parse)
                .ok_or_else(|| {
                    (
                        Some(number),
                        SchemaErrorKind::BadSectionHeader(line.to_owned()),
                    )
                })?;
            sections.push(Section {
                name,
                header_line: Some(number),
                parts: vec![Vec::new()],
            });
            expecting_header = false;
            continue;
        }
        let code = comment_start(raw).map_or(raw, |start| &raw[..start]).trim();
        let Some(section) = sections.last_mut() else {
            continue;
        };
        if code == "---" {
            section.parts.push(Vec::new());
        } else if !code.is_empty()
            && let Some(part) = section.parts.last_mut()
        {
            part.push((number, code));
        }
    }
    Ok(sections)
}

#[derive(Default)]
struct Parser {
    definitions: BTreeMap<TypeName, MessageDefinition>,
    /// Every (referenced type, referring field, line) seen, checked once all are defined.
    references: Vec<(TypeName, String, Option<usize>)>,
}

impl Parser {
    fn run(
        mut self,
        root: &TypeName,
        sections: Vec<Section<'_>>,
    ) -> Located<BTreeMap<TypeName, MessageDefinition>> {
        let mut defined: BTreeSet<TypeName> = sections.iter().map(|s| s.name.clone()).collect();
        let mut messages: Vec<(TypeName, Vec<Line<'_>>, Option<usize>)> = Vec::new();
        for section in sections {
            let is_root = section.name == *root && section.header_line.is_none();
            if section.parts.len() == 1 {
                let lines = section.parts.into_iter().flatten().collect();
                messages.push((section.name, lines, section.header_line));
            } else if is_root {
                let synthesized = split_interface(root, section.parts)?;
                for (name, lines) in synthesized.parts {
                    defined.insert(name.clone());
                    messages.push((name, lines, None));
                }
                if let Some(event) = synthesized.event {
                    for field in &event.fields {
                        if let BaseType::Message(type_name) = &field.ty.base {
                            let reference = (type_name.clone(), field.name.clone(), None);
                            self.references.push(reference);
                        }
                    }
                    self.add(event, None)?;
                }
            } else {
                return Err((
                    section.header_line,
                    SchemaErrorKind::NotAMessage(section.name.to_string()),
                ));
            }
        }
        for (name, lines, header_line) in messages {
            let definition = self.parse_message(name, &lines, &defined)?;
            self.add(definition, header_line)?;
        }
        self.add_missing_builtins()?;
        Ok(self.definitions)
    }

    fn add(&mut self, definition: MessageDefinition, line: Option<usize>) -> Located<()> {
        match self.definitions.get(&definition.name) {
            Some(existing) if *existing != definition => Err((
                line,
                SchemaErrorKind::ConflictingDefinition(definition.name.to_string()),
            )),
            Some(_) => Ok(()),
            None => {
                self.definitions.insert(definition.name.clone(), definition);
                Ok(())
            }
        }
    }

    /// Adds the standard definitions of referenced types the text lacks, then fails on the
    /// first reference to a type that is still unknown.
    fn add_missing_builtins(&mut self) -> Located<()> {
        let mut next = 0;
        while let Some((name, field, line)) = self.references.get(next).cloned() {
            next += 1;
            if self.definitions.contains_key(&name) {
                continue;
            }
            let Some(text) = builtin::definition_text(&name) else {
                return Err((
                    line,
                    SchemaErrorKind::UnknownType {
                        field,
                        type_name: name.to_string(),
                    },
                ));
            };
            let lines: Vec<Line<'_>> = text.lines().map(|line| (0, line)).collect();
            let defined = BTreeSet::from([name.clone()]);
            let definition = self.parse_message(name, &lines, &defined)?;
            self.add(definition, None)?;
        }
        Ok(())
    }

    fn parse_message(
        &mut self,
        name: TypeName,
        lines: &[Line<'_>],
        defined: &BTreeSet<TypeName>,
    ) -> Located<MessageDefinition> {
        let mut definition = MessageDefinition {
            name,
            fields: Vec::new(),
            constants: Vec::new(),
        };
        let mut names = BTreeSet::new();
        for &(number, line) in lines {
            // Built-in texts carry line 0: they have no line in the user's schema.
            let at = (number > 0).then_some(number);
            let item = parse_line(line).map_err(|kind| (at, kind))?;
            let item_name = match &item {
                Item::Field { name, .. } | Item::Constant { name, .. } => name.clone(),
            };
            if !names.insert(item_name.clone()) {
                return Err((at, SchemaErrorKind::DuplicateName(item_name)));
            }
            match item {
                Item::Field { ty, name, default } => {
                    let ty = resolve(&definition.name.package, ty, defined);
                    if let BaseType::Message(type_name) = &ty.base {
                        if default.is_some() {
                            return Err((at, SchemaErrorKind::DefaultOnMessageField(name)));
                        }
                        self.references.push((type_name.clone(), name.clone(), at));
                    }
                    let default = default
                        .map(|text| literal(&ty, text))
                        .transpose()
                        .map_err(|kind| (at, kind))?;
                    definition.fields.push(FieldDef { name, ty, default });
                }
                Item::Constant { ty, name, value } => {
                    let ty = resolve(&definition.name.package, ty, defined);
                    if ty.array != ArrayKind::Single || matches!(ty.base, BaseType::Message(_)) {
                        return Err((at, SchemaErrorKind::ConstantNotPrimitive(name)));
                    }
                    let value = literal(&ty, value).map_err(|kind| (at, kind))?;
                    definition.constants.push(ConstantDef { name, ty, value });
                }
            }
        }
        Ok(definition)
    }
}

fn literal(ty: &FieldType, text: &str) -> Result<super::value::Value, SchemaErrorKind> {
    parse_literal(ty, text).map_err(|reason| SchemaErrorKind::InvalidLiteral {
        literal: text.to_owned(),
        type_name: ty.to_string(),
        reason,
    })
}

/// The messages defined by a service or action text, and the event wrapper if the schema
/// names a service event.
struct Synthesized<'a> {
    parts: Vec<(TypeName, Vec<Line<'a>>)>,
    event: Option<MessageDefinition>,
}

fn split_interface<'a>(root: &TypeName, parts: Vec<Vec<Line<'a>>>) -> Located<Synthesized<'a>> {
    let first_line = parts.iter().flatten().next().map(|(number, _)| *number);
    let not_a_message = || (first_line, SchemaErrorKind::NotAMessage(root.to_string()));
    let suffixes: &[&str] = match parts.len() {
        2 => &["_Request", "_Response"],
        3 => &["_Goal", "_Result", "_Feedback"],
        _ => return Err(not_a_message()),
    };
    let named = |base: &str, suffix: &str| TypeName::new(&root.package, &format!("{base}{suffix}"));
    if parts.len() == 2
        && let Some(base) = root.name.strip_suffix("_Event")
    {
        let request = named(base, "_Request");
        let response = named(base, "_Response");
        let field = |name: &str, base: BaseType, array: ArrayKind| FieldDef {
            name: name.to_owned(),
            ty: FieldType { base, array },
            default: None,
        };
        let event = MessageDefinition {
            name: root.clone(),
            fields: vec![
                field(
                    "info",
                    BaseType::Message(TypeName::new("service_msgs", "ServiceEventInfo")),
                    ArrayKind::Single,
                ),
                field(
                    "request",
                    BaseType::Message(request.clone()),
                    ArrayKind::Bounded(1),
                ),
                field(
                    "response",
                    BaseType::Message(response.clone()),
                    ArrayKind::Bounded(1),
                ),
            ],
            constants: Vec::new(),
        };
        let mut parts = parts.into_iter();
        let lines = [parts.next(), parts.next()].map(Option::unwrap_or_default);
        let [request_lines, response_lines] = lines;
        return Ok(Synthesized {
            parts: vec![(request, request_lines), (response, response_lines)],
            event: Some(event),
        });
    }
    let index = suffixes
        .iter()
        .position(|suffix| root.name.ends_with(suffix))
        .ok_or_else(not_a_message)?;
    let lines = parts.into_iter().nth(index).unwrap_or_default();
    Ok(Synthesized {
        parts: vec![(root.clone(), lines)],
        event: None,
    })
}

enum Item<'a> {
    Field {
        ty: RawType,
        name: String,
        default: Option<&'a str>,
    },
    Constant {
        ty: RawType,
        name: String,
        value: &'a str,
    },
}

/// A type as written, before unqualified message names are resolved.
struct RawType {
    base: RawBase,
    array: ArrayKind,
}

enum RawBase {
    Resolved(BaseType),
    Message {
        package: Option<String>,
        name: String,
    },
}

/// Reads one non-empty line with its comment removed.
fn parse_line(line: &str) -> Result<Item<'_>, SchemaErrorKind> {
    let bad_line = || SchemaErrorKind::BadLine(line.to_owned());
    let (type_token, rest) = line.split_once(char::is_whitespace).ok_or_else(bad_line)?;
    let rest = rest.trim_start();
    let name_end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    let (name, after) = rest.split_at(name_end);
    if name.is_empty() {
        return Err(bad_line());
    }
    if !is_identifier(name) {
        return Err(SchemaErrorKind::InvalidName(name.to_owned()));
    }
    let ty = parse_type(type_token)?;
    let after = after.trim_start();
    if let Some(value) = after.strip_prefix('=') {
        return Ok(Item::Constant {
            ty,
            name: name.to_owned(),
            value: value.trim(),
        });
    }
    // A default is separated from the name by whitespace; `name"x"` is not a field.
    if !after.is_empty() && after.len() == rest.len() - name_end {
        return Err(bad_line());
    }
    Ok(Item::Field {
        ty,
        name: name.to_owned(),
        default: (!after.is_empty()).then_some(after),
    })
}

fn parse_type(token: &str) -> Result<RawType, SchemaErrorKind> {
    let invalid = || SchemaErrorKind::InvalidType(token.to_owned());
    let parse_len = |text: &str| text.parse::<usize>().map_err(|_| invalid());
    let (base_text, array) = match token.strip_suffix(']') {
        Some(open_part) => {
            let open = open_part.rfind('[').ok_or_else(invalid)?;
            let inner = &open_part[open + 1..];
            let array = if inner.is_empty() {
                ArrayKind::Unbounded
            } else if let Some(bound) = inner.strip_prefix("<=") {
                ArrayKind::Bounded(parse_len(bound)?)
            } else {
                ArrayKind::Fixed(parse_len(inner)?)
            };
            (&open_part[..open], array)
        }
        None => (token, ArrayKind::Single),
    };
    let base = if let Some((name, bound)) = base_text.split_once("<=") {
        let bound = Some(parse_len(bound)?);
        match name {
            "string" => RawBase::Resolved(BaseType::String { bound }),
            "wstring" => RawBase::Resolved(BaseType::WString { bound }),
            _ => return Err(invalid()),
        }
    } else if let Some(primitive) = Primitive::from_name(base_text) {
        RawBase::Resolved(BaseType::Primitive(primitive))
    } else if base_text == "string" {
        RawBase::Resolved(BaseType::String { bound: None })
    } else if base_text == "wstring" {
        RawBase::Resolved(BaseType::WString { bound: None })
    } else {
        let name = TypeName::parse(base_text).ok_or_else(invalid)?;
        RawBase::Message {
            package: (base_text.contains('/')).then_some(name.package),
            name: name.name,
        }
    };
    Ok(RawType { base, array })
}

/// Resolves a message type name written in `package`'s text: a qualified name is taken as
/// is; an unqualified one is the type of that package if the schema defines it, else
/// `std_msgs/Header` for `Header` (the ROS convention), else the only defined type of that
/// name in another package, else the name in `package` (reported as unknown later).
fn resolve(package: &str, ty: RawType, defined: &BTreeSet<TypeName>) -> FieldType {
    let base = match ty.base {
        RawBase::Resolved(base) => base,
        RawBase::Message {
            package: Some(package),
            name,
        } => BaseType::Message(TypeName { package, name }),
        RawBase::Message {
            package: None,
            name,
        } => {
            let local = TypeName::new(package, &name);
            let mut elsewhere = defined.iter().filter(|defined| defined.name == name);
            let resolved = if defined.contains(&local) {
                local
            } else if name == "Header" {
                TypeName::new("std_msgs", "Header")
            } else if let (Some(only), None) = (elsewhere.next(), elsewhere.next()) {
                only.clone()
            } else {
                local
            };
            BaseType::Message(resolved)
        }
    };
    FieldType {
        base,
        array: ty.array,
    }
}
