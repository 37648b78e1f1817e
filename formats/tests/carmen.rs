//! The CARMEN importer on the real logs of `../shared/data/carmen/` (see its README for the
//! table of scans, beams and broken timestamps these tests check), and on small logs made
//! here: malformed lines, gzip against plain, the strict time policy.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::io::Write;
use std::path::{Path, PathBuf};

use flate2::Compression;
use flate2::write::GzEncoder;
use lewis_formats::import::carmen::parse::LaserId;
use lewis_formats::import::carmen::{
    CarmenImport, ImportError, ImportOptions, ImportedMessage, OdometrySource, Payload,
    PeriodSource, ReadingCounts, StampProblem, TimePolicy, TimingOptions, robot_toml,
};

fn data_file(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/carmen")
        .join(name);
    assert!(
        path.exists(),
        "missing test data {}: these tests need the CARMEN logs of ../shared/data/carmen/ \
         (see ../shared/data/README.md)",
        path.display()
    );
    path
}

/// Everything an import produced, by channel.
struct Imported {
    import: CarmenImport,
    by_channel: BTreeMap<String, Vec<ImportedMessage>>,
    order: Vec<i64>,
    readings: ReadingCounts,
}

fn import_all(path: &Path, options: ImportOptions) -> Imported {
    let import = CarmenImport::open(path, options).unwrap();
    let mut by_channel: BTreeMap<String, Vec<ImportedMessage>> = BTreeMap::new();
    let mut order = Vec::new();
    let mut messages = import.messages().unwrap();
    for m in messages.by_ref() {
        let m = m.unwrap();
        order.push(m.time_ns);
        by_channel.entry(m.channel.clone()).or_default().push(m);
    }
    let readings = messages.reading_counts();
    Imported {
        import,
        by_channel,
        order,
        readings,
    }
}

/// The scan-timestamp problems the README's table names, per file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct ScanClock {
    out_of_order: usize,
    coarse: usize,
    negative: usize,
    zero: usize,
}

/// Imports a real log and checks it against the README's table and the invariants every
/// import must keep.
fn check_log(file: &str, scans: u64, beams: usize, clock: ScanClock) -> Imported {
    let imported = import_all(&data_file(file), ImportOptions::default());
    let report = imported.import.report();
    assert_eq!(report.counts.scans_of(LaserId::Front), scans, "{file}");
    assert_eq!(report.laser.beams(), beams, "{file}");
    assert_eq!(report.laser.beam_counts.len(), 1, "{file}: one beam count");
    assert_eq!(report.counts.malformed, 0, "{file}: {:?}", report.malformed);
    assert!(report.gzip);

    // The scan clock's problems, as the README says.
    let t = &report.timing.scans;
    let found = ScanClock {
        out_of_order: t.out_of_order,
        coarse: t.coarse,
        negative: t.negative,
        zero: t.zero,
    };
    assert_eq!(found, clock, "{file}: {t:?}");
    let broken = clock.out_of_order + clock.coarse + clock.negative + clock.zero;
    assert_eq!(t.retimed(), broken, "{file}");
    assert_eq!(t.total, usize::try_from(scans).unwrap());
    let warnings = report.warnings().join("\n");
    assert_eq!(
        warnings.contains("laser scan timestamps"),
        broken > 0,
        "{file}: {warnings}"
    );

    // One reading and one Distance per scan, a sonar reading every other scan, one
    // Egomotion per ODOM line, a heartbeat of each source every 100 ms of the log.
    let count = |channel: &str| imported.by_channel.get(channel).map_or(0, Vec::len);
    let scans = usize::try_from(scans).unwrap();
    assert_eq!(count("/laser/RangeFinder"), scans, "{file}");
    assert_eq!(count("/distance/Distance"), scans, "{file}");
    assert_eq!(count("/sonar/RangeFinder"), scans.div_ceil(2), "{file}");
    assert_eq!(report.odometry, OdometrySource::OdomLines);
    assert_eq!(
        count("/base/Egomotion"),
        usize::try_from(report.counts.odometry).unwrap()
    );
    let (first, last) = (imported.order[0], *imported.order.last().unwrap());
    let heartbeats = usize::try_from((last - first) / 100_000_000 + 1).unwrap();
    for source in ["laser", "base", "sonar"] {
        assert_eq!(
            count(&format!("/lewis/health/{source}")),
            heartbeats,
            "{file}"
        );
    }
    assert_eq!(imported.by_channel.len(), 7, "{file}");

    // Time never goes backwards: non-decreasing over the import, strictly increasing per
    // channel, never negative; headers agree with the log times and count from 1.
    assert!(imported.order.windows(2).all(|w| w[0] <= w[1]), "{file}");
    assert!(imported.order.iter().all(|t| *t >= 0), "{file}");
    for (channel, messages) in &imported.by_channel {
        assert!(
            messages.windows(2).all(|w| w[0].time_ns < w[1].time_ns),
            "{file} {channel}"
        );
        for (k, m) in messages.iter().enumerate() {
            let h = m.payload.header();
            assert_eq!(h.seq, u64::try_from(k + 1).unwrap());
            assert_eq!(h.publish_time_ns, m.time_ns);
            assert!(
                channel.starts_with(&format!("/{}/", h.provider))
                    || *channel == format!("/lewis/health/{}", h.provider)
            );
        }
    }

    // Every reading is within [0, max_range], with a pose per beam.
    let max = report.laser.max_range_m;
    for m in &imported.by_channel["/laser/RangeFinder"] {
        let Payload::RangeFinder(rf) = &m.payload else {
            panic!("{m:?}")
        };
        assert_eq!(usize::try_from(rf.range_count).unwrap(), beams);
        assert_eq!(rf.ranges.len(), beams);
        assert_eq!(rf.sensor_positions.len(), beams);
        assert!(rf.uniform && rf.max_range == max);
        assert!(rf.ranges.iter().all(|r| (0.0..=max).contains(r)));
    }
    for m in &imported.by_channel["/sonar/RangeFinder"] {
        let Payload::RangeFinder(rf) = &m.payload else {
            panic!("{m:?}")
        };
        assert!(!rf.uniform);
        assert_eq!((rf.ranges.len(), rf.sensor_positions.len()), (24, 24));
        assert!(rf.ranges.iter().all(|r| (0.0..=rf.max_range).contains(r)));
    }
    assert_eq!(
        imported.readings.readings,
        u64::try_from(scans * beams).unwrap(),
        "{file}"
    );

    // The robot description names the providers and is valid for the runtime.
    let toml = robot_toml(report);
    let interfaces: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let robot = lewis_robot::parse(&toml, Path::new("imported.toml"), &interfaces)
        .unwrap_or_else(|e| panic!("{file}: {e}\n{toml}"));
    let provides = |name: &str| -> Vec<String> {
        robot
            .service(name)
            .unwrap()
            .provides
            .iter()
            .map(|p| p.interface.clone())
            .collect()
    };
    assert_eq!(provides("laser"), ["RangeFinder"]);
    assert_eq!(provides("base"), ["Egomotion", "Synchrodrive"]);
    assert_eq!(provides("sonar"), ["RangeFinder"]);
    assert_eq!(provides("distance"), ["Distance"]);
    assert_eq!(provides("obstacle_avoider"), ["Mover"]);
    assert_eq!(provides("vector_mover"), ["Mover"]);
    // The Distance readings are the distance service's, computed from the laser readings
    // they name.
    for (m, laser) in imported.by_channel["/distance/Distance"]
        .iter()
        .zip(&imported.by_channel["/laser/RangeFinder"])
    {
        let h = m.payload.header();
        assert_eq!(h.inputs.len(), 1);
        assert_eq!(
            (h.inputs[0].channel.as_str(), h.inputs[0].seq),
            ("/laser/RangeFinder", laser.payload.header().seq)
        );
        assert_eq!(m.time_ns, laser.time_ns);
    }
    imported
}

#[test]
fn freiburg_079_imports_with_its_clock_as_logged() {
    let imported = check_log(
        "freiburg-079-corrected.log.gz",
        4791,
        360,
        ScanClock::default(),
    );
    let report = imported.import.report();
    // The max range comes from the log's PARAM robot_front_laser_max 80.99.
    assert_eq!(report.laser.max_range_m, 80.99);
    assert!(report.laser.max_range_line.is_some());
    // About 4.5 scans per second over its 1061 s.
    let rate = report.laser.rate_hz.unwrap();
    assert!((4.0..5.0).contains(&rate), "{rate}");
    assert!(matches!(
        report.timing.scan_period_source,
        PeriodSource::Measured { .. }
    ));
    // Every scan is followed by an ODOM line stamped 0 (or with garbage) by the tool that
    // corrected the log: 4772 zero, 1 negative, 4 tiny denormals out of order.
    assert_eq!(report.timing.odometry.zero, 4772);
    assert_eq!(report.timing.odometry.negative, 1);

    // The first scan by hand: `FLASER 360 1.65 1.66 ... 0.227623 pippo 0.227623`.
    let Payload::RangeFinder(first) = &imported.by_channel["/laser/RangeFinder"][0].payload else {
        panic!()
    };
    assert_eq!(first.ranges[0], 1.65);
    assert_eq!(first.ranges[1], 1.66);
    assert_eq!(first.header.provider, "laser");
    // The ODOM line before it has the same stamp: the scan comes 1 ns after it.
    assert_eq!(
        imported.by_channel["/laser/RangeFinder"][0].time_ns,
        227_623_001
    );
    assert!((first.theta_offset + FRAC_PI_2).abs() < 1e-12);
    assert!((first.theta_separation.to_degrees() - 0.5).abs() < 1e-12);
    assert!((first.sensor_positions[359].theta.to_degrees() - 89.5).abs() < 1e-9);
    // The first ODOM line: `ODOM 0 0 0 0 0 0 0.015885 pippo 0.015885`.
    let first_odometry = &imported.by_channel["/base/Egomotion"][0];
    assert_eq!(first_odometry.time_ns, 15_885_000);
    // No-return readings (81.91 in this log) are published as the max range.
    assert!(imported.readings.no_return > 30_000);
    assert_eq!(imported.readings.invalid, 0);
}

#[test]
fn intel_scan_clock_goes_backwards_four_times() {
    let imported = check_log(
        "intel-corrected.log.gz",
        910,
        180,
        ScanClock {
            out_of_order: 4,
            ..ScanClock::default()
        },
    );
    let report = imported.import.report();
    assert_eq!(
        report.laser.max_range_m, 81.91,
        "no PARAM: the SICK default"
    );
    assert_eq!(report.laser.max_range_line, None);
}

#[test]
fn aces_imports_with_fifty_metre_no_returns() {
    let imported = check_log("aces-corrected.log.gz", 440, 180, ScanClock::default());
    // Its 620 readings of exactly 50 are "no return" codes.
    assert_eq!(imported.readings.no_return, 620);
}

#[test]
fn freiburg_101_imports() {
    check_log(
        "freiburg-101-corrected.log.gz",
        292,
        360,
        ScanClock::default(),
    );
}

#[test]
fn seattle_imports() {
    check_log("seattle-corrected.log.gz", 241, 361, ScanClock::default());
}

#[test]
fn edmonton_imports_with_its_ten_metre_max_range() {
    let imported = check_log("edmonton-corrected.log.gz", 340, 180, ScanClock::default());
    // PARAM robot_front_laser_max 10: the real readings beyond it are counted apart.
    assert_eq!(imported.import.report().laser.max_range_m, 10.0);
    assert!(imported.readings.beyond_max_range > 0);
    assert!(imported.readings.no_return > 3000);
}

#[test]
fn csail_coarse_stamps_are_retimed_from_the_nominal_scan_period() {
    let imported = check_log(
        "csail-corrected.log.gz",
        406,
        361,
        ScanClock {
            coarse: 406,
            ..ScanClock::default()
        },
    );
    let timing = &imported.import.report().timing;
    assert_eq!(timing.scan_period_source, PeriodSource::Nominal);
    assert_eq!(timing.scans.kept, 0);
    let scans = &imported.by_channel["/laser/RangeFinder"];
    assert_eq!(scans[1].time_ns - scans[0].time_ns, 200_000_000);
    let warnings = imported.import.report().warnings().join("\n");
    assert!(
        warnings.contains("406 of 406 unusable (406 printed too coarsely"),
        "{warnings}"
    );
}

#[test]
fn infinite_corridor_negative_then_wrapped_stamps_are_retimed() {
    check_log(
        "infinite-corridor-corrected.log.gz",
        1941,
        180,
        ScanClock {
            negative: 4,
            coarse: 1937,
            ..ScanClock::default()
        },
    );
}

#[test]
fn orebro_zero_stamps_are_retimed() {
    let imported = check_log(
        "orebro-corrected.log.gz",
        237,
        181,
        ScanClock {
            zero: 237,
            ..ScanClock::default()
        },
    );
    assert!(imported.readings.no_return > 900, "32.76x codes");
}

#[test]
fn the_strict_policy_refuses_a_log_with_unusable_scan_stamps() {
    let options = ImportOptions {
        timing: TimingOptions {
            policy: TimePolicy::RejectBrokenScans,
            ..TimingOptions::default()
        },
        ..ImportOptions::default()
    };
    let path = data_file("orebro-corrected.log.gz");
    let err = CarmenImport::open(&path, options).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, ImportError::Timing { .. }));
    assert!(
        text.starts_with(&format!(
            "{}: 237 of 237 laser scan timestamps are unusable (237 zero; the first, zero, at line",
            path.display()
        )),
        "{text}"
    );
    // A log whose scan clock is good passes, though its odometry stamps are broken.
    assert!(CarmenImport::open(&data_file("seattle-corrected.log.gz"), options).is_ok());
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut encoder = GzEncoder::new(Vec::new(), Compression::default());
    encoder.write_all(bytes).unwrap();
    encoder.finish().unwrap()
}

const SMALL_LOG: &str = "\
# a hand-made log
PARAM robot_front_laser_max 8.0 nohost 0
ODOM 0 0 0 0.1 0 0 1.0 host 1.0
FLASER 3 1.0 9.5 81.91 0 0 0 0 0 0 1.1 host 1.1
FLASER 3 1.0 2.0 oops 0 0 0 0 0 0 1.2 host 1.2
NEFF 10
TRUEPOS 1 2 3 4 5 6 1.3 host 1.3
ODOM 0.3 0.4 0 0.1 0 0 1.3 host 1.3
FLASER 4000000000 1.0
FLASER 3 1.5 2.5 3.5 0 0 0 0.3 0.4 0 1.4 host 1.4
";

#[test]
fn malformed_lines_are_reported_with_file_and_line_and_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let imported = import_all(&path, ImportOptions::default());
    let report = imported.import.report();
    assert_eq!(report.counts.malformed, 2);
    let errors: Vec<String> = report.malformed.iter().map(ToString::to_string).collect();
    assert_eq!(
        errors,
        [
            format!(
                "{}:5: FLASER field `r3` is `oops`: expected a range in m",
                path.display()
            ),
            format!(
                "{}:9: FLASER declares 4000000000 readings but only 1 fields follow the count: the line is truncated or the count is wrong",
                path.display()
            ),
        ]
    );
    assert_eq!(report.counts.unknown["TRUEPOS"], 1);
    assert_eq!(report.counts.ignored["NEFF"], 1);
    assert_eq!(report.counts.comments, 1);
    assert!(!report.gzip);
    assert!(report.timing.is_clean(), "{:?}", report.timing);
    assert_eq!(report.laser.max_range_m, 8.0);

    let scans = &imported.by_channel["/laser/RangeFinder"];
    assert_eq!(scans.len(), 2);
    let Payload::RangeFinder(first) = &scans[0].payload else {
        panic!()
    };
    // 9.5 is beyond the 8 m max range, 81.91 is a no-return code: both read 8.
    assert_eq!(first.ranges, [1.0, 8.0, 8.0]);
    assert_eq!(scans[0].time_ns, 1_100_000_000);
    let Payload::Egomotion(second) = &imported.by_channel["/base/Egomotion"][1].payload else {
        panic!()
    };
    assert_eq!((second.pose.x, second.distance_travelled), (0.3, 0.5));
    assert_eq!(
        imported.readings,
        ReadingCounts {
            readings: 6,
            hits: 4,
            no_return: 1,
            beyond_max_range: 1,
            invalid: 0
        }
    );
    let warnings = report.warnings().join("\n");
    assert!(
        warnings.contains("2 malformed lines skipped; the first: "),
        "{warnings}"
    );
    assert!(
        warnings.contains("line types not imported: 1 TRUEPOS"),
        "{warnings}"
    );
}

fn all_messages(path: &Path) -> Vec<ImportedMessage> {
    let import = CarmenImport::open(path, ImportOptions::default()).unwrap();
    import.messages().unwrap().map(Result::unwrap).collect()
}

#[test]
fn gzip_is_told_by_its_magic_bytes_not_its_name() {
    let dir = tempfile::tempdir().unwrap();
    // Plain text named .gz, gzip named .log: the same messages either way.
    let plain = write(dir.path(), "plain.log.gz", SMALL_LOG.as_bytes());
    let packed = write(dir.path(), "packed.log", &gzip(SMALL_LOG.as_bytes()));
    let from_plain = all_messages(&plain);
    assert!(!from_plain.is_empty());
    assert_eq!(from_plain, all_messages(&packed));
    let report = CarmenImport::open(&packed, ImportOptions::default()).unwrap();
    assert!(report.report().gzip);
}

#[test]
fn a_real_log_decompressed_gives_the_same_messages() {
    let dir = tempfile::tempdir().unwrap();
    let packed = data_file("orebro-corrected.log.gz");
    let mut text = Vec::new();
    std::io::Read::read_to_end(
        &mut flate2::read::GzDecoder::new(std::fs::File::open(&packed).unwrap()),
        &mut text,
    )
    .unwrap();
    let plain = write(dir.path(), "orebro.log", &text);
    assert_eq!(all_messages(&packed), all_messages(&plain));
}

#[test]
fn a_gzip_file_cut_short_is_a_read_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = gzip(SMALL_LOG.repeat(50).as_bytes());
    bytes.truncate(bytes.len() / 2);
    let path = write(dir.path(), "cut.log.gz", &bytes);
    let err = CarmenImport::open(&path, ImportOptions::default()).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, ImportError::Read(_)), "{text}");
    assert!(
        text.starts_with(&path.display().to_string()) && text.contains("gzip"),
        "{text}"
    );
}

#[test]
fn a_log_without_scans_is_refused_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "odom.log", b"ODOM 0 0 0 0 0 0 1.0 h 1.0\n");
    let err = CarmenImport::open(&path, ImportOptions::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{}: no laser scans (FLASER or ROBOTLASER1 lines) among its 1 lines: nothing to import as a RangeFinder",
            path.display()
        )
    );
}

#[test]
fn without_odom_lines_egomotion_comes_from_the_scans() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "scans.log",
        b"FLASER 2 1 1 0 0 0 1 2 0.5\nFLASER 2 1 1 0 0 0 4 6 0.5\n",
    );
    let imported = import_all(&path, ImportOptions::default());
    let report = imported.import.report();
    assert_eq!(report.odometry, OdometrySource::ScanPoses);
    assert_eq!(report.timing.scans.missing, 2);
    let ego = &imported.by_channel["/base/Egomotion"];
    assert_eq!(ego.len(), 2);
    let Payload::Egomotion(last) = &ego[1].payload else {
        panic!()
    };
    assert_eq!(
        (last.pose.x, last.pose.y, last.distance_travelled),
        (4.0, 6.0, 5.0)
    );
    assert_eq!(
        ego[1].time_ns,
        imported.by_channel["/laser/RangeFinder"][1].time_ns
    );
    assert!(report.timing.scans.first_problem == Some((1, StampProblem::Missing)));
}

#[test]
fn no_sonar_is_derived_when_asked_for_none() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let imported = import_all(
        &path,
        ImportOptions {
            sonar: None,
            ..ImportOptions::default()
        },
    );
    assert!(!imported.by_channel.contains_key("/sonar/RangeFinder"));
    assert!(!robot_toml(imported.import.report()).contains("name = \"sonar\""));
}

#[test]
fn payloads_carry_their_schema_and_decode_back_from_cdr() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let mut buffer = Vec::new();
    let mut schemas = std::collections::BTreeSet::new();
    for m in all_messages(&path) {
        m.payload.encode_to_vec(&mut buffer);
        let decoded = match &m.payload {
            Payload::RangeFinder(_) => {
                Payload::RangeFinder(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
            Payload::Distance(_) => {
                Payload::Distance(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
            Payload::Egomotion(_) => {
                Payload::Egomotion(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
            Payload::Health(_) => {
                Payload::Health(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
            Payload::ImageSource(_) => {
                Payload::ImageSource(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
            Payload::Blobs(_) => {
                Payload::Blobs(lewis_interfaces::cdr::from_bytes(&buffer).unwrap())
            }
        };
        assert_eq!(decoded, m.payload);
        assert!(
            m.payload.schema_text().contains("range")
                || ["Egomotion", "Health"].contains(&m.payload.interface())
        );
        schemas.insert((m.payload.schema_name(), m.channel.clone()));
    }
    assert_eq!(
        schemas.into_iter().collect::<Vec<_>>(),
        [
            (
                "lewis_interfaces/msg/Distance",
                "/distance/Distance".to_owned()
            ),
            (
                "lewis_interfaces/msg/Egomotion",
                "/base/Egomotion".to_owned()
            ),
            (
                "lewis_interfaces/msg/Health",
                "/lewis/health/base".to_owned()
            ),
            (
                "lewis_interfaces/msg/Health",
                "/lewis/health/laser".to_owned()
            ),
            (
                "lewis_interfaces/msg/Health",
                "/lewis/health/sonar".to_owned()
            ),
            (
                "lewis_interfaces/msg/RangeFinder",
                "/laser/RangeFinder".to_owned()
            ),
            (
                "lewis_interfaces/msg/RangeFinder",
                "/sonar/RangeFinder".to_owned()
            ),
        ]
    );
}

#[test]
fn a_limit_imports_the_log_up_to_its_nth_scan() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let imported = import_all(
        &path,
        ImportOptions {
            max_scans: Some(1),
            ..ImportOptions::default()
        },
    );
    let report = imported.import.report();
    assert!(report.cut_short);
    assert_eq!(
        report.counts.odometry, 1,
        "the ODOM line after the scan is not read"
    );
    let counts: Vec<(&str, usize)> = imported
        .by_channel
        .iter()
        .map(|(c, m)| (c.as_str(), m.len()))
        .collect();
    assert_eq!(
        counts,
        [
            ("/base/Egomotion", 1),
            ("/distance/Distance", 1),
            ("/laser/RangeFinder", 1),
            ("/lewis/health/base", 2),
            ("/lewis/health/laser", 2),
            ("/lewis/health/sonar", 2),
            ("/sonar/RangeFinder", 1),
        ]
    );
    let warnings = report.warnings().join("\n");
    assert!(
        warnings.contains("only the log up to its scan 1 was imported (line 4)"),
        "{warnings}"
    );
    // The whole log has two scans: a limit beyond it cuts nothing.
    let all = import_all(
        &path,
        ImportOptions {
            max_scans: Some(5),
            ..ImportOptions::default()
        },
    );
    assert!(!all.import.report().cut_short);
    assert_eq!(all.by_channel["/laser/RangeFinder"].len(), 2);
}

#[test]
fn the_avoider_goal_is_the_pose_farthest_from_the_start_unless_given() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let farthest = CarmenImport::open(&path, ImportOptions::default()).unwrap();
    assert_eq!(farthest.report().goal, (0.3, 0.4));
    assert!(robot_toml(farthest.report()).contains("goal = { x_m = 0.3, y_m = 0.4 }"));
    let given = CarmenImport::open(
        &path,
        ImportOptions {
            goal: Some((5.0, -2.0)),
            ..ImportOptions::default()
        },
    )
    .unwrap();
    assert!(robot_toml(given.report()).contains("goal = { x_m = 5.0, y_m = -2.0 }"));
}

#[test]
fn options_out_of_range_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "small.log", SMALL_LOG.as_bytes());
    let check = |options: ImportOptions, expected: &str| {
        let error = CarmenImport::open(&path, options).unwrap_err().to_string();
        assert!(error.contains(expected), "{error}");
    };
    check(
        ImportOptions {
            max_scans: Some(0),
            ..ImportOptions::default()
        },
        "--limit-scans 0 would import nothing",
    );
    check(
        ImportOptions {
            goal: Some((f64::NAN, 0.0)),
            ..ImportOptions::default()
        },
        "give finite coordinates",
    );
    check(
        ImportOptions {
            distance_sectors: 0,
            ..ImportOptions::default()
        },
        "0 Distance sectors: give 1 to 360",
    );
}
