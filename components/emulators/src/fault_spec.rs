//! The text form of injected faults, as `lewis fake-device --fault` takes it: a comma-separated
//! list of
//!
//! - `noise=N`: N garbage bytes before every frame;
//! - `bad-crc-every=N`: every N-th frame with a corrupted checksum (1: all);
//! - `silent`: no answers, no streaming;
//! - `unplug@T1-T2`: the cable is pulled T1 after the start and put back at T2 (the
//!   pseudo-terminal closes, the driver sees a hang-up, a new one appears at the same path);
//!   `unplug@T1` pulls it for good; times as `5s`, `1.5s` or `500ms`;
//! - `none`: no fault (clears what came before it).
//!
//! Later items override earlier ones, except `unplug@`, which adds a window each time
//! (windows may not overlap).

use std::time::Duration;

use lewis_drivers::faults::Faults;

/// The syntax, for error messages and `--help`.
pub const FAULT_SYNTAX: &str = "noise=N, bad-crc-every=N, silent, unplug@T1-T2 (or unplug@T1: for good; T as 5s, 1.5s or 500ms) or none, comma-separated";

/// A time the cable is pulled, and when it is put back (`None`: never).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unplug {
    /// After the start.
    pub at: Duration,
    /// When it is plugged back in, after the start.
    pub until: Option<Duration>,
}

/// Faults of the device and the times its cable is pulled.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FaultPlan {
    /// Faults of the device's bytes, from the start.
    pub faults: Faults,
    /// Unplugging windows, in time order, not overlapping.
    pub unplugs: Vec<Unplug>,
}

/// A fault list that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FaultSpecError {
    /// An item that is none of the known faults.
    #[error("unknown fault `{item}`: use {FAULT_SYNTAX}")]
    Unknown {
        /// The item.
        item: String,
    },
    /// A count that is not a non-negative integer.
    #[error("fault `{item}` needs a non-negative integer after `=`")]
    BadCount {
        /// The item.
        item: String,
    },
    /// A time that cannot be read.
    #[error("fault `{item}`: `{time}` is not a time: write it as 5s, 1.5s or 500ms")]
    BadTime {
        /// The item.
        item: String,
        /// The time as written.
        time: String,
    },
    /// An unplugging window that ends before it starts, or overlaps another.
    #[error("fault `{item}`: {reason}")]
    BadWindow {
        /// The item.
        item: String,
        /// What is wrong.
        reason: String,
    },
}

/// Reads a fault list.
///
/// # Errors
/// The first item that is not a fault, or whose number or times cannot be read.
pub fn parse_faults(spec: &str) -> Result<FaultPlan, FaultSpecError> {
    let mut plan = FaultPlan::default();
    for item in spec
        .split(',')
        .map(str::trim)
        .filter(|item| !item.is_empty())
    {
        if let Some(window) = item.strip_prefix("unplug@") {
            let unplug = parse_window(item, window)?;
            plan.unplugs.push(unplug);
            continue;
        }
        let (key, value) = match item.split_once('=') {
            Some((key, value)) => (key.trim(), Some(value.trim())),
            None => (item, None),
        };
        let count = |value: Option<&str>| -> Result<u32, FaultSpecError> {
            value
                .and_then(|value| value.parse().ok())
                .ok_or_else(|| FaultSpecError::BadCount {
                    item: item.to_owned(),
                })
        };
        match (key, value) {
            ("noise", value) => plan.faults.noise_bytes = count(value)? as usize,
            ("bad-crc-every", value) => plan.faults.corrupt_checksum_every = count(value)?,
            ("silent", None) => plan.faults.silent = true,
            ("none", None) => plan = FaultPlan::default(),
            _ => {
                return Err(FaultSpecError::Unknown {
                    item: item.to_owned(),
                });
            }
        }
    }
    plan.unplugs.sort_by_key(|unplug| unplug.at);
    for pair in plan.unplugs.windows(2) {
        if pair[0].until.is_none_or(|until| until > pair[1].at) {
            return Err(FaultSpecError::BadWindow {
                item: format!("unplug@{}", show(pair[1].at)),
                reason: format!(
                    "it starts while the cable is still out since {}: unplugging windows may not overlap",
                    show(pair[0].at)
                ),
            });
        }
    }
    Ok(plan)
}

/// `T1-T2` or `T1`.
fn parse_window(item: &str, window: &str) -> Result<Unplug, FaultSpecError> {
    let (at, until) = match window.split_once('-') {
        Some((at, until)) => (at, Some(until)),
        None => (window, None),
    };
    let at = parse_time(item, at)?;
    let until = until.map(|until| parse_time(item, until)).transpose()?;
    if let Some(until) = until
        && until <= at
    {
        return Err(FaultSpecError::BadWindow {
            item: item.to_owned(),
            reason: "the cable must be put back after it is pulled: write unplug@T1-T2 with T2 later than T1".to_owned(),
        });
    }
    Ok(Unplug { at, until })
}

/// `5s`, `1.5s`, `500ms`: a time as written everywhere in Lewis ([`lewis_stdx`]), of at most
/// a day.
fn parse_time(item: &str, text: &str) -> Result<Duration, FaultSpecError> {
    let text = text.trim();
    let bad = || FaultSpecError::BadTime {
        item: item.to_owned(),
        time: text.to_owned(),
    };
    let time = lewis_stdx::parse_duration(text).map_err(|_| bad())?;
    if time > Duration::from_secs(86_400) {
        return Err(bad());
    }
    Ok(time)
}

fn show(time: Duration) -> String {
    format!("{}s", time.as_secs_f64())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(spec: &str, expected: &Result<FaultPlan, FaultSpecError>) {
        assert_eq!(&parse_faults(spec), expected, "{spec}");
    }

    fn faults(faults: Faults) -> Result<FaultPlan, FaultSpecError> {
        Ok(FaultPlan {
            faults,
            unplugs: Vec::new(),
        })
    }

    fn error_of(spec: &str) -> String {
        parse_faults(spec).unwrap_err().to_string()
    }

    #[test]
    fn fault_lists_are_read_or_rejected_with_the_item() {
        check("", &faults(Faults::default()));
        check(
            "noise=8, bad-crc-every=3",
            &faults(Faults {
                noise_bytes: 8,
                corrupt_checksum_every: 3,
                silent: false,
            }),
        );
        check(
            "silent",
            &faults(Faults {
                silent: true,
                ..Faults::default()
            }),
        );
        check("silent,none", &faults(Faults::default()));
        check(
            "noise=-1",
            &Err(FaultSpecError::BadCount {
                item: "noise=-1".to_owned(),
            }),
        );
        check(
            "unplug",
            &Err(FaultSpecError::Unknown {
                item: "unplug".to_owned(),
            }),
        );
        check(
            "silent=1",
            &Err(FaultSpecError::Unknown {
                item: "silent=1".to_owned(),
            }),
        );
    }

    #[test]
    fn unplugging_windows_are_read_in_time_order() {
        let secs = Duration::from_secs_f64;
        check(
            "unplug@5s-8s",
            &Ok(FaultPlan {
                faults: Faults::default(),
                unplugs: vec![Unplug {
                    at: secs(5.0),
                    until: Some(secs(8.0)),
                }],
            }),
        );
        check(
            "noise=2, unplug@20s, unplug@500ms-1.5s",
            &Ok(FaultPlan {
                faults: Faults {
                    noise_bytes: 2,
                    ..Faults::default()
                },
                unplugs: vec![
                    Unplug {
                        at: secs(0.5),
                        until: Some(secs(1.5)),
                    },
                    Unplug {
                        at: secs(20.0),
                        until: None,
                    },
                ],
            }),
        );
    }

    #[test]
    fn bad_unplugging_windows_say_what_to_write() {
        assert!(error_of("unplug@5").contains("`5` is not a time"));
        assert!(error_of("unplug@5s-x").contains("`x` is not a time"));
        assert!(error_of("unplug@-1s").contains("is not a time"));
        assert!(error_of("unplug@8s-5s").contains("T2 later than T1"));
        assert!(error_of("unplug@1s-5s,unplug@4s-6s").contains("may not overlap"));
        assert!(error_of("unplug@1s,unplug@4s-6s").contains("may not overlap"));
        assert!(error_of("unplg@1s").contains("unplug@T1-T2"));
    }
}
