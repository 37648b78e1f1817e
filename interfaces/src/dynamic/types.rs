//! The model of a parsed ros2msg schema: type names, field types, fields and constants.

use std::fmt;

use super::value::Value;

/// A message type name, `package/Type`. The `msg` (or `srv`, `action`) folder that ROS 2
/// puts in the middle is not part of the identity: `std_msgs/msg/String` and
/// `std_msgs/String` are the same type.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TypeName {
    /// The package (`std_msgs`); empty for a bare schema name without a package.
    pub package: String,
    /// The type (`String`).
    pub name: String,
}

impl TypeName {
    /// Reads `package/Type`, `package/msg/Type` (any middle folder) or a bare `Type`.
    /// Returns `None` when the text is not made of identifiers separated by `/`.
    pub fn parse(text: &str) -> Option<Self> {
        let parts: Vec<&str> = text.split('/').collect();
        let (package, name) = match parts.as_slice() {
            [name] => ("", *name),
            [package, name] | [package, _, name] => (*package, *name),
            _ => return None,
        };
        let all_identifiers = parts.iter().all(|part| is_identifier(part));
        all_identifiers.then(|| Self {
            package: package.to_owned(),
            name: name.to_owned(),
        })
    }

    /// A name in `package`.
    pub fn new(package: &str, name: &str) -> Self {
        Self {
            package: package.to_owned(),
            name: name.to_owned(),
        }
    }
}

impl fmt::Display for TypeName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.package.is_empty() {
            f.write_str(&self.name)
        } else {
            write!(f, "{}/{}", self.package, self.name)
        }
    }
}

/// True for `[A-Za-z][A-Za-z0-9_]*`.
pub(crate) fn is_identifier(text: &str) -> bool {
    let mut chars = text.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A primitive ROS 2 type of fixed size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Primitive {
    /// `bool`: one byte, 0 or 1.
    Bool,
    /// `byte`: one unsigned byte.
    Byte,
    /// `char`: one unsigned byte.
    Char,
    /// `int8`.
    Int8,
    /// `uint8`.
    UInt8,
    /// `int16`.
    Int16,
    /// `uint16`.
    UInt16,
    /// `int32`.
    Int32,
    /// `uint32`.
    UInt32,
    /// `int64`.
    Int64,
    /// `uint64`.
    UInt64,
    /// `float32`.
    Float32,
    /// `float64`.
    Float64,
}

impl Primitive {
    /// The primitive named `name` in a .msg file, if it is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "bool" => Self::Bool,
            "byte" => Self::Byte,
            "char" => Self::Char,
            "int8" => Self::Int8,
            "uint8" => Self::UInt8,
            "int16" => Self::Int16,
            "uint16" => Self::UInt16,
            "int32" => Self::Int32,
            "uint32" => Self::UInt32,
            "int64" => Self::Int64,
            "uint64" => Self::UInt64,
            "float32" => Self::Float32,
            "float64" => Self::Float64,
            _ => return None,
        })
    }

    /// The name used in .msg files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Bool => "bool",
            Self::Byte => "byte",
            Self::Char => "char",
            Self::Int8 => "int8",
            Self::UInt8 => "uint8",
            Self::Int16 => "int16",
            Self::UInt16 => "uint16",
            Self::Int32 => "int32",
            Self::UInt32 => "uint32",
            Self::Int64 => "int64",
            Self::UInt64 => "uint64",
            Self::Float32 => "float32",
            Self::Float64 => "float64",
        }
    }

    /// Size in bytes on the wire, which is also its CDR alignment.
    pub fn size_bytes(self) -> usize {
        match self {
            Self::Bool | Self::Byte | Self::Char | Self::Int8 | Self::UInt8 => 1,
            Self::Int16 | Self::UInt16 => 2,
            Self::Int32 | Self::UInt32 | Self::Float32 => 4,
            Self::Int64 | Self::UInt64 | Self::Float64 => 8,
        }
    }
}

/// The element type of a field, before any array suffix.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum BaseType {
    /// A fixed-size primitive.
    Primitive(Primitive),
    /// `string` or `string<=N` (bound in bytes).
    String {
        /// The bound, for `string<=N`.
        bound: Option<usize>,
    },
    /// `wstring` or `wstring<=N` (bound in characters).
    WString {
        /// The bound, for `wstring<=N`.
        bound: Option<usize>,
    },
    /// A nested message, fully resolved.
    Message(TypeName),
}

impl fmt::Display for BaseType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Primitive(primitive) => f.write_str(primitive.name()),
            Self::String { bound: None } => f.write_str("string"),
            Self::String { bound: Some(bound) } => write!(f, "string<={bound}"),
            Self::WString { bound: None } => f.write_str("wstring"),
            Self::WString { bound: Some(bound) } => write!(f, "wstring<={bound}"),
            Self::Message(name) => name.fmt(f),
        }
    }
}

/// Whether a field is a single value, a fixed array or a sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ArrayKind {
    /// One value.
    Single,
    /// `T[N]`: exactly N values, no count on the wire.
    Fixed(usize),
    /// `T[]`: a u32 count, then the values.
    Unbounded,
    /// `T[<=N]`: a u32 count of at most N, then the values.
    Bounded(usize),
}

/// The full type of a field: element type and array kind.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FieldType {
    /// The element type.
    pub base: BaseType,
    /// Single value, fixed array or sequence.
    pub array: ArrayKind,
}

impl fmt::Display for FieldType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.base.fmt(f)?;
        match self.array {
            ArrayKind::Single => Ok(()),
            ArrayKind::Fixed(len) => write!(f, "[{len}]"),
            ArrayKind::Unbounded => f.write_str("[]"),
            ArrayKind::Bounded(bound) => write!(f, "[<={bound}]"),
        }
    }
}

/// A field of a message.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldDef {
    /// The field name.
    pub name: String,
    /// The field type.
    pub ty: FieldType,
    /// The default value written after the name, if any.
    pub default: Option<Value>,
}

/// A constant of a message (`int32 FOO=3`); constants are not on the wire.
#[derive(Debug, Clone, PartialEq)]
pub struct ConstantDef {
    /// The constant name.
    pub name: String,
    /// The constant type (a primitive or a string, never an array).
    pub ty: FieldType,
    /// The value.
    pub value: Value,
}

/// One message type: its fields in wire order and its constants.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageDefinition {
    /// The type name.
    pub name: TypeName,
    /// The fields, in wire order.
    pub fields: Vec<FieldDef>,
    /// The constants, in text order.
    pub constants: Vec<ConstantDef>,
}
