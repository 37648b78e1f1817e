//! The errors of schema parsing and of CDR decoding, each saying where it happened.

use std::fmt;

/// A ros2msg schema text that cannot be parsed or compiled into a decoder.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("ros2msg schema `{schema}`{}: {kind}", line_suffix(*.line))]
pub struct SchemaError {
    /// The schema name given to the parser (`package/msg/Type`).
    pub schema: String,
    /// The 1-based line of the schema text the error is about, when there is one.
    pub line: Option<usize>,
    /// What is wrong.
    pub kind: SchemaErrorKind,
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|line| format!(", line {line}"))
        .unwrap_or_default()
}

/// What is wrong with a schema text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SchemaErrorKind {
    /// The schema name is not `package/Type`, `package/msg/Type` or a bare `Type`.
    #[error("`{0}` is not a message type name of the form package/msg/Type")]
    InvalidTypeName(String),
    /// A line is neither a field, a constant, a comment nor a section header.
    #[error("cannot read `{0}`: expected `TYPE NAME`, `TYPE NAME DEFAULT` or `TYPE NAME=VALUE`")]
    BadLine(String),
    /// A field or constant name is not an identifier.
    #[error(
        "`{0}` is not a valid field or constant name (letters, digits and `_`, starting with a letter)"
    )]
    InvalidName(String),
    /// A type token cannot be read (bad array suffix, bad bound, stray characters).
    #[error("`{0}` is not a valid type")]
    InvalidType(String),
    /// A field refers to a message type that the schema does not define.
    #[error(
        "field `{field}` has type `{type_name}`, which is not defined in the schema (add a `MSG: {type_name}` section)"
    )]
    UnknownType {
        /// The field naming the type.
        field: String,
        /// The resolved name of the missing type.
        type_name: String,
    },
    /// Two fields or constants of one message share a name.
    #[error("`{0}` is defined twice in the same message")]
    DuplicateName(String),
    /// Two `MSG:` sections define the same type differently.
    #[error("`{0}` is defined twice with different contents")]
    ConflictingDefinition(String),
    /// A line after a separator line is not `MSG: package/Type`.
    #[error("expected `MSG: package/Type` after the separator line, found `{0}`")]
    BadSectionHeader(String),
    /// A constant or default value cannot be read as its type.
    #[error("`{literal}` is not a valid {type_name} value: {reason}")]
    InvalidLiteral {
        /// The literal text.
        literal: String,
        /// The type it should have.
        type_name: String,
        /// Why it does not fit.
        reason: String,
    },
    /// A constant has an array or message type (only primitives and strings may be constants).
    #[error("constant `{0}` must have a primitive or string type")]
    ConstantNotPrimitive(String),
    /// A field of message type has a default value (ros2msg does not allow it).
    #[error("field `{0}` has a message type and cannot have a default value")]
    DefaultOnMessageField(String),
    /// A type contains itself, directly or through other types.
    #[error("type `{0}` contains itself, so it has no finite encoding")]
    Recursive(String),
    /// Types are nested deeper than the decoder allows.
    #[error("types are nested more than {0} levels deep")]
    TooDeep(usize),
    /// The text is a service or action definition that is not one of its decodable messages.
    #[error(
        "`{0}` is a service or action definition (it has `---` lines); only its _Request, _Response, _Event, _Goal, _Result or _Feedback message can be decoded"
    )]
    NotAMessage(String),
}

/// CDR bytes that do not match the schema they are decoded with.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{kind}", Location { path, offset: *offset })]
pub struct DecodeError {
    /// The field path where decoding failed (`new_parameters[0].value.string_value`), empty
    /// for the message itself.
    pub path: String,
    /// The byte offset in the message (counting the 4-byte encapsulation header).
    pub offset: usize,
    /// What went wrong.
    pub kind: DecodeErrorKind,
}

struct Location<'a> {
    path: &'a str,
    offset: usize,
}

impl fmt::Display for Location<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "at byte {}: ", self.offset)
        } else {
            write!(f, "at byte {} (field `{}`): ", self.offset, self.path)
        }
    }
}

/// What went wrong while decoding CDR bytes.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeErrorKind {
    /// The message is shorter than the 4-byte encapsulation header.
    #[error("the message has {0} bytes, fewer than the 4-byte CDR encapsulation header")]
    MissingHeader(usize),
    /// The encapsulation header names an encoding other than plain CDR.
    #[error(
        "encapsulation {0:02x} {1:02x} is not plain CDR (00 01 little-endian or 00 00 big-endian)"
    )]
    UnsupportedEncapsulation(u8, u8),
    /// The bytes end before a value does.
    #[error("the message ends early: {needed} more bytes needed, {available} left")]
    UnexpectedEnd {
        /// Bytes the value needs.
        needed: usize,
        /// Bytes left in the message.
        available: usize,
    },
    /// A sequence or string length is larger than what the remaining bytes can hold.
    #[error("length {count} cannot fit in the {remaining} bytes left")]
    LengthTooLarge {
        /// The length read from the message.
        count: u64,
        /// Bytes left after the length.
        remaining: usize,
    },
    /// A bounded sequence or string is longer than its bound.
    #[error("length {count} exceeds the bound {bound} of the schema")]
    BoundExceeded {
        /// The length read from the message.
        count: u64,
        /// The schema's bound.
        bound: u64,
    },
    /// A `bool` byte is neither 0 nor 1.
    #[error("bool byte {0:#04x} is neither 0 nor 1")]
    InvalidBool(u8),
    /// A string does not end with its NUL byte.
    #[error("string does not end with a NUL byte")]
    StringNotTerminated,
    /// A string is not UTF-8.
    #[error("string is not valid UTF-8")]
    InvalidUtf8,
    /// A `wstring` holds a value that is not a Unicode scalar value.
    #[error("wide character {0:#x} is not a Unicode scalar value")]
    InvalidWideChar(u32),
    /// Bytes are left after the message beyond the final alignment padding.
    #[error("{0} bytes are left after the end of the message")]
    TrailingBytes(usize),
}
