//! Durations as people type them, one way everywhere (command lines, scripts, fault
//! specifications): a number, an optional fraction and a unit, `500ms`, `30s`, `1.5s`,
//! `2m`, `1h`. A bare number is refused, since `5` could be seconds or milliseconds.

use std::fmt;
use std::time::Duration;

const UNITS: [(&str, i64); 4] = [
    ("ms", 1_000_000),
    ("s", 1_000_000_000),
    ("m", 60_000_000_000),
    ("h", 3_600_000_000_000),
];

/// Why a duration could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DurationError {
    /// The duration as written.
    pub found: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

impl DurationError {
    /// What to write instead.
    #[must_use]
    pub fn hint(&self) -> &'static str {
        "write a number and a unit: `500ms`, `30s`, `1.5s`, `2m` or `1h`"
    }
}

impl fmt::Display for DurationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid duration `{}`: {}", self.found, self.reason)
    }
}

impl std::error::Error for DurationError {}

/// Reads a duration that is zero or longer, in nanoseconds, exactly (no floating point).
///
/// # Errors
/// When `text` is not a number with one of the units `ms`, `s`, `m`, `h`, has a fraction
/// finer than a nanosecond, or is longer than `i64` nanoseconds (292 years).
pub fn parse_duration_ns(text: &str) -> Result<i64, DurationError> {
    let invalid = |reason| DurationError {
        found: text.to_owned(),
        reason,
    };
    let number_end = text
        .find(|c: char| !c.is_ascii_digit() && c != '.')
        .ok_or_else(|| invalid("it has no unit"))?;
    let (number, unit) = text.split_at(number_end);
    if number.is_empty() {
        return Err(invalid("it is not a number"));
    }
    let (_, unit_ns) = UNITS
        .iter()
        .find(|(name, _)| *name == unit)
        .ok_or_else(|| invalid("the unit must be `ms`, `s`, `m` or `h`"))?;
    let (whole, fraction) = number.split_once('.').unwrap_or((number, ""));
    if whole.is_empty() || fraction.contains('.') || (number.contains('.') && fraction.is_empty()) {
        return Err(invalid("it is not a number"));
    }
    let too_long = || invalid("it is too long");
    let whole: i64 = whole.parse().map_err(|_| too_long())?;
    let mut total = whole.checked_mul(*unit_ns).ok_or_else(too_long)?;
    // The fraction in units of `unit_ns`, digit by digit, exact down to the nanosecond.
    let mut scale = *unit_ns;
    for digit in fraction.chars() {
        scale /= 10;
        if scale == 0 {
            return Err(invalid("it is finer than a nanosecond"));
        }
        let value = i64::from(digit.to_digit(10).unwrap_or(0));
        total = total.checked_add(value * scale).ok_or_else(too_long)?;
    }
    Ok(total)
}

/// [`parse_duration_ns`] as a [`Duration`], for command-line flags (`--duration 8s`).
///
/// # Errors
/// As [`parse_duration_ns`].
pub fn parse_duration(text: &str) -> Result<Duration, DurationError> {
    let ns = parse_duration_ns(text)?;
    Ok(Duration::from_nanos(u64::try_from(ns).unwrap_or(0)))
}

/// Writes a duration in the largest unit that shows it exactly (`30s`, `1500ms`).
#[must_use]
pub fn format_duration_ns(ns: i64) -> String {
    for (name, unit_ns) in UNITS.iter().rev() {
        if ns % unit_ns == 0 {
            return format!("{}{name}", ns / unit_ns);
        }
    }
    format!("{ns}ns")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expected: Result<i64, &str>) {
        let actual = parse_duration_ns(text).map_err(|e| e.to_string());
        assert_eq!(actual, expected.map_err(str::to_owned), "for `{text}`");
    }

    #[test]
    fn whole_numbers_with_each_unit() {
        check("500ms", Ok(500_000_000));
        check("30s", Ok(30_000_000_000));
        check("2m", Ok(120_000_000_000));
        check("1h", Ok(3_600_000_000_000));
    }

    #[test]
    fn fractions_are_exact() {
        check("1.5s", Ok(1_500_000_000));
        check("0.25m", Ok(15_000_000_000));
        check("0.000001ms", Ok(1));
    }

    #[test]
    fn malformed_durations_say_why() {
        check("30", Err("invalid duration `30`: it has no unit"));
        check(
            "30x",
            Err("invalid duration `30x`: the unit must be `ms`, `s`, `m` or `h`"),
        );
        check("s", Err("invalid duration `s`: it is not a number"));
        check(".5s", Err("invalid duration `.5s`: it is not a number"));
        check("5.s", Err("invalid duration `5.s`: it is not a number"));
        check(
            "1.2.3s",
            Err("invalid duration `1.2.3s`: it is not a number"),
        );
        check("0s", Ok(0));
        check(
            "0.0000001ms",
            Err("invalid duration `0.0000001ms`: it is finer than a nanosecond"),
        );
        check(
            "99999999999h",
            Err("invalid duration `99999999999h`: it is too long"),
        );
        check("-1s", Err("invalid duration `-1s`: it is not a number"));
    }

    #[test]
    fn flags_read_as_std_durations() {
        assert_eq!(parse_duration("8s"), Ok(Duration::from_secs(8)));
        assert_eq!(parse_duration("500ms"), Ok(Duration::from_millis(500)));
        assert!(parse_duration("8").is_err());
    }

    #[test]
    fn formatting_picks_the_largest_exact_unit() {
        assert_eq!(format_duration_ns(30_000_000_000), "30s");
        assert_eq!(format_duration_ns(1_500_000_000), "1500ms");
        assert_eq!(format_duration_ns(120_000_000_000), "2m");
        assert_eq!(format_duration_ns(1), "1ns");
    }
}
