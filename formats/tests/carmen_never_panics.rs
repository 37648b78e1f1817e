//! Property tests of the CARMEN importer: no text or bytes make it panic, and the time policy
//! always gives times that never go backwards.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;

use lewis_formats::import::carmen::parse::parse_line;
use lewis_formats::import::carmen::timing::{PrintedTime, StampInput, Stream, retime};
use lewis_formats::import::carmen::{CarmenImport, ImportOptions, LogReader, TimingOptions};
use proptest::prelude::*;

/// Lines that look like a CARMEN log often enough to reach deep into the parser.
fn log_line() -> impl Strategy<Value = String> {
    let word = prop_oneof![
        Just("FLASER".to_owned()),
        Just("RLASER".to_owned()),
        Just("ODOM".to_owned()),
        Just("PARAM".to_owned()),
        Just("ROBOTLASER1".to_owned()),
        Just("NEFF".to_owned()),
        Just("#".to_owned()),
        "-?[0-9]{1,3}(\\.[0-9]{1,6})?(e[+-][0-9]{1,3})?",
        Just("nan".to_owned()),
        Just("inf".to_owned()),
        Just("81.91".to_owned()),
        Just("0".to_owned()),
        Just("1000000000000".to_owned()),
        "[a-z]{1,5}",
        "\\PC{0,6}",
    ];
    prop::collection::vec(word, 0..24).prop_map(|w| w.join(" "))
}

fn import(bytes: Vec<u8>) {
    let reader = LogReader::from_reader(
        PathBuf::from("prop.log"),
        Box::new(std::io::Cursor::new(bytes.clone())),
    )
    .unwrap();
    let Ok(import) = CarmenImport::from_reader(reader, ImportOptions::default()) else {
        return;
    };
    let again = LogReader::from_reader(
        PathBuf::from("prop.log"),
        Box::new(std::io::Cursor::new(bytes)),
    )
    .unwrap();
    let mut last = 0;
    for m in import.messages_from(again).unwrap() {
        let m = m.unwrap();
        assert!(m.time_ns >= last);
        last = m.time_ns;
    }
}

proptest! {
    #[test]
    fn arbitrary_text_never_panics_the_line_parser(line in "\\PC*") {
        let _ = parse_line(&line);
    }

    #[test]
    fn log_like_lines_never_panic_the_importer(lines in prop::collection::vec(log_line(), 0..40)) {
        import(lines.join("\n").into_bytes());
    }

    #[test]
    fn arbitrary_bytes_never_panic_the_importer(bytes in prop::collection::vec(any::<u8>(), 0..600), gzip_magic in any::<bool>()) {
        let mut bytes = bytes;
        if gzip_magic {
            bytes.splice(0..0, [0x1f, 0x8b]);
        }
        import(bytes);
    }

    #[test]
    fn retimed_stamps_never_go_backwards(
        stamps in prop::collection::vec(
            (any::<bool>(), prop_oneof![
                Just(None),
                (-5.0f64..5000.0).prop_map(|s| Some(format!("{s}"))),
                (0u32..1000).prop_map(|s| Some(format!("{:e}", f64::from(s) * 1.0e7))),
                Just(Some("0".to_owned())),
                Just(Some("nan".to_owned())),
                Just(Some("1e300".to_owned())),
            ]),
            0..60,
        )
    ) {
        let inputs: Vec<StampInput> = stamps
            .iter()
            .zip(1..)
            .map(|((scan, text), line)| StampInput {
                stream: if *scan { Stream::Scan } else { Stream::Odometry },
                line,
                time: text.as_deref().and_then(PrintedTime::parse),
            })
            .collect();
        let out = retime(&inputs, &TimingOptions::default()).unwrap();
        prop_assert_eq!(out.times_ns.len(), inputs.len());
        prop_assert!(out.times_ns.iter().all(|t| *t >= 0));
        prop_assert!(out.times_ns.windows(2).all(|w| w[0] < w[1]));
        let r = &out.report;
        prop_assert_eq!(r.scans.total + r.odometry.total, inputs.len());
        for s in [&r.scans, &r.odometry] {
            let problems = s.missing + s.not_finite + s.zero + s.negative + s.out_of_range + s.coarse + s.out_of_order;
            prop_assert_eq!(s.kept + problems, s.total);
        }
    }
}
