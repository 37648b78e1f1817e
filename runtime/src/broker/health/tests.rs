//! Table-driven tests of the data checks: one `check` helper feeds a monitor and returns
//! the check that fired, if any.

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Blobs, Egomotion, Header, Pose3D, RangeFinder};

use super::{Check, DataMonitor};
use lewis_robot::{DataChecks, OnCheckFailure};

const MS: i64 = 1_000_000;

/// A 10 Hz range finder's scan number `n`, with noise in its readings.
fn scan(n: u32, publish_ns: i64) -> Vec<u8> {
    let ranges: Vec<f64> = (0..8)
        .map(|i| 2.0 + f64::from((n * 7 + i * 13) % 17) * 0.001)
        .collect();
    scan_of(ranges, n, publish_ns)
}

fn scan_of(ranges: Vec<f64>, n: u32, publish_ns: i64) -> Vec<u8> {
    let count = ranges.len();
    cdr::to_vec(&RangeFinder {
        header: header(n, publish_ns),
        range_count: i32::try_from(count).unwrap(),
        ranges,
        max_range: 8.0,
        uniform: true,
        sensor_positions: vec![Pose3D::default(); count],
        ..RangeFinder::default()
    })
}

fn header(seq: u32, publish_ns: i64) -> Header {
    Header {
        provider: "laser".into(),
        seq: u64::from(seq),
        publish_time_ns: publish_ns,
        ..Header::default()
    }
}

/// A named stream, when it is last polled (ms) and the check expected to fire, when (ms).
type Case = (&'static str, Vec<Sample>, i64, Option<(Check, i64)>);

/// One sample: when the broker sees it, its publish time and bytes.
struct Sample {
    at_ns: i64,
    publish_ns: i64,
    bytes: Vec<u8>,
}

/// A healthy stream of `count` scans at `period_ms`, from time 0.
fn stream(count: u32, period_ms: i64) -> Vec<Sample> {
    (0..count)
        .map(|n| {
            let at_ns = i64::from(n) * period_ms * MS;
            Sample {
                at_ns,
                publish_ns: at_ns - MS,
                bytes: scan(n, at_ns - MS),
            }
        })
        .collect()
}

/// Feeds the samples to a monitor of `interface` at 10 Hz declared, then polls it at
/// `end_ns`; the first check that fired and when, or `None`.
fn check(
    interface: &str,
    checks: DataChecks,
    samples: &[Sample],
    end_ns: i64,
) -> Option<(Check, i64)> {
    let mut monitor = DataMonitor::new(interface, checks, Some(10.0), 0);
    for s in samples {
        if let Err(failure) = monitor.sample(s.at_ns, s.publish_ns, &s.bytes) {
            return Some((failure.check, s.at_ns));
        }
    }
    monitor.poll(end_ns).err().map(|f| (f.check, end_ns))
}

fn range_finder() -> DataChecks {
    DataChecks::default_for("RangeFinder")
}

#[test]
fn a_healthy_range_finder_passes_every_check() {
    assert_eq!(
        check("RangeFinder", range_finder(), &stream(50, 100), 4_950 * MS),
        None
    );
}

#[test]
fn each_bad_stream_fires_its_check() {
    let nan = {
        let mut s = stream(10, 100);
        let mut ranges = vec![1.0; 8];
        ranges[3] = f64::NAN;
        s[5].bytes = scan_of(ranges, 5, s[5].publish_ns);
        s
    };
    let out_of_range = {
        let mut s = stream(10, 100);
        s[4].bytes = scan_of(vec![9.5; 8], 4, s[4].publish_ns);
        s
    };
    let negative = {
        let mut s = stream(10, 100);
        s[4].bytes = scan_of(vec![-0.1; 8], 4, s[4].publish_ns);
        s
    };
    let negative_max_range = {
        let mut s = stream(10, 100);
        let mut scan: RangeFinder = cdr::from_bytes(&s[3].bytes).unwrap();
        scan.max_range = -1.0;
        s[3].bytes = cdr::to_vec(&scan);
        s
    };
    let garbage = {
        let mut s = stream(10, 100);
        s[6].bytes = vec![0xAB; 40];
        s
    };
    let sizes = {
        let mut s = stream(10, 100);
        let mut scan: RangeFinder = cdr::from_bytes(&s[2].bytes).unwrap();
        scan.range_count = 9;
        s[2].bytes = cdr::to_vec(&scan);
        s
    };
    let frozen = {
        let mut s = stream(10, 100);
        for sample in s.iter_mut().skip(3) {
            // The same readings in new headers: the device repeats itself.
            sample.bytes = scan(3, sample.publish_ns);
        }
        s
    };
    let stale = {
        let mut s = stream(10, 100);
        s[7].publish_ns = s[7].at_ns - 600 * MS;
        s
    };
    // A third of the rate: one sample in three.
    let slow: Vec<Sample> = stream(30, 100).into_iter().step_by(3).collect();
    // Silence after a good start.
    let silent = stream(5, 100);

    let cases: [Case; 10] = [
        ("nan", nan, 2_000, Some((Check::Values, 500))),
        (
            "out of range",
            out_of_range,
            2_000,
            Some((Check::Values, 400)),
        ),
        ("negative", negative, 2_000, Some((Check::Values, 400))),
        (
            "negative max_range",
            negative_max_range,
            2_000,
            Some((Check::Values, 300)),
        ),
        ("garbage", garbage, 2_000, Some((Check::Values, 600))),
        ("sizes", sizes, 2_000, Some((Check::Values, 200))),
        // The fifth identical payload: scans 3, 4, 5, 6, 7.
        ("frozen", frozen, 2_000, Some((Check::Frozen, 700))),
        ("stale", stale, 2_000, Some((Check::Freshness, 700))),
        // Judged from the window's end: 4 samples (0, 300, 600, 900 ms) of the 5 needed.
        ("slow", slow, 2_900, Some((Check::Rate, 1_200))),
        ("silent", silent, 2_000, Some((Check::Rate, 2_000))),
    ];
    for (name, samples, end_ms, expected) in cases {
        let expected = expected.map(|(c, ms)| (c, ms * MS));
        assert_eq!(
            check("RangeFinder", range_finder(), &samples, end_ms * MS),
            expected,
            "{name}"
        );
    }
}

#[test]
fn a_check_turned_off_does_not_fire() {
    let frozen: Vec<Sample> = stream(10, 100)
        .into_iter()
        .map(|s| Sample {
            bytes: scan(0, s.publish_ns),
            ..s
        })
        .collect();
    let off = DataChecks {
        frozen_count: None,
        ..range_finder()
    };
    assert_eq!(check("RangeFinder", off, &frozen, 900 * MS), None);
    let silent = stream(2, 100);
    let off = DataChecks {
        min_rate_fraction: 0.0,
        ..range_finder()
    };
    assert_eq!(check("RangeFinder", off, &silent, 10_000 * MS), None);
    let mut garbage = stream(3, 100);
    garbage[1].bytes = vec![1, 2, 3];
    let off = DataChecks {
        values: false,
        ..range_finder()
    };
    assert_eq!(check("RangeFinder", off, &garbage, 250 * MS), None);
    assert_eq!(
        check("RangeFinder", DataChecks::none(), &garbage, 10_000 * MS),
        None
    );
}

#[test]
fn odometry_at_rest_and_empty_blob_lists_are_never_frozen() {
    for (interface, bytes) in [
        ("Egomotion", cdr::to_vec(&Egomotion::default())),
        ("Blobs", cdr::to_vec(&Blobs::default())),
    ] {
        let samples: Vec<Sample> = (0..50)
            .map(|n| Sample {
                at_ns: n * 100 * MS,
                publish_ns: n * 100 * MS,
                bytes: bytes.clone(),
            })
            .collect();
        let checks = DataChecks::default_for(interface);
        assert_eq!(
            check(interface, checks, &samples, 4_950 * MS),
            None,
            "{interface}"
        );
    }
}

#[test]
fn the_rate_is_judged_only_a_window_after_the_start() {
    let mut monitor = DataMonitor::new("RangeFinder", range_finder(), Some(10.0), 5_000 * MS);
    assert_eq!(monitor.deadline(), Some(6_000 * MS));
    assert_eq!(monitor.poll(5_999 * MS), Ok(()));
    assert_eq!(
        monitor.poll(6_000 * MS).map_err(|f| f.check),
        Err(Check::Rate)
    );
    // Without a declared rate there is nothing to judge.
    let monitor = DataMonitor::new("RangeFinder", range_finder(), None, 0);
    assert_eq!(monitor.deadline(), None);
}

#[test]
fn a_failure_says_what_the_robot_file_asks_for() {
    let checks = DataChecks {
        on_failure: OnCheckFailure::Degraded,
        ..range_finder()
    };
    let mut monitor = DataMonitor::new("RangeFinder", checks, Some(10.0), 0);
    let failure = monitor.sample(0, 0, b"not cdr").unwrap_err();
    assert_eq!(failure.check, Check::Values);
    assert_eq!(failure.on_failure, OnCheckFailure::Degraded);
    assert!(
        failure
            .to_string()
            .starts_with("values check failed: does not decode as RangeFinder"),
        "{failure}"
    );
}

#[test]
fn a_non_finite_number_is_named_by_its_place() {
    let odometry = Egomotion {
        translation_velocity: f64::INFINITY,
        ..Egomotion::default()
    };
    let mut monitor = DataMonitor::new("Egomotion", DataChecks::default_for("Egomotion"), None, 0);
    let failure = monitor.sample(0, 0, &cdr::to_vec(&odometry)).unwrap_err();
    assert_eq!(
        failure.reason,
        "`translation_velocity` is inf, not a finite number"
    );
}

#[test]
fn every_interface_decodes_its_own_default_message() {
    for name in lewis_interfaces::interface_names() {
        let info = lewis_interfaces::interface_info(name).unwrap();
        let bytes = lewis_interfaces::msg::default_message(info.publication.name).unwrap();
        let checks = DataChecks {
            frozen_count: None,
            ..DataChecks::default_for(name)
        };
        let mut monitor = DataMonitor::new(name, checks, None, 0);
        // A range finder's default says no max_range: its ranges are not judged.
        assert_eq!(monitor.sample(0, 0, &bytes), Ok(()), "{name}");
    }
}

#[test]
fn check_names_round_trip() {
    for check in Check::ALL {
        assert_eq!(Check::parse(check.as_str()), Some(check));
    }
    assert_eq!(Check::parse("speed"), None);
}
