//! The values check: a payload decodes as its interface's message (the generated decoder),
//! its arrays have the sizes their size fields say, every number the IDL declares is
//! finite (the schema-driven decoder walks them, whatever the interface), and the
//! interface's own ranges hold (a range finder's readings within `[0, max_range]`).

use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::{Struct, cdr, msg};
use std::fmt::Write as _;

/// The values check of one interface, compiled once and used for every sample.
#[derive(Debug, Clone)]
pub(super) struct ValueCheck {
    interface: String,
    /// `None` when the interface is not compiled into this binary (every sample then fails).
    numbers: Option<Decoder>,
}

impl ValueCheck {
    pub(super) fn new(interface: &str) -> Self {
        let numbers = lewis_interfaces::interface_info(interface)
            .and_then(|info| Decoder::new(info.publication.name, info.publication.text).ok());
        Self {
            interface: interface.to_owned(),
            numbers,
        }
    }

    /// `Err` with what is wrong when the payload breaks a promise of its interface.
    pub(super) fn check(&self, bytes: &[u8]) -> Result<(), String> {
        let Some(numbers) = &self.numbers else {
            return Err(format!(
                "`{}` is not an interface this broker knows",
                self.interface
            ));
        };
        typed(&self.interface, bytes)?;
        let value = numbers
            .decode(bytes)
            .map_err(|e| format!("does not decode as {}: {e}", self.interface))?;
        let mut path = String::new();
        match first_non_finite(&value, &mut path) {
            Some(x) => Err(format!("`{path}` is {x}, not a finite number")),
            None => Ok(()),
        }
    }
}

/// Decodes `bytes` with the interface's generated type, checks its array sizes and the
/// interface's own ranges.
fn typed(interface: &str, bytes: &[u8]) -> Result<(), String> {
    macro_rules! interfaces {
        ($($name:ident),* $(,)?) => {
            match interface {
                "RangeFinder" => range_finder(&owned::<msg::RangeFinder>(interface, bytes)?),
                "Distance" => distance(&owned::<msg::Distance>(interface, bytes)?),
                $(stringify!($name) => owned::<msg::$name>(interface, bytes).map(drop),)*
                _ => Err(format!("`{interface}` is not an interface this broker knows")),
            }
        };
    }
    interfaces!(
        Blobs,
        Blobs3D,
        Broker,
        CameraControl,
        Clock,
        CommandLog,
        Egomotion,
        GroundTruth,
        Health,
        ImageSource,
        LogLine,
        Mover,
        Power,
        ProcessCpu,
        RecorderStats,
        Sequencer,
        Signs,
        Speech,
        Synchrodrive,
        UnansweredCall,
        WorldState,
    )
}

fn owned<T: Struct>(interface: &str, bytes: &[u8]) -> Result<T, String> {
    let message: T =
        cdr::from_bytes(bytes).map_err(|e| format!("does not decode as {interface}: {e}"))?;
    message.check_sizes().map_err(|e| e.to_string())?;
    Ok(message)
}

fn range_finder(scan: &msg::RangeFinder) -> Result<(), String> {
    within_max_range("ranges", &scan.ranges, scan.max_range)
}

fn distance(distance: &msg::Distance) -> Result<(), String> {
    within_max_range(
        "sector_distances",
        &distance.sector_distances,
        distance.max_range,
    )
}

/// Readings of a sensor that says how far it sees: each within `[0, max_range]`. A message
/// that does not say (`max_range` 0, as a service that has not learnt it yet sends) is not
/// judged on its ranges; a `max_range` that is not a number fails the number check.
fn within_max_range(field: &str, readings: &[f64], max_range: f64) -> Result<(), String> {
    if max_range < 0.0 {
        return Err(format!("`max_range` is {max_range}, not a distance"));
    }
    if !(max_range.is_finite() && max_range > 0.0) {
        return Ok(());
    }
    match readings
        .iter()
        .enumerate()
        .find(|(_, r)| !(0.0..=max_range).contains(*r))
    {
        Some((i, r)) => Err(format!(
            "`{field}[{i}]` is {r}, outside [0, max_range = {max_range}]"
        )),
        None => Ok(()),
    }
}

/// The first number in `value` that is NaN or infinite, its place left in `path`. Places
/// are written into the one buffer, never allocated: a laser scan is hundreds of numbers
/// many times a second.
fn first_non_finite(value: &Value, path: &mut String) -> Option<f64> {
    match value {
        Value::Float(x) if !x.is_finite() => Some(*x),
        Value::Array(items) => {
            let len = path.len();
            for (i, item) in items.iter().enumerate() {
                let _ = write!(path, "[{i}]");
                if let Some(x) = first_non_finite(item, path) {
                    return Some(x);
                }
                path.truncate(len);
            }
            None
        }
        Value::Struct(fields) => {
            let len = path.len();
            for (name, field) in fields {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(name);
                if let Some(x) = first_non_finite(field, path) {
                    return Some(x);
                }
                path.truncate(len);
            }
            None
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_non_finite_number_is_named_by_its_place() {
        let point = |x: f64| Value::Struct(vec![("x".into(), Value::Float(x))]);
        let value = Value::Struct(vec![
            ("stamp".into(), Value::Int(3)),
            (
                "points".into(),
                Value::Array(vec![point(1.0), point(f64::INFINITY), point(f64::NAN)]),
            ),
        ]);
        let mut path = String::new();
        assert_eq!(first_non_finite(&value, &mut path), Some(f64::INFINITY));
        assert_eq!(path, "points[1].x");
        let mut path = String::new();
        assert_eq!(first_non_finite(&point(2.0), &mut path), None);
        assert_eq!(path, "");
    }
}
