//! Two CDR messages of one type compared field by field, in one walk over both bytes, with
//! no value tree built: how a replay tells whether a re-simulated message is the recorded
//! one within a tolerance (a camera frame is a megabyte; decoding both of every pair was
//! a large part of a closed-loop replay's own time).
//!
//! The rules are those of comparing the two decoded [`Value`](super::Value)s: numbers (of
//! any width, signed or not) are the same when equal, both NaN, or within the tolerance;
//! byte arrays, strings and booleans are the same only when equal; arrays of other lengths
//! differ, their common elements still compared. The largest numeric difference is kept
//! with the path of its field (`ranges.[3]`), written out only when it grows.

use super::cdr::{Decoded, Walker, into_error, minimum_size};
use super::error::DecodeError;
use super::plan::{Decoder, Element, FieldPlan, Length};
use super::types::Primitive;
use super::value::Value;

/// How two messages are compared.
#[derive(Debug, Clone, Copy)]
pub struct CompareOptions<'a> {
    /// Numbers closer than this are the same.
    pub tolerance: f64,
    /// A field of the message (its top level) that is not compared, such as a `header`
    /// that a replay re-stamps.
    pub skip_field: Option<&'a str>,
    /// Put before every field's path in [`LargestDifference::field`] (`request`).
    pub path_prefix: &'a str,
}

/// The largest numeric difference between compared messages, and the field it is in.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LargestDifference {
    /// The difference (infinite when one number is infinite or NaN and the other not).
    pub difference: f64,
    /// Its field's path (`min_distance`, `ranges.[3]`), when a difference was seen.
    pub field: Option<String>,
}

impl LargestDifference {
    /// Keeps `other` when its difference is larger than this one's.
    pub fn merge(&mut self, other: Self) {
        if other.difference > self.difference {
            *self = other;
        }
    }
}

impl Decoder {
    /// Whether messages `a` and `b`, both of this decoder's type, are the same under
    /// `options`; `largest` gets their largest numeric difference when it is larger than
    /// the one it holds.
    ///
    /// # Errors
    /// When either message does not decode (`largest` is then left as it was).
    pub fn compare(
        &self,
        a: &[u8],
        b: &[u8],
        options: &CompareOptions<'_>,
        largest: &mut LargestDifference,
    ) -> Result<bool, DecodeError> {
        let mut pair = Pair {
            a: Walker::new(self, a)?,
            b: Walker::new(self, b)?,
            options,
            largest: LargestDifference::default(),
            path: Vec::new(),
        };
        let same = pair
            .structure(self.root, options.skip_field)
            .and_then(|same| {
                pair.a.finish()?;
                pair.b.finish()?;
                Ok(same)
            })
            .map_err(|failure| into_error(*failure))?;
        largest.merge(pair.largest);
        Ok(same)
    }
}

/// One step of the path to a value: a field, or an element (`[3]`).
#[derive(Debug, Clone, Copy)]
enum Step<'d> {
    Field(&'d str),
    Index(usize),
}

/// Two walks in step through messages of one type.
struct Pair<'d, 'a, 'o> {
    a: Walker<'d, 'a>,
    b: Walker<'d, 'a>,
    options: &'o CompareOptions<'o>,
    largest: LargestDifference,
    path: Vec<Step<'d>>,
}

impl<'d> Pair<'d, '_, '_> {
    fn structure(&mut self, index: usize, skip: Option<&str>) -> Decoded<bool> {
        let decoder: &'d Decoder = self.a.decoder;
        let Some(plan) = decoder.structs.get(index) else {
            // Plans only hold indexes they created; both sides are the same empty value.
            return Ok(true);
        };
        if plan.placeholder_only {
            // Its one byte is read and not shown: nothing to compare.
            self.a.structure(index)?;
            self.b.structure(index)?;
            return Ok(true);
        }
        let mut same = true;
        for field in &plan.fields {
            if skip == Some(&*field.name) {
                self.a.field(field)?;
                self.b.field(field)?;
                continue;
            }
            self.path.push(Step::Field(&field.name));
            same &= self.field(field)?;
            self.path.pop();
        }
        Ok(same)
    }

    fn field(&mut self, field: &FieldPlan) -> Decoded<bool> {
        match field.length {
            Length::Single => self.element(field.element),
            Length::Fixed(len) => self.array(field.element, len, len),
            Length::Sequence { bound } => {
                let minimum = minimum_size(field.element);
                let len_a = self.a.cursor.length(minimum, bound)?;
                let len_b = self.b.cursor.length(minimum, bound)?;
                self.array(field.element, len_a, len_b)
            }
        }
    }

    fn element(&mut self, element: Element) -> Decoded<bool> {
        Ok(match element {
            Element::Primitive(primitive) => {
                let x = self.a.cursor.primitive(primitive)?;
                let y = self.b.cursor.primitive(primitive)?;
                self.same_primitive(&x, &y)
            }
            Element::String { bound } => {
                self.a.cursor.string(bound)? == self.b.cursor.string(bound)?
            }
            Element::WString { bound } => {
                self.a.cursor.wstring(bound)? == self.b.cursor.wstring(bound)?
            }
            Element::Struct(index) => self.structure(index, None)?,
        })
    }

    fn array(&mut self, element: Element, len_a: usize, len_b: usize) -> Decoded<bool> {
        if len_a > 0 {
            self.a.array_start(element, len_a)?;
        }
        if len_b > 0 {
            self.b.array_start(element, len_b)?;
        }
        if let Element::Primitive(Primitive::UInt8 | Primitive::Byte) = element {
            return Ok(self.a.cursor.take(len_a)? == self.b.cursor.take(len_b)?);
        }
        let common = len_a.min(len_b);
        let mut same = len_a == len_b;
        for index in 0..common {
            self.path.push(Step::Index(index));
            same &= self.element(element)?;
            self.path.pop();
        }
        // The longer side's extra elements are read to stay in step, not compared.
        for _ in common..len_a {
            self.a.element(element)?;
        }
        for _ in common..len_b {
            self.b.element(element)?;
        }
        Ok(same)
    }

    fn same_primitive(&mut self, x: &Value, y: &Value) -> bool {
        let (Some(x), Some(y)) = (number(x), number(y)) else {
            return x == y;
        };
        if x.is_nan() && y.is_nan() {
            return true;
        }
        let difference = (x - y).abs();
        if difference.is_finite() {
            self.see(difference);
        } else if x != y {
            self.see(f64::INFINITY);
        }
        x == y || difference <= self.options.tolerance
    }

    fn see(&mut self, difference: f64) {
        if difference > self.largest.difference {
            self.largest.difference = difference;
            self.largest.field = Some(self.path_text());
        }
    }

    fn path_text(&self) -> String {
        let mut text = self.options.path_prefix.to_owned();
        for step in &self.path {
            if !text.is_empty() {
                text.push('.');
            }
            match step {
                Step::Field(name) => text.push_str(name),
                Step::Index(index) => {
                    text.push('[');
                    text.push_str(&index.to_string());
                    text.push(']');
                }
            }
        }
        text
    }
}

/// A primitive value as a number, when it is one.
fn number(value: &Value) -> Option<f64> {
    match value {
        Value::Int(i) => Some(*i as f64),
        Value::UInt(u) => Some(*u as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;
    use crate::Struct;
    use crate::cdr;
    use crate::msg::{Header, ImageSource, InputRef, Pose3D, RangeFinder};

    /// The rules of the module documentation written over decoded values: the oracle the
    /// one-walk comparison must agree with.
    fn oracle(
        decoder: &Decoder,
        a: &[u8],
        b: &[u8],
        tolerance: f64,
    ) -> Option<(bool, LargestDifference)> {
        let strip = |value: Value| match value {
            Value::Struct(fields) => Value::Struct(
                fields
                    .into_iter()
                    .filter(|(n, _)| &**n != "header")
                    .collect(),
            ),
            other => other,
        };
        let a = strip(decoder.decode(a).ok()?);
        let b = strip(decoder.decode(b).ok()?);
        let mut largest = LargestDifference::default();
        let same = same_value(&a, &b, tolerance, &mut largest, &mut Vec::new());
        Some((same, largest))
    }

    fn same_value(
        a: &Value,
        b: &Value,
        tolerance: f64,
        largest: &mut LargestDifference,
        path: &mut Vec<String>,
    ) -> bool {
        if let (Some(x), Some(y)) = (number(a), number(b)) {
            if x.is_nan() && y.is_nan() {
                return true;
            }
            let difference = (x - y).abs();
            let seen = if difference.is_finite() {
                difference
            } else if x != y {
                f64::INFINITY
            } else {
                0.0
            };
            if seen > largest.difference {
                largest.difference = seen;
                largest.field = Some(path.join("."));
            }
            return x == y || difference <= tolerance;
        }
        match (a, b) {
            (Value::Array(x), Value::Array(y)) => {
                let mut same = x.len() == y.len();
                for (i, (x, y)) in x.iter().zip(y).enumerate() {
                    path.push(format!("[{i}]"));
                    same &= same_value(x, y, tolerance, largest, path);
                    path.pop();
                }
                same
            }
            (Value::Struct(x), Value::Struct(y)) => {
                let mut same = x.len() == y.len();
                for ((name, x), (_, y)) in x.iter().zip(y) {
                    path.push(name.to_string());
                    same &= same_value(x, y, tolerance, largest, path);
                    path.pop();
                }
                same
            }
            _ => a == b,
        }
    }

    fn decoder<T: Struct>() -> Decoder {
        Decoder::new(T::SCHEMA_NAME, T::SCHEMA_TEXT).unwrap_or_else(|e| panic!("{e}"))
    }

    fn compare(
        decoder: &Decoder,
        a: &[u8],
        b: &[u8],
        tolerance: f64,
    ) -> Option<(bool, LargestDifference)> {
        let options = CompareOptions {
            tolerance,
            skip_field: Some("header"),
            path_prefix: "",
        };
        let mut largest = LargestDifference::default();
        let same = decoder.compare(a, b, &options, &mut largest).ok()?;
        Some((same, largest))
    }

    fn header(provider: &str, seq: u64) -> Header {
        Header {
            provider: provider.into(),
            seq,
            publish_time_ns: i64::try_from(seq).unwrap_or(0) * 1000,
            inputs: (0..seq % 3)
                .map(|i| InputRef {
                    channel: format!("/in/{i}"),
                    seq: i,
                })
                .collect(),
        }
    }

    fn scan(provider: &str, seq: u64, ranges: Vec<f64>, uniform: bool) -> Vec<u8> {
        let count = ranges.len();
        cdr::to_vec(&RangeFinder {
            header: header(provider, seq),
            range_count: i32::try_from(count).unwrap_or(0),
            ranges,
            max_range: 8.0,
            uniform,
            sensor_positions: vec![Pose3D::default(); count % 4],
            ..RangeFinder::default()
        })
    }

    #[test]
    fn messages_that_differ_only_in_their_headers_are_the_same() {
        let d = decoder::<RangeFinder>();
        // Headers of other lengths put the fields after them at other offsets.
        let a = scan("laser", 1, vec![1.0, 2.0], true);
        let b = scan("a-much-longer-provider", 5, vec![1.0, 2.0], true);
        assert_eq!(
            compare(&d, &a, &b, 0.0),
            Some((true, LargestDifference::default()))
        );
    }

    #[test]
    fn the_largest_difference_is_named_by_its_path() {
        let d = decoder::<RangeFinder>();
        let a = scan("laser", 1, vec![1.0, 2.0, 3.0], true);
        let b = scan("laser", 1, vec![1.0, 2.5, 3.1], true);
        let (same, largest) = compare(&d, &a, &b, 0.2).unwrap_or_else(|| panic!("decodes"));
        assert!(!same);
        assert_eq!(largest.difference, 0.5);
        assert_eq!(largest.field.as_deref(), Some("ranges.[1]"));
        let (same, _) = compare(&d, &a, &b, 0.6).unwrap_or_else(|| panic!("decodes"));
        assert!(same, "within the tolerance");
    }

    #[test]
    fn bytes_are_compared_exactly_and_a_broken_message_is_an_error() {
        let d = decoder::<ImageSource>();
        let image = |data: Vec<u8>| {
            cdr::to_vec(&ImageSource {
                header: header("camera", 2),
                width: 2,
                height: 1,
                encoding: "rgb8".into(),
                data,
                ..ImageSource::default()
            })
        };
        let a = image(vec![1, 2, 3, 4, 5, 6]);
        assert_eq!(
            compare(&d, &a, &image(vec![1, 2, 3, 4, 5, 7]), 10.0).map(|c| c.0),
            Some(false)
        );
        assert_eq!(compare(&d, &a, &a, 0.0).map(|c| c.0), Some(true));
        let cut = &a[..a.len() - 9];
        assert_eq!(compare(&d, &a, cut, 0.0), None);
    }

    fn ranges() -> impl Strategy<Value = Vec<f64>> {
        let value = prop_oneof![
            8 => prop::sample::select(vec![0.5, 1.0, 1.25, 2.0]),
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
        ];
        prop::collection::vec(value, 0..6)
    }

    proptest! {
        #[test]
        fn one_walk_agrees_with_comparing_decoded_values(
            ranges_a in ranges(),
            ranges_b in ranges(),
            uniform_b: bool,
            seq_b in 0u64..5,
            tolerance in prop::sample::select(vec![0.0, 0.3, 1.0]),
        ) {
            let d = decoder::<RangeFinder>();
            let a = scan("laser", 1, ranges_a, true);
            let b = scan("sonar", seq_b, ranges_b, uniform_b);
            let walked = compare(&d, &a, &b, tolerance);
            let decoded = oracle(&d, &a, &b, tolerance);
            prop_assert_eq!(walked.as_ref().map(|w| w.0), decoded.as_ref().map(|o| o.0));
            prop_assert_eq!(
                walked.map(|w| (w.1.difference.to_bits(), w.1.field)),
                decoded.map(|o| (o.1.difference.to_bits(), o.1.field))
            );
        }
    }
}
