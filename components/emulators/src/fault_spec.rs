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
//!
//! The words and their parsing are the serial-line family of the one fault vocabulary,
//! [`lewis_service::fault`]; this module gives them the emulators' names.

pub use lewis_service::fault::{
    LINE_FAULT_SYNTAX as FAULT_SYNTAX, LineFaultError as FaultSpecError,
    LineFaultPlan as FaultPlan, Unplug, parse_line_faults as parse_faults,
};

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use lewis_drivers::faults::Faults;

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
                suggestion: None,
            }),
        );
        check(
            "silent=1",
            &Err(FaultSpecError::Unknown {
                item: "silent=1".to_owned(),
                suggestion: None,
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
