//! The values check: a payload decodes as its interface's message (the generated decoder),
//! its arrays have the sizes their size fields say, the interface's own ranges hold (a
//! range finder's readings within `[0, max_range]`), and every number the IDL declares is
//! finite (the generated `first_non_finite`, whatever the interface).
//!
//! One typed decode per sample and no value tree: the broker checks every sample of every
//! checked provider, a laser scan is hundreds of ranges and as many beam poses many times
//! a second, and a schema-driven decoder building a tree of them cost the broker more CPU
//! than all its other work.

use lewis_interfaces::{Struct, cdr, msg};

/// The values check of one interface, used for every sample.
#[derive(Debug, Clone)]
pub(super) struct ValueCheck {
    interface: String,
}

impl ValueCheck {
    pub(super) fn new(interface: &str) -> Self {
        Self {
            interface: interface.to_owned(),
        }
    }

    /// `Err` with what is wrong when the payload breaks a promise of its interface.
    pub(super) fn check(&self, bytes: &[u8]) -> Result<(), String> {
        typed(&self.interface, bytes)
    }
}

/// Decodes `bytes` with the interface's generated type, checks its array sizes, the
/// interface's own ranges, then that every number is finite.
fn typed(interface: &str, bytes: &[u8]) -> Result<(), String> {
    macro_rules! interfaces {
        ($($name:ident),* $(,)?) => {
            match interface {
                "RangeFinder" => {
                    let scan = owned::<msg::RangeFinder>(interface, bytes)?;
                    range_finder(&scan)?;
                    finite(&scan)
                }
                "Distance" => {
                    let distance = owned::<msg::Distance>(interface, bytes)?;
                    self::distance(&distance)?;
                    finite(&distance)
                }
                $(stringify!($name) => finite(&owned::<msg::$name>(interface, bytes)?),)*
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
        HostLink,
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

/// Every number of `message` is finite, or the first that is not, by its place.
fn finite<T: Struct>(message: &T) -> Result<(), String> {
    let mut path = String::new();
    match message.first_non_finite(&mut path) {
        Some(x) => Err(format!("`{path}` is {x}, not a finite number")),
        None => Ok(()),
    }
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
