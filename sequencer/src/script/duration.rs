//! A state's `timeout`: a duration as written everywhere in Lewis (`lewis_stdx`), longer
//! than zero.

use crate::diagnostic::Problem;

/// Reads a timeout: a positive duration (`500ms`, `30s`, `1.5s`, `2m`, `1h`), in nanoseconds.
pub(crate) fn parse_timeout_ns(text: &str) -> Result<i64, Problem> {
    let invalid = |reason| Problem::InvalidDuration {
        found: text.to_owned(),
        reason,
    };
    match lewis_stdx::parse_duration_ns(text) {
        Ok(0) => Err(invalid("it must be longer than zero")),
        Ok(ns) => Ok(ns),
        Err(e) => Err(invalid(e.reason)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expected: Result<i64, &str>) {
        let actual = parse_timeout_ns(text).map_err(|e| e.to_string());
        assert_eq!(actual, expected.map_err(str::to_owned), "for `{text}`");
    }

    #[test]
    fn a_timeout_is_a_duration_longer_than_zero() {
        check("1.5s", Ok(1_500_000_000));
        check(
            "0s",
            Err("invalid duration `0s`: it must be longer than zero"),
        );
        check("30", Err("invalid duration `30`: it has no unit"));
    }
}
