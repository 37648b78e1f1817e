//! The validated form of a set of interface definitions: what code generation reads.

use std::path::PathBuf;

use super::diagnostic::Position;

/// The ROS 2 package every generated schema belongs to (`lewis_interfaces/msg/<Name>`).
pub const PACKAGE: &str = "lewis_interfaces";

/// The built-in header type that starts every publication, command and reply.
pub const HEADER_TYPE: &str = "Header";

/// The built-in type of one provenance entry of the header.
pub const INPUT_REF_TYPE: &str = "InputRef";

/// A primitive type, named by its ROS 2 spelling in `types.xml`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    /// `bool`
    Bool,
    /// `byte`
    Byte,
    /// `char`
    Char,
    /// `int8`
    Int8,
    /// `uint8`
    UInt8,
    /// `int16`
    Int16,
    /// `uint16`
    UInt16,
    /// `int32`
    Int32,
    /// `uint32`
    UInt32,
    /// `int64`
    Int64,
    /// `uint64`
    UInt64,
    /// `float32`
    Float32,
    /// `float64`
    Float64,
    /// `string`
    String,
    /// `uint8[]`: a byte sequence (images), encoded and decoded in bulk.
    Bytes,
}

impl Primitive {
    /// Every primitive, with its ROS 2 spelling.
    pub const ALL: [(Self, &'static str); 15] = [
        (Self::Bool, "bool"),
        (Self::Byte, "byte"),
        (Self::Char, "char"),
        (Self::Int8, "int8"),
        (Self::UInt8, "uint8"),
        (Self::Int16, "int16"),
        (Self::UInt16, "uint16"),
        (Self::Int32, "int32"),
        (Self::UInt32, "uint32"),
        (Self::Int64, "int64"),
        (Self::UInt64, "uint64"),
        (Self::Float32, "float32"),
        (Self::Float64, "float64"),
        (Self::String, "string"),
        (Self::Bytes, "uint8[]"),
    ];

    /// Parses a ROS 2 spelling.
    #[must_use]
    pub fn from_ros2(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(p, _)| *p)
    }

    /// The ROS 2 spelling.
    #[must_use]
    pub fn ros2(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(p, _)| *p == self)
            .map_or("", |(_, n)| n)
    }

    /// The Rust type that holds it.
    #[must_use]
    pub fn rust(self) -> &'static str {
        match self {
            Self::Bool => "bool",
            Self::Byte | Self::Char | Self::UInt8 => "u8",
            Self::Int8 => "i8",
            Self::Int16 => "i16",
            Self::UInt16 => "u16",
            Self::Int32 => "i32",
            Self::UInt32 => "u32",
            Self::Int64 => "i64",
            Self::UInt64 => "u64",
            Self::Float32 => "f32",
            Self::Float64 => "f64",
            Self::String => "String",
            Self::Bytes => "Vec<u8>",
        }
    }

    /// Whether it is an integer, so that it may give an array's size.
    #[must_use]
    pub fn is_integer(self) -> bool {
        matches!(
            self,
            Self::Int8
                | Self::UInt8
                | Self::Byte
                | Self::Int16
                | Self::UInt16
                | Self::Int32
                | Self::UInt32
                | Self::Int64
                | Self::UInt64
        )
    }
}

/// The type of a field, resolved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FieldType {
    /// A primitive, with the IDL name it was written as (`Float`).
    Primitive {
        /// The IDL name.
        idl_name: String,
        /// What it is.
        primitive: Primitive,
    },
    /// A compound type, by name.
    Struct(String),
}

/// A field of a struct, publication, command or reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// Its name, `snake_case`.
    pub name: String,
    /// Its type.
    pub ty: FieldType,
    /// Whether it is a sequence of its type.
    pub is_array: bool,
    /// For an array sized by another field: the earlier integer field that holds its
    /// length (the header's provenance list is the one array without one).
    pub array_size: Option<String>,
    /// The unit of the value (`m`, `rad/s`), for documentation.
    pub unit: Option<String>,
    /// What it means, for documentation.
    pub description: Option<String>,
    /// For a String field with a vocabulary: the words it may hold, in definition order.
    /// (The field may also be empty where its description says so: "none".) Empty for any
    /// other field.
    pub values: Vec<AllowedValue>,
}

impl Field {
    /// The name of the enum generated for this field's values in struct `owner`: the
    /// struct's name then the field's in CamelCase (`Mover.status` gives `MoverStatus`).
    #[must_use]
    pub fn vocabulary_name(&self, owner: &str) -> String {
        format!("{owner}{}", camel_case(&self.name))
    }
}

/// One word a String field may hold: `<value name="arrived" description="..."/>`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AllowedValue {
    /// The word as it is on the wire: lower-case words joined by `-` or `_`.
    pub name: String,
    /// What it means, for documentation.
    pub description: Option<String>,
}

impl AllowedValue {
    /// Its Rust variant: the words in CamelCase (`out-of-service` gives `OutOfService`).
    #[must_use]
    pub fn variant(&self) -> String {
        camel_case(&self.name)
    }

    /// Its ros2msg constant in a message: the field's name and the word, upper case, `_`
    /// between words (`status` and `out-of-service` give `STATUS_OUT_OF_SERVICE`).
    #[must_use]
    pub fn constant(&self, field: &str) -> String {
        format!("{field}_{}", self.name)
            .replace('-', "_")
            .to_ascii_uppercase()
    }
}

/// `snake_case` or `kebab-case` words in `CamelCase`.
#[must_use]
pub(super) fn camel_case(words: &str) -> String {
    words
        .split(['_', '-'])
        .map(|part| {
            let mut chars = part.chars();
            chars.next().map_or_else(String::new, |c| {
                c.to_ascii_uppercase().to_string() + chars.as_str()
            })
        })
        .collect()
}

/// What a generated struct is for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StructKind {
    /// A compound type of `types.xml` (or a built-in one).
    Compound,
    /// The publication of an interface.
    Publication {
        /// The interface.
        interface: String,
    },
    /// The request of a command.
    Command {
        /// The interface.
        interface: String,
        /// The command's name.
        command: String,
    },
    /// The reply to a command.
    Reply {
        /// The interface.
        interface: String,
        /// The command's name.
        command: String,
    },
}

/// A struct to generate: a compound type, a publication, a command or a reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StructType {
    /// Its type name, `CamelCase`, unique in the package.
    pub name: String,
    /// What it is for.
    pub kind: StructKind,
    /// Documentation.
    pub description: Option<String>,
    /// Its fields, in wire order. Messages (everything but compounds) get the header
    /// first, which is not listed here.
    pub fields: Vec<Field>,
}

impl StructType {
    /// Whether it starts with the common header.
    #[must_use]
    pub fn has_header(&self) -> bool {
        !matches!(self.kind, StructKind::Compound)
    }
}

/// A command of an interface.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Command {
    /// Its name, `snake_case`, as clients call it.
    pub name: String,
    /// Documentation.
    pub description: Option<String>,
    /// The request's struct.
    pub request: StructType,
    /// The reply's struct (only the header when the command answers nothing else).
    pub reply: StructType,
}

/// An interface: what a provider publishes and the commands it accepts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Interface {
    /// Its name, `CamelCase`.
    pub name: String,
    /// Its version, `MAJOR.MINOR`.
    pub version: String,
    /// Documentation: the `<description>` and the `<comment>`s.
    pub description: Option<String>,
    /// The file it was read from.
    pub file: PathBuf,
    /// Where the `<interface>` element starts.
    pub position: Position,
    /// The XML text, kept to store in recordings.
    pub xml: String,
    /// The publication.
    pub publication: StructType,
    /// The commands, in file order.
    pub commands: Vec<Command>,
}

/// A validated set of interface definitions.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Idl {
    /// The compound types, the built-in header types first, then in file order.
    pub types: Vec<StructType>,
    /// The XML text of the type libraries, by file name.
    pub types_xml: Vec<(String, String)>,
    /// The interfaces, sorted by name.
    pub interfaces: Vec<Interface>,
}

impl Idl {
    /// The interface of this name.
    #[must_use]
    pub fn interface(&self, name: &str) -> Option<&Interface> {
        self.interfaces.iter().find(|i| i.name == name)
    }

    /// The compound type of this name.
    #[must_use]
    pub fn compound(&self, name: &str) -> Option<&StructType> {
        self.types.iter().find(|t| t.name == name)
    }

    /// Every struct that code generation emits: compounds, then per interface its
    /// publication, commands and replies.
    pub fn all_structs(&self) -> impl Iterator<Item = &StructType> {
        self.types
            .iter()
            .chain(self.interfaces.iter().flat_map(|i| {
                std::iter::once(&i.publication)
                    .chain(i.commands.iter().flat_map(|c| [&c.request, &c.reply]))
            }))
    }

    /// The built-in compound types that every set of interfaces has.
    #[must_use]
    pub fn builtin_types() -> Vec<StructType> {
        let field = |name: &str, ty: FieldType, is_array: bool, description: &str| Field {
            name: name.to_owned(),
            ty,
            is_array,
            array_size: None,
            unit: None,
            description: Some(description.to_owned()),
            values: Vec::new(),
        };
        let prim = |idl_name: &str, primitive| FieldType::Primitive {
            idl_name: idl_name.to_owned(),
            primitive,
        };
        vec![
            StructType {
                name: HEADER_TYPE.to_owned(),
                kind: StructKind::Compound,
                description: Some(
                    "Starts every publication, command and reply: who sent it, its place in \
                     the channel, when, and what it was computed from."
                        .to_owned(),
                ),
                fields: vec![
                    field(
                        "provider",
                        prim("String", Primitive::String),
                        false,
                        "the service that sent it",
                    ),
                    field(
                        "seq",
                        prim("UnsignedLong", Primitive::UInt64),
                        false,
                        "sequence number in its channel, from 1",
                    ),
                    field(
                        "publish_time_ns",
                        prim("Long", Primitive::Int64),
                        false,
                        "the sender's clock when it was sent, in nanoseconds",
                    ),
                    field(
                        "inputs",
                        FieldType::Struct(INPUT_REF_TYPE.to_owned()),
                        true,
                        "the samples it was computed from (provenance)",
                    ),
                ],
            },
            StructType {
                name: INPUT_REF_TYPE.to_owned(),
                kind: StructKind::Compound,
                description: Some("One input a sample was computed from.".to_owned()),
                fields: vec![
                    field(
                        "channel",
                        prim("String", Primitive::String),
                        false,
                        "the channel the input came from",
                    ),
                    field(
                        "seq",
                        prim("UnsignedLong", Primitive::UInt64),
                        false,
                        "the input's sequence number in that channel",
                    ),
                ],
            },
        ]
    }
}
