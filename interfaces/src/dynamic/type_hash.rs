//! ROS 2's type hash (REP 2011, `RIHS01_` and 64 hex digits): what a ROS 2 publisher of
//! Iron or later puts in its endpoint's `USER_DATA` (`typehash=RIHS01_...;`) and rosbag2
//! writes in a bag's metadata, so that two sides that name a type alike but define it
//! differently can tell.
//!
//! The hash is SHA-256 over a JSON text of the type's description as
//! `rosidl_generator_type_description` writes it: the type and every type it uses
//! (sorted by name), each as its fields' names and types (a type id, array capacity,
//! string bound and nested type name); default values, constants and comments are left
//! out, so the hash changes only when the bytes on the wire would.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

use super::schema::MessageSchema;
use super::types::{ArrayKind, BaseType, FieldType, MessageDefinition, Primitive, TypeName};

/// The type hash of `schema`'s root type (`RIHS01_` and 64 lowercase hex digits), or `None`
/// when a type it uses is not defined in it.
#[must_use]
pub fn type_hash(schema: &MessageSchema) -> Option<String> {
    let root = schema.definition(schema.root())?;
    let mut referenced = BTreeMap::new();
    collect(schema, root, &mut referenced)?;
    let mut json = String::from("{\"type_description\": ");
    describe(root, &mut json);
    json.push_str(", \"referenced_type_descriptions\": [");
    // Sorted by the full name (`pkg/msg/Type`), as rosidl sorts them.
    let mut names: Vec<(String, &MessageDefinition)> = referenced
        .into_values()
        .map(|definition: &MessageDefinition| (full_name(&definition.name), definition))
        .collect();
    names.sort_by(|a, b| a.0.cmp(&b.0));
    for (i, (_, definition)) in names.iter().enumerate() {
        if i > 0 {
            json.push_str(", ");
        }
        describe(definition, &mut json);
    }
    json.push_str("]}");
    let digest = Sha256::digest(json.as_bytes());
    let mut hash = String::from("RIHS01_");
    for byte in digest {
        let _ = write!(hash, "{byte:02x}");
    }
    Some(hash)
}

/// Every type `definition` uses, at any depth, by name.
fn collect<'s>(
    schema: &'s MessageSchema,
    definition: &MessageDefinition,
    into: &mut BTreeMap<TypeName, &'s MessageDefinition>,
) -> Option<()> {
    for field in &definition.fields {
        if let BaseType::Message(name) = &field.ty.base
            && !into.contains_key(name)
        {
            let nested = schema.definition(name)?;
            into.insert(name.clone(), nested);
            collect(schema, nested, into)?;
        }
    }
    Some(())
}

/// `package/msg/Type`: the name in a type description (the schema's names drop `msg`).
fn full_name(name: &TypeName) -> String {
    format!("{}/msg/{}", name.package, name.name)
}

/// One type's description, as JSON with rosidl's separators (`, ` and `: `). The names
/// are identifiers (the parser checked), so nothing needs escaping.
fn describe(definition: &MessageDefinition, json: &mut String) {
    let _ = write!(
        json,
        "{{\"type_name\": \"{}\", \"fields\": [",
        full_name(&definition.name)
    );
    if definition.fields.is_empty() {
        // An empty message becomes a struct with one uint8 member in ROS 2's IDL, whose
        // description is what is hashed.
        field(json, "structure_needs_at_least_one_member", 3, 0, 0, "");
    }
    for (i, def) in definition.fields.iter().enumerate() {
        if i > 0 {
            json.push_str(", ");
        }
        let (id, capacity, string_capacity, nested) = field_type(&def.ty);
        field(json, &def.name, id, capacity, string_capacity, &nested);
    }
    json.push_str("]}");
}

fn field(
    json: &mut String,
    name: &str,
    id: u32,
    capacity: usize,
    string_capacity: usize,
    nested: &str,
) {
    let _ = write!(
        json,
        "{{\"name\": \"{name}\", \"type\": {{\"type_id\": {id}, \"capacity\": {capacity}, \
         \"string_capacity\": {string_capacity}, \"nested_type_name\": \"{nested}\"}}}}"
    );
}

/// A field's `type_description_interfaces/msg/FieldType`: its type id, capacity, string
/// capacity and nested type name.
fn field_type(ty: &FieldType) -> (u32, usize, usize, String) {
    let (element, string_capacity, nested) = match &ty.base {
        BaseType::Primitive(primitive) => (primitive_id(*primitive), 0, String::new()),
        BaseType::String { bound: None } => (17, 0, String::new()),
        BaseType::WString { bound: None } => (18, 0, String::new()),
        BaseType::String { bound: Some(n) } => (21, *n, String::new()),
        BaseType::WString { bound: Some(n) } => (22, *n, String::new()),
        BaseType::Message(name) => (1, 0, full_name(name)),
    };
    // Arrays, bounded and unbounded sequences are the element's id plus 48, 96 and 144.
    let (offset, capacity) = match ty.array {
        ArrayKind::Single => (0, 0),
        ArrayKind::Fixed(n) => (48, n),
        ArrayKind::Bounded(n) => (96, n),
        ArrayKind::Unbounded => (144, 0),
    };
    (element + offset, capacity, string_capacity, nested)
}

/// The id of a primitive, after the .msg to IDL mapping (`char` is `uint8` there, `byte`
/// is `octet`).
fn primitive_id(primitive: Primitive) -> u32 {
    match primitive {
        Primitive::Int8 => 2,
        Primitive::UInt8 | Primitive::Char => 3,
        Primitive::Int16 => 4,
        Primitive::UInt16 => 5,
        Primitive::Int32 => 6,
        Primitive::UInt32 => 7,
        Primitive::Int64 => 8,
        Primitive::UInt64 => 9,
        Primitive::Float32 => 10,
        Primitive::Float64 => 11,
        Primitive::Bool => 15,
        Primitive::Byte => 16,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_companions_types_hash_as_ros_2_jazzy_does() {
        // The hashes rosbag2 (Jazzy) wrote for ../shared/data/ros2's recordings; the texts
        // are the ones this crate writes for the companions.
        for (name, expected) in [
            (
                crate::ros2::LASER_SCAN,
                "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
            ),
            (
                crate::ros2::ODOMETRY,
                "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
            ),
        ] {
            let text = crate::ros2::schema_text(name).unwrap_or_default();
            let schema = MessageSchema::parse(name, &text);
            let hash = schema.ok().and_then(|schema| type_hash(&schema));
            assert_eq!(hash.as_deref(), Some(expected), "{name}");
        }
    }

    #[test]
    fn constants_defaults_and_comments_do_not_change_it_and_types_do() {
        let hash = |text: &str| {
            MessageSchema::parse("p/msg/T", text)
                .ok()
                .and_then(|schema| type_hash(&schema))
        };
        let plain = hash("int32 a\nstring b\n");
        assert_eq!(plain, hash("int32 A=3\nint32 a 7 # a comment\nstring b\n"));
        assert_ne!(plain, hash("int64 a\nstring b\n"));
        assert_ne!(plain, hash("int32[] a\nstring b\n"));
        assert_ne!(plain, hash("int32 a\nstring<=5 b\n"));
        assert_ne!(plain, hash("int32 c\nstring b\n"));
    }
}
