//! Constant and default values written in .msg text (`int32 X=3`, `string s "a"`,
//! `int8[3] v [0, 127, -128]`), read into values of the field's type.

use super::types::{ArrayKind, BaseType, FieldType, Primitive};
use super::value::Value;

/// Reads `text` as a value of `ty`. The error is a reason for the user.
pub(crate) fn parse_literal(ty: &FieldType, text: &str) -> Result<Value, String> {
    let text = text.trim();
    match ty.array {
        ArrayKind::Single => parse_scalar(&ty.base, text),
        ArrayKind::Fixed(len) => {
            let items = parse_array(&ty.base, text)?;
            if items.len() == len {
                Ok(Value::Array(items))
            } else {
                Err(format!("expected {len} items, found {}", items.len()))
            }
        }
        ArrayKind::Bounded(bound) => {
            let items = parse_array(&ty.base, text)?;
            if items.len() <= bound {
                Ok(Value::Array(items))
            } else {
                Err(format!(
                    "expected at most {bound} items, found {}",
                    items.len()
                ))
            }
        }
        ArrayKind::Unbounded => parse_array(&ty.base, text).map(Value::Array),
    }
}

fn parse_array(base: &BaseType, text: &str) -> Result<Vec<Value>, String> {
    let inner = text
        .strip_prefix('[')
        .and_then(|rest| rest.strip_suffix(']'))
        .ok_or("an array value is written `[a, b, c]`")?;
    if inner.trim().is_empty() {
        return Ok(Vec::new());
    }
    split_outside_quotes(inner, ',')
        .into_iter()
        .map(|item| parse_scalar(base, item.trim()))
        .collect()
}

fn parse_scalar(base: &BaseType, text: &str) -> Result<Value, String> {
    match base {
        BaseType::Primitive(primitive) => parse_primitive(*primitive, text),
        BaseType::String { bound } | BaseType::WString { bound } => {
            let value = parse_string(text)?;
            let len = match base {
                BaseType::WString { .. } => value.chars().count(),
                _ => value.len(),
            };
            match bound {
                Some(bound) if len > *bound => {
                    Err(format!("{len} long, longer than the bound {bound}"))
                }
                _ => Ok(Value::String(value)),
            }
        }
        BaseType::Message(_) => Err("message fields have no literal values".to_owned()),
    }
}

fn parse_primitive(primitive: Primitive, text: &str) -> Result<Value, String> {
    let (min, max): (i128, i128) = match primitive {
        Primitive::Bool => return parse_bool(text).map(Value::Bool),
        Primitive::Float32 | Primitive::Float64 => {
            return text
                .parse::<f64>()
                .map(Value::Float)
                .map_err(|_| "not a number".to_owned());
        }
        Primitive::Byte | Primitive::Char | Primitive::UInt8 => (0, u8::MAX.into()),
        Primitive::Int8 => (i8::MIN.into(), i8::MAX.into()),
        Primitive::Int16 => (i16::MIN.into(), i16::MAX.into()),
        Primitive::UInt16 => (0, u16::MAX.into()),
        Primitive::Int32 => (i32::MIN.into(), i32::MAX.into()),
        Primitive::UInt32 => (0, u32::MAX.into()),
        Primitive::Int64 => (i64::MIN.into(), i64::MAX.into()),
        Primitive::UInt64 => (0, u64::MAX.into()),
    };
    let value = parse_integer(text).ok_or("not an integer")?;
    if value < min || value > max {
        return Err(format!("out of range {min}..={max}"));
    }
    let signed = matches!(
        primitive,
        Primitive::Int8 | Primitive::Int16 | Primitive::Int32 | Primitive::Int64
    );
    // The range check above makes both conversions exact.
    Ok(if signed {
        Value::Int(i64::try_from(value).map_err(|e| e.to_string())?)
    } else {
        Value::UInt(u64::try_from(value).map_err(|e| e.to_string())?)
    })
}

fn parse_bool(text: &str) -> Result<bool, String> {
    match text.to_ascii_lowercase().as_str() {
        "true" | "1" => Ok(true),
        "false" | "0" => Ok(false),
        _ => Err("expected true or false".to_owned()),
    }
}

/// Decimal, or hexadecimal/octal/binary with a `0x`/`0o`/`0b` prefix, with an optional sign.
fn parse_integer(text: &str) -> Option<i128> {
    let (negative, digits) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text.strip_prefix('+').unwrap_or(text)),
    };
    let lower = digits.to_ascii_lowercase();
    let (radix, digits) = if let Some(hex) = lower.strip_prefix("0x") {
        (16, hex)
    } else if let Some(octal) = lower.strip_prefix("0o") {
        (8, octal)
    } else if let Some(binary) = lower.strip_prefix("0b") {
        (2, binary)
    } else {
        (10, lower.as_str())
    };
    // `from_str_radix` accepts a sign of its own; a second one is not a literal.
    if digits.starts_with(['+', '-']) {
        return None;
    }
    let magnitude = i128::from_str_radix(digits, radix).ok()?;
    Some(if negative { -magnitude } else { magnitude })
}

/// A quoted string (`"..."` or `'...'`, backslash escapes) or, unquoted, the text itself.
fn parse_string(text: &str) -> Result<String, String> {
    let Some(quote) = text.chars().next().filter(|c| *c == '"' || *c == '\'') else {
        return Ok(text.to_owned());
    };
    let mut out = String::new();
    let mut chars = text[1..].chars();
    while let Some(c) = chars.next() {
        match c {
            '\\' => match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some('r') => out.push('\r'),
                Some(escaped) => out.push(escaped),
                None => return Err("the string ends with a lone backslash".to_owned()),
            },
            c if c == quote => {
                return if chars.as_str().trim().is_empty() {
                    Ok(out)
                } else {
                    Err("text follows the closing quote".to_owned())
                };
            }
            c => out.push(c),
        }
    }
    Err("the closing quote is missing".to_owned())
}

/// Splits at `separator` where it is outside single or double quotes.
pub(crate) fn split_outside_quotes(text: &str, separator: char) -> Vec<&str> {
    let mut parts = Vec::new();
    let mut start = 0;
    for (index, _) in outside_quotes(text).filter(|(_, c)| *c == separator) {
        parts.push(&text[start..index]);
        start = index + separator.len_utf8();
    }
    parts.push(&text[start..]);
    parts
}

/// The byte index of the first `#` outside quotes, where a comment starts.
pub(crate) fn comment_start(line: &str) -> Option<usize> {
    outside_quotes(line)
        .find(|(_, c)| *c == '#')
        .map(|(index, _)| index)
}

/// The characters of `text` (with their byte index) that are outside single or double
/// quotes; a backslash escapes the next character inside quotes.
fn outside_quotes(text: &str) -> impl Iterator<Item = (usize, char)> + '_ {
    let mut quote: Option<char> = None;
    let mut escaped = false;
    text.char_indices().filter(move |&(_, c)| {
        if let Some(open) = quote {
            if escaped {
                escaped = false;
            } else if c == '\\' {
                escaped = true;
            } else if c == open {
                quote = None;
            }
            false
        } else if c == '"' || c == '\'' {
            quote = Some(c);
            false
        } else {
            true
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(ty: &str, literal: &str, expected: Result<Value, &str>) {
        let base = |name: &str| {
            Primitive::from_name(name).map_or_else(
                || match name {
                    "string" => BaseType::String { bound: None },
                    "string<=3" => BaseType::String { bound: Some(3) },
                    other => panic!("test type {other}"),
                },
                BaseType::Primitive,
            )
        };
        let ty = match ty.split_once('[') {
            Some((name, "]")) => FieldType {
                base: base(name),
                array: ArrayKind::Unbounded,
            },
            Some((name, len)) => FieldType {
                base: base(name),
                array: ArrayKind::Fixed(len.trim_end_matches(']').parse().unwrap()),
            },
            None => FieldType {
                base: base(ty),
                array: ArrayKind::Single,
            },
        };
        assert_eq!(
            parse_literal(&ty, literal),
            expected.map_err(str::to_owned),
            "{ty} {literal}"
        );
    }

    #[test]
    fn integers_are_range_checked_per_type() {
        check("int8", "-128", Ok(Value::Int(-128)));
        check("int8", "128", Err("out of range -128..=127"));
        check("uint8", "255", Ok(Value::UInt(255)));
        check("uint8", "-1", Err("out of range 0..=255"));
        check("uint64", "18446744073709551615", Ok(Value::UInt(u64::MAX)));
        check("int64", "-9223372036854775808", Ok(Value::Int(i64::MIN)));
        check("int32", "0x10", Ok(Value::Int(16)));
        check("int32", "--1", Err("not an integer"));
        check("int32", "1.5", Err("not an integer"));
    }

    #[test]
    fn bools_and_floats_read_their_usual_spellings() {
        check("bool", "true", Ok(Value::Bool(true)));
        check("bool", "False", Ok(Value::Bool(false)));
        check("bool", "yes", Err("expected true or false"));
        check("float32", "-1.125", Ok(Value::Float(-1.125)));
        check("float64", "-2.5e3", Ok(Value::Float(-2500.0)));
    }

    #[test]
    fn strings_unquote_and_unescape() {
        check(
            "string",
            "\"Hello world!\"",
            Ok(Value::String("Hello world!".into())),
        );
        check(
            "string",
            "'Hello\\'world!'",
            Ok(Value::String("Hello'world!".into())),
        );
        check(
            "string",
            "\"Hello\\\"world!\"",
            Ok(Value::String("Hello\"world!".into())),
        );
        check(
            "string",
            "bare words",
            Ok(Value::String("bare words".into())),
        );
        check("string", "\"open", Err("the closing quote is missing"));
        check(
            "string<=3",
            "\"abcd\"",
            Err("4 long, longer than the bound 3"),
        );
    }

    #[test]
    fn arrays_split_outside_quotes_and_check_length() {
        check(
            "string[3]",
            "[\"\", \"max, value\", 'x']",
            Ok(Value::Array(vec![
                Value::String(String::new()),
                Value::String("max, value".into()),
                Value::String("x".into()),
            ])),
        );
        check("int8[2]", "[1, 2, 3]", Err("expected 2 items, found 3"));
        check("int8[]", "[]", Ok(Value::Array(vec![])));
        check(
            "int8[]",
            "1, 2",
            Err("an array value is written `[a, b, c]`"),
        );
    }

    #[test]
    fn comments_start_at_a_hash_outside_quotes() {
        assert_eq!(comment_start("int32 x # c"), Some(8));
        assert_eq!(comment_start("string s \"a # b\" # c"), Some(17));
        assert_eq!(comment_start("string s 'it''s'"), None);
    }
}
