//! Decoded values as JSON, for `--json` output and for tools.

use lewis_interfaces::dynamic::Value;
use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};

/// Serializes a decoded [`Value`]: messages become objects with their fields in wire order,
/// arrays and byte arrays become arrays of numbers, non-finite floats become the strings
/// `"NaN"`, `"inf"` and `"-inf"` (JSON has no such numbers).
///
/// `serde_json::to_string(&JsonValue(&value))` gives the JSON text.
#[derive(Debug, Clone, Copy)]
pub struct JsonValue<'a>(pub &'a Value);

impl Serialize for JsonValue<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self.0 {
            Value::Bool(value) => serializer.serialize_bool(*value),
            Value::Int(value) => serializer.serialize_i64(*value),
            Value::UInt(value) => serializer.serialize_u64(*value),
            Value::Float(value) if value.is_finite() => serializer.serialize_f64(*value),
            Value::Float(value) => serializer.collect_str(value),
            Value::String(value) => serializer.serialize_str(value),
            Value::Bytes(bytes) => {
                let mut seq = serializer.serialize_seq(Some(bytes.len()))?;
                for byte in bytes {
                    seq.serialize_element(byte)?;
                }
                seq.end()
            }
            Value::Array(items) => {
                let mut seq = serializer.serialize_seq(Some(items.len()))?;
                for item in items {
                    seq.serialize_element(&JsonValue(item))?;
                }
                seq.end()
            }
            Value::Struct(fields) => {
                let mut map = serializer.serialize_map(Some(fields.len()))?;
                for (name, value) in fields {
                    map.serialize_entry(&**name, &JsonValue(value))?;
                }
                map.end()
            }
        }
    }
}

/// Serializes an optional decoded value with [`JsonValue`] (for `#[serde(serialize_with)]`,
/// which hands over a `&Option`).
#[allow(clippy::ref_option)]
pub(crate) fn serialize_optional_value<S: Serializer>(
    value: &Option<Value>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    match value {
        Some(value) => serializer.serialize_some(&JsonValue(value)),
        None => serializer.serialize_none(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_become_json_with_field_order_kept() {
        let value = Value::Struct(vec![
            ("z".into(), Value::Int(-1)),
            ("a".into(), Value::Bytes(vec![1, 2])),
            (
                "f".into(),
                Value::Array(vec![
                    Value::Float(0.5),
                    Value::Float(f64::NAN),
                    Value::Float(f64::NEG_INFINITY),
                ]),
            ),
            ("s".into(), Value::String("é\"".into())),
            ("b".into(), Value::Bool(true)),
            ("u".into(), Value::UInt(u64::MAX)),
            ("e".into(), Value::Struct(vec![])),
        ]);
        assert_eq!(
            serde_json::to_string(&JsonValue(&value)).unwrap(),
            r#"{"z":-1,"a":[1,2],"f":[0.5,"NaN","-inf"],"s":"é\"","b":true,"u":18446744073709551615,"e":{}}"#
        );
    }
}
