//! A schema compiled once into a decoding plan: every type reference resolved to an index,
//! so that decoding many messages walks flat tables instead of looking names up.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::cdr;
use super::error::{DecodeError, SchemaError, SchemaErrorKind};
use super::schema::MessageSchema;
use super::types::{ArrayKind, BaseType, Primitive, TypeName};
use super::value::Value;

/// How deep messages may nest inside each other. ROS 2 messages rarely nest ten deep; the
/// limit keeps decoding of hostile schemas from exhausting the stack.
pub const MAX_NESTING_DEPTH: usize = 64;

/// A compiled schema that decodes CDR messages of one type into [`Value`]s.
/// Compile once per schema (per MCAP channel) and reuse for every message.
#[derive(Debug, Clone)]
pub struct Decoder {
    type_name: TypeName,
    pub(super) root: usize,
    pub(super) structs: Vec<StructPlan>,
}

#[derive(Debug, Clone)]
pub(super) struct StructPlan {
    pub(super) fields: Vec<FieldPlan>,
    /// The message has no fields: on the wire it is one placeholder byte, which is read
    /// and not shown (as rosidl's own bindings do).
    pub(super) placeholder_only: bool,
}

#[derive(Debug, Clone)]
pub(super) struct FieldPlan {
    pub(super) name: Arc<str>,
    pub(super) element: Element,
    pub(super) length: Length,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum Element {
    Primitive(Primitive),
    String { bound: Option<usize> },
    WString { bound: Option<usize> },
    Struct(usize),
}

#[derive(Debug, Clone, Copy)]
pub(super) enum Length {
    Single,
    Fixed(usize),
    Sequence { bound: Option<usize> },
}

impl Decoder {
    /// Parses and compiles the schema data of an MCAP schema record named `schema_name`.
    pub fn new(schema_name: &str, text: &str) -> Result<Self, SchemaError> {
        Self::from_schema(&MessageSchema::parse(schema_name, text)?)
    }

    /// Compiles a parsed schema.
    pub fn from_schema(schema: &MessageSchema) -> Result<Self, SchemaError> {
        let mut compiler = Compiler {
            schema,
            indexes: BTreeMap::new(),
            structs: Vec::new(),
        };
        let root = compiler
            .compile(schema.root(), 0)
            .map_err(|kind| SchemaError {
                schema: schema.schema_name().to_owned(),
                line: None,
                kind,
            })?;
        // Every slot is filled once its type is compiled, and compilation succeeded.
        let structs = compiler.structs.into_iter().flatten().collect();
        Ok(Self {
            type_name: schema.root().clone(),
            root,
            structs,
        })
    }

    /// The message type this decoder reads.
    pub fn type_name(&self) -> &TypeName {
        &self.type_name
    }

    /// Decodes one message: the 4-byte encapsulation header (plain CDR, little- or
    /// big-endian), then the fields. Every byte must be used, except the padding that
    /// rounds the message up to a multiple of 4 bytes.
    pub fn decode(&self, message: &[u8]) -> Result<Value, DecodeError> {
        cdr::decode(self, self.root, message)
    }
}

struct Compiler<'s> {
    schema: &'s MessageSchema,
    /// Index of each type seen; its slot in `structs` is `None` while it is being compiled.
    indexes: BTreeMap<TypeName, usize>,
    structs: Vec<Option<StructPlan>>,
}

impl Compiler<'_> {
    fn compile(&mut self, name: &TypeName, depth: usize) -> Result<usize, SchemaErrorKind> {
        if let Some(&index) = self.indexes.get(name) {
            return match self.structs.get(index) {
                Some(Some(_)) => Ok(index),
                _ => Err(SchemaErrorKind::Recursive(name.to_string())),
            };
        }
        if depth > MAX_NESTING_DEPTH {
            return Err(SchemaErrorKind::TooDeep(MAX_NESTING_DEPTH));
        }
        let definition =
            self.schema
                .definition(name)
                .ok_or_else(|| SchemaErrorKind::UnknownType {
                    field: String::new(),
                    type_name: name.to_string(),
                })?;
        let index = self.structs.len();
        self.structs.push(None);
        self.indexes.insert(name.clone(), index);
        let mut fields = Vec::with_capacity(definition.fields.len().max(1));
        for field in &definition.fields {
            let element = match &field.ty.base {
                BaseType::Primitive(primitive) => Element::Primitive(*primitive),
                BaseType::String { bound } => Element::String { bound: *bound },
                BaseType::WString { bound } => Element::WString { bound: *bound },
                BaseType::Message(nested) => Element::Struct(self.compile(nested, depth + 1)?),
            };
            let length = match field.ty.array {
                ArrayKind::Single => Length::Single,
                ArrayKind::Fixed(len) => Length::Fixed(len),
                ArrayKind::Unbounded => Length::Sequence { bound: None },
                ArrayKind::Bounded(bound) => Length::Sequence { bound: Some(bound) },
            };
            fields.push(FieldPlan {
                name: field.name.as_str().into(),
                element,
                length,
            });
        }
        // rosidl gives a message without fields one placeholder byte, so it is never empty
        // on the wire.
        let placeholder_only = fields.is_empty();
        if placeholder_only {
            fields.push(FieldPlan {
                name: "structure_needs_at_least_one_member".into(),
                element: Element::Primitive(Primitive::UInt8),
                length: Length::Single,
            });
        }
        if let Some(slot) = self.structs.get_mut(index) {
            *slot = Some(StructPlan {
                fields,
                placeholder_only,
            });
        }
        Ok(index)
    }
}
