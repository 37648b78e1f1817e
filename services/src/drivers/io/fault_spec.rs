//! The text form of injected faults, as `lewis fake-device --fault` takes it: a comma-separated
//! list of `noise=N` (garbage bytes before every frame), `bad-crc-every=N` (every N-th frame
//! with a corrupted checksum), `silent` (no answers, no streaming) and `none`.

use crate::drivers::faults::Faults;

/// A fault list that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FaultSpecError {
    /// An item that is none of the known faults.
    #[error(
        "unknown fault `{item}`: use noise=N, bad-crc-every=N, silent or none, comma-separated"
    )]
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
}

/// Reads a fault list; later items override earlier ones.
pub fn parse_faults(spec: &str) -> Result<Faults, FaultSpecError> {
    let mut faults = Faults::default();
    for item in spec
        .split(',')
        .map(str::trim)
        .filter(|item| !item.is_empty())
    {
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
            ("noise", value) => faults.noise_bytes = count(value)? as usize,
            ("bad-crc-every", value) => faults.corrupt_checksum_every = count(value)?,
            ("silent", None) => faults.silent = true,
            ("none", None) => faults = Faults::default(),
            _ => {
                return Err(FaultSpecError::Unknown {
                    item: item.to_owned(),
                });
            }
        }
    }
    Ok(faults)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(spec: &str, expected: &Result<Faults, FaultSpecError>) {
        assert_eq!(&parse_faults(spec), expected, "{spec}");
    }

    #[test]
    fn fault_lists_are_read_or_rejected_with_the_item() {
        check("", &Ok(Faults::default()));
        check(
            "noise=8, bad-crc-every=3",
            &Ok(Faults {
                noise_bytes: 8,
                corrupt_checksum_every: 3,
                silent: false,
            }),
        );
        check(
            "silent",
            &Ok(Faults {
                silent: true,
                ..Faults::default()
            }),
        );
        check("silent,none", &Ok(Faults::default()));
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
}
