//! The value tree a decoded message becomes, and how it is shown.

use std::fmt::{self, Write as _};
use std::sync::Arc;

/// A decoded value. Signed integers are `Int`, unsigned ones (and `byte`, `char`) `UInt`,
/// both float widths `Float`; `uint8`/`byte` arrays and sequences are `Bytes` for speed.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A `bool`.
    Bool(bool),
    /// An `int8` to `int64`.
    Int(i64),
    /// A `uint8` to `uint64`, `byte` or `char`.
    UInt(u64),
    /// A `float32` (widened exactly) or `float64`.
    Float(f64),
    /// A `string` or `wstring`.
    String(String),
    /// A `uint8[...]` or `byte[...]` array or sequence.
    Bytes(Vec<u8>),
    /// Any other array or sequence.
    Array(Vec<Value>),
    /// A message: its fields in wire order.
    Struct(Vec<(Arc<str>, Value)>),
}

impl Value {
    /// The field `name` of a message value.
    pub fn field(&self, name: &str) -> Option<&Value> {
        match self {
            Self::Struct(fields) => fields
                .iter()
                .find(|(field, _)| &**field == name)
                .map(|(_, value)| value),
            _ => None,
        }
    }

    /// The value at `path`: field names separated by `.`, array items as `[index]`
    /// (`new_parameters[0].value.type`). Items of `Bytes` are not values; reach them with
    /// [`Value::as_bytes`].
    pub fn get(&self, path: &str) -> Option<&Value> {
        let mut value = self;
        for segment in path.split('.').filter(|segment| !segment.is_empty()) {
            let (name, mut indexes) = segment.split_at(segment.find('[').unwrap_or(segment.len()));
            if !name.is_empty() {
                value = value.field(name)?;
            }
            while let Some(rest) = indexes.strip_prefix('[') {
                let (index, after) = rest.split_once(']')?;
                let Self::Array(items) = value else {
                    return None;
                };
                value = items.get(index.parse::<usize>().ok()?)?;
                indexes = after;
            }
            if !indexes.is_empty() {
                return None;
            }
        }
        Some(value)
    }

    /// The boolean, for a `Bool`.
    pub fn as_bool(&self) -> Option<bool> {
        match self {
            Self::Bool(value) => Some(*value),
            _ => None,
        }
    }

    /// The integer, for an `Int` or a `UInt` that fits an `i64`.
    pub fn as_i64(&self) -> Option<i64> {
        match self {
            Self::Int(value) => Some(*value),
            Self::UInt(value) => i64::try_from(*value).ok(),
            _ => None,
        }
    }

    /// The integer, for a `UInt` or a non-negative `Int`.
    pub fn as_u64(&self) -> Option<u64> {
        match self {
            Self::UInt(value) => Some(*value),
            Self::Int(value) => u64::try_from(*value).ok(),
            _ => None,
        }
    }

    /// The number, for a `Float`.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Self::Float(value) => Some(*value),
            _ => None,
        }
    }

    /// The text, for a `String`.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Self::String(value) => Some(value),
            _ => None,
        }
    }

    /// The bytes, for `Bytes`.
    pub fn as_bytes(&self) -> Option<&[u8]> {
        match self {
            Self::Bytes(value) => Some(value),
            _ => None,
        }
    }

    /// The items, for an `Array`.
    pub fn as_array(&self) -> Option<&[Value]> {
        match self {
            Self::Array(items) => Some(items),
            _ => None,
        }
    }

    /// Shows the value with at most `max_items` items of each array (the rest counted).
    /// `{}` gives one line (`{data: "hi", level: 20}`), `{:#}` an indented YAML-like block.
    pub fn display_limited(&self, max_items: usize) -> ValueDisplay<'_> {
        ValueDisplay {
            value: self,
            max_items: Some(max_items),
        }
    }
}

impl fmt::Display for Value {
    /// `{}`: one line, `{data: "hi", stamp: {sec: 1, nanosec: 2}, ranges: [1.0, 2.5]}`;
    /// `{:#}`: an indented YAML-like block, one field per line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        ValueDisplay {
            value: self,
            max_items: None,
        }
        .fmt(f)
    }
}

/// A [`Value`] shown with a limit on array items; see [`Value::display_limited`].
#[derive(Debug, Clone, Copy)]
pub struct ValueDisplay<'a> {
    value: &'a Value,
    max_items: Option<usize>,
}

impl fmt::Display for ValueDisplay<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if f.alternate() {
            let mut out = String::new();
            self.block(&mut out, self.value, 0)?;
            f.write_str(out.trim_end_matches('\n'))
        } else {
            let mut out = String::new();
            self.inline(&mut out, self.value)?;
            f.write_str(&out)
        }
    }
}

impl ValueDisplay<'_> {
    fn shown(&self, len: usize) -> usize {
        self.max_items.map_or(len, |max| len.min(max))
    }

    fn inline(&self, out: &mut String, value: &Value) -> fmt::Result {
        match value {
            Value::Bool(value) => write!(out, "{value}"),
            Value::Int(value) => write!(out, "{value}"),
            Value::UInt(value) => write!(out, "{value}"),
            Value::Float(value) => write!(out, "{value:?}"),
            Value::String(value) => write!(out, "{value:?}"),
            Value::Bytes(bytes) => {
                self.inline_list(out, bytes.len(), |out, i| write!(out, "{}", bytes[i]))
            }
            Value::Array(items) => {
                self.inline_list(out, items.len(), |out, i| self.inline(out, &items[i]))
            }
            Value::Struct(fields) => {
                out.push('{');
                for (index, (name, value)) in fields.iter().enumerate() {
                    if index > 0 {
                        out.push_str(", ");
                    }
                    write!(out, "{name}: ")?;
                    self.inline(out, value)?;
                }
                out.push('}');
                Ok(())
            }
        }
    }

    fn inline_list(
        &self,
        out: &mut String,
        len: usize,
        mut item: impl FnMut(&mut String, usize) -> fmt::Result,
    ) -> fmt::Result {
        out.push('[');
        let shown = self.shown(len);
        for index in 0..shown {
            if index > 0 {
                out.push_str(", ");
            }
            item(out, index)?;
        }
        if shown < len {
            let separator = if shown > 0 { ", " } else { "" };
            write!(out, "{separator}... {} more", len - shown)?;
        }
        out.push(']');
        Ok(())
    }

    /// Writes a value that starts a new line at `indent`.
    fn block(&self, out: &mut String, value: &Value, indent: usize) -> fmt::Result {
        match value {
            Value::Struct(fields) if !fields.is_empty() => self.fields(out, fields, indent, false),
            Value::Array(items) if is_block(value) => {
                let shown = self.shown(items.len());
                for item in &items[..shown] {
                    write!(out, "{:indent$}- ", "")?;
                    match item {
                        Value::Struct(fields) if !fields.is_empty() => {
                            self.fields(out, fields, indent + 2, true)?;
                        }
                        item if is_block(item) => {
                            out.push('\n');
                            self.block(out, item, indent + 2)?;
                        }
                        item => {
                            self.inline(out, item)?;
                            out.push('\n');
                        }
                    }
                }
                if shown < items.len() {
                    writeln!(out, "{:indent$}- ... {} more", "", items.len() - shown)?;
                }
                Ok(())
            }
            value => {
                write!(out, "{:indent$}", "")?;
                self.inline(out, value)?;
                out.push('\n');
                Ok(())
            }
        }
    }

    fn fields(
        &self,
        out: &mut String,
        fields: &[(Arc<str>, Value)],
        indent: usize,
        first_on_current_line: bool,
    ) -> fmt::Result {
        for (index, (name, value)) in fields.iter().enumerate() {
            if index > 0 || !first_on_current_line {
                write!(out, "{:indent$}", "")?;
            }
            write!(out, "{name}:")?;
            if is_block(value) {
                out.push('\n');
                self.block(out, value, indent + 2)?;
            } else {
                out.push(' ');
                self.inline(out, value)?;
                out.push('\n');
            }
        }
        Ok(())
    }
}

/// True for values shown over several lines in the block form.
fn is_block(value: &Value) -> bool {
    match value {
        Value::Struct(fields) => !fields.is_empty(),
        Value::Array(items) => items
            .iter()
            .any(|item| matches!(item, Value::Struct(_) | Value::Array(_))),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Value {
        let parameter = |name: &str, kind: u64| {
            Value::Struct(vec![
                ("name".into(), Value::String(name.into())),
                (
                    "value".into(),
                    Value::Struct(vec![
                        ("type".into(), Value::UInt(kind)),
                        ("bytes".into(), Value::Bytes(vec![1, 2, 3])),
                    ]),
                ),
            ])
        };
        Value::Struct(vec![
            (
                "stamp".into(),
                Value::Struct(vec![
                    ("sec".into(), Value::Int(-1)),
                    ("nanosec".into(), Value::UInt(5)),
                ]),
            ),
            ("node".into(), Value::String("/talker \"x\"".into())),
            ("ok".into(), Value::Bool(true)),
            (
                "ranges".into(),
                Value::Array(vec![Value::Float(1.0), Value::Float(2.5)]),
            ),
            (
                "new_parameters".into(),
                Value::Array(vec![parameter("a", 1), parameter("b", 2)]),
            ),
            ("empty".into(), Value::Array(vec![])),
        ])
    }

    #[test]
    fn compact_form_is_one_line_with_quoted_strings() {
        assert_eq!(
            sample().to_string(),
            "{stamp: {sec: -1, nanosec: 5}, node: \"/talker \\\"x\\\"\", ok: true, \
             ranges: [1.0, 2.5], new_parameters: [{name: \"a\", value: {type: 1, bytes: [1, 2, 3]}}, \
             {name: \"b\", value: {type: 2, bytes: [1, 2, 3]}}], empty: []}"
        );
    }

    #[test]
    fn block_form_nests_structs_and_lists_of_structs() {
        let expected = "\
stamp:
  sec: -1
  nanosec: 5
node: \"/talker \\\"x\\\"\"
ok: true
ranges: [1.0, 2.5]
new_parameters:
  - name: \"a\"
    value:
      type: 1
      bytes: [1, 2, 3]
  - name: \"b\"
    value:
      type: 2
      bytes: [1, 2, 3]
empty: []";
        assert_eq!(format!("{:#}", sample()), expected);
    }

    #[test]
    fn limited_display_counts_the_items_left_out() {
        let value = Value::Struct(vec![
            ("data".into(), Value::Bytes(vec![7; 10])),
            ("none".into(), Value::Array(vec![Value::Int(1)])),
        ]);
        assert_eq!(
            value.display_limited(2).to_string(),
            "{data: [7, 7, ... 8 more], none: [1]}"
        );
        assert_eq!(
            value.display_limited(0).to_string(),
            "{data: [... 10 more], none: [... 1 more]}"
        );
    }

    #[test]
    fn paths_reach_nested_fields_and_items() {
        let value = sample();
        assert_eq!(value.get("stamp.sec"), Some(&Value::Int(-1)));
        assert_eq!(
            value.get("new_parameters[1].value.type"),
            Some(&Value::UInt(2))
        );
        assert_eq!(value.get("new_parameters[2]"), None);
        assert_eq!(value.get("ranges[1]").and_then(Value::as_f64), Some(2.5));
        assert_eq!(value.get("node[0]"), None);
        assert_eq!(value.get("stamp.nope"), None);
        assert_eq!(value.get(""), Some(&value));
    }
}
