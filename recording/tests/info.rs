//! `lewis info` (`lewis_recording::inspect`) on the ROS 2 recordings of `../shared/data/mcap/`
//! and on files written here: without a summary, truncated, with lost-message counts.
//!
//! The expected channel tables were produced by the independent Python tool, not by us:
//! `pymcap-cli info-json FILE` (PyPI pymcap-cli, with mcap and mcap-ros2-support), its
//! header, statistics, chunk compressions and channels printed in the form of `table`.
//! The warning lines are ours (pymcap-cli does not check the Statistics record).

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use expect_test::{Expect, expect};
use lewis_recording::info::{CountSource, InfoOptions, InfoReport, WarningKind, inspect};

fn data_file(name: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/mcap")
        .join(name);
    assert!(
        path.exists(),
        "missing test data {}: these tests need the ROS 2 recordings of ../shared/data/mcap/ \
         (see ../shared/data/README.md)",
        path.display()
    );
    path
}

fn options(messages: usize, scan: bool) -> InfoOptions {
    InfoOptions { messages, scan }
}

/// The report in the neutral form the expected values were written in.
fn table(report: &InfoReport) -> String {
    let mut lines = vec![
        format!("library: {} | profile: {}", report.library, report.profile),
        format!(
            "messages: {} chunks: {} start: {} end: {}",
            report.message_count,
            report.chunk_count,
            report.start_ns.map_or("-".into(), |t| t.to_string()),
            report.end_ns.map_or("-".into(), |t| t.to_string()),
        ),
    ];
    let compressions: Vec<String> = report
        .compressions
        .iter()
        .map(|c| format!("{}: {}", c.compression, c.chunk_count))
        .collect();
    lines.push(format!("compression: {}", compressions.join(", ")));
    for channel in &report.channels {
        let schema = channel.schema_name.as_deref().unwrap_or("-");
        lines.push(format!(
            "{} {} {schema} {}",
            channel.id, channel.topic, channel.message_count
        ));
    }
    for warning in &report.warnings {
        lines.push(format!("warning: {}", warning.message));
    }
    lines.join("\n") + "\n"
}

/// Checks a recording read through its summary and by a full scan.
fn check(name: &str, expected: &Expect) {
    let path = data_file(name);
    for scan in [false, true] {
        let report = inspect(&path, &options(0, scan)).unwrap();
        assert_eq!(report.damage, None, "{name}");
        let source = if scan {
            CountSource::Scan
        } else {
            CountSource::Summary
        };
        assert_eq!(report.source, source);
        expected.assert_eq(&table(&report));
    }
}

#[test]
fn talker_lists_three_channels_with_zstd_chunks() {
    check(
        "talker.mcap",
        &expect![[r#"
            library: mcap go #(devel) | profile: ros2
            messages: 20 chunks: 1 start: 1585866235112411371 end: 1585866239643508139
            compression: zstd: 1
            1 /rosout rcl_interfaces/msg/Log 10
            2 /parameter_events rcl_interfaces/msg/ParameterEvent 0
            3 /topic std_msgs/msg/String 10
        "#]],
    );
}

#[test]
fn cdr_test_lists_basic_types_and_arrays() {
    check(
        "cdr_test_0.mcap",
        &expect![[r#"
            library: libmcap 0.8.0 | profile: ros2
            messages: 7 chunks: 1 start: 1586406456763032325 end: 1586406456914169506
            compression: none: 1
            1 /test_topic test_msgs/msg/BasicTypes 3
            2 /array_topic test_msgs/msg/Arrays 4
        "#]],
    );
}

#[test]
fn rewriter_lists_strings_and_empty() {
    check(
        "rewriter_b_0.mcap",
        &expect![[r#"
            library: libmcap 0.8.0 | profile: ros2
            messages: 75 chunks: 1 start: 0 end: 222000000
            compression: none: 1
            1 c_strings test_msgs/msg/Strings 50
            2 a_empty test_msgs/msg/Empty 25
        "#]],
    );
}

#[test]
fn seek_test_bag_lists_one_channel() {
    check(
        "test_bag_for_seek_0.mcap",
        &expect![[r#"
            library: libmcap 0.8.0 | profile: ros2
            messages: 5 chunks: 1 start: 1000000000 end: 1400000000
            compression: none: 1
            1 topic1 test_msgs/BasicTypes 5
        "#]],
    );
}

#[test]
fn topics_and_services_reports_its_statistics_disagreeing_with_its_channels() {
    check(
        "topics_and_services.mcap",
        &expect![[r#"
            library: libmcap 1.1.0 | profile: ros2
            messages: 13 chunks: 1 start: 1697522263121459207 end: 1697522264629347866
            compression: none: 1
            1 /rosout rcl_interfaces/msg/Log 0
            2 /parameter_events rcl_interfaces/msg/ParameterEvent 7
            3 /events/write_split rosbag2_interfaces/msg/WriteSplitEvent 0
            4 /add_two_ints2/_service_event example_interfaces/srv/AddTwoInts_Event 0
            5 /add_two_ints/_service_event example_interfaces/srv/AddTwoInts_Event 6
            warning: the Statistics record counts 2 channels but the summary has 5 Channel records; channels without a message count in it (counted as 0): 1 /rosout, 3 /events/write_split, 4 /add_two_ints2/_service_event
            warning: the Statistics record counts 2 schemas but the summary has 4 Schema records
        "#]],
    );
    let report = inspect(&data_file("topics_and_services.mcap"), &options(0, false)).unwrap();
    assert_eq!(report.warnings[0].kind, WarningKind::StatisticsMismatch);
}

#[test]
fn every_recording_decodes_its_first_messages() {
    for name in [
        "talker.mcap",
        "cdr_test_0.mcap",
        "rewriter_b_0.mcap",
        "test_bag_for_seek_0.mcap",
        "topics_and_services.mcap",
    ] {
        for scan in [false, true] {
            let report = inspect(&data_file(name), &options(100, scan)).unwrap();
            assert_eq!(report.messages.len() as u64, report.message_count, "{name}");
            for message in &report.messages {
                assert_eq!(message.error, None, "{name} {}", message.topic);
            }
        }
    }
}

/// The Display form with the data folder's location replaced, so it does not depend on it.
fn human(report: &InfoReport) -> String {
    report
        .to_string()
        .replace(&report.path.display().to_string(), "FILE")
}

#[test]
fn human_report_shows_header_times_channels_and_decoded_messages() {
    let report = inspect(&data_file("talker.mcap"), &options(2, false)).unwrap();
    expect![[r#"
        file:        FILE (12880 bytes)
        library:     mcap go #(devel)
        profile:     ros2
        messages:    20 (counted by the summary)
        start:       2020-04-02T22:23:55.112411371Z (1585866235.112411371)
        end:         2020-04-02T22:23:59.643508139Z (1585866239.643508139)
        duration:    4.531096768 s
        chunks:      1 (zstd: 1)
        attachments: 0
        metadata:    0
        channels:    3
          id topic             schema                                      encoding messages rate_hz
           1 /rosout           rcl_interfaces/msg/Log (ros2msg)            cdr            10    2.21
           2 /parameter_events rcl_interfaces/msg/ParameterEvent (ros2msg) cdr             0    0.00
           3 /topic            std_msgs/msg/String (ros2msg)               cdr            10    2.21
        first messages:
          1585866235.112411371 /rosout {stamp: {sec: 1585866235, nanosec: 112130688}, level: 20, name: "minimal_publisher", msg: "Publishing: 'Hello, world! 0'", file: "/opt/ros2_ws/eloquent/src/ros2/examples/rclcpp/minimal_publisher/lambda.cpp", function: "operator()", line: 38}
          1585866235.112609068 /topic {data: "Hello, world! 0"}
    "#]]
    .assert_eq(&human(&report));
}

#[test]
fn json_report_carries_channels_warnings_and_decoded_values() {
    let report = inspect(&data_file("topics_and_services.mcap"), &options(8, false)).unwrap();
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["source"], "summary");
    assert_eq!(json["profile"], "ros2");
    assert_eq!(json["channels"][4]["topic"], "/add_two_ints/_service_event");
    assert_eq!(json["channels"][4]["message_count"], 6);
    assert_eq!(json["channels"][4]["lost_count"], serde_json::Value::Null);
    assert_eq!(json["warnings"][0]["kind"], "statistics_mismatch");
    assert_eq!(
        json["messages"][0]["value"]["new_parameters"][0]["name"],
        "use_sim_time"
    );
    assert_eq!(json["messages"][7]["value"]["request"][0]["b"], 3);
    assert_eq!(json["damage"], serde_json::Value::Null);
}

// Files written here with the mcap crate.

const STRING_SCHEMA: &str = "string data\n";

fn string_message(text: &str) -> Vec<u8> {
    let mut bytes = vec![0, 1, 0, 0];
    bytes.extend_from_slice(&u32::try_from(text.len() + 1).unwrap().to_le_bytes());
    bytes.extend_from_slice(text.as_bytes());
    bytes.push(0);
    bytes
}

/// Writes `count` std_msgs/String messages "Hello World: N" on /chatter, 10 ms apart, and
/// the given metadata records.
fn write_recording(
    path: &Path,
    options: mcap::WriteOptions,
    count: u64,
    metadata: &[(&str, &[(&str, &str)])],
) {
    let mut writer = options
        .profile("ros2")
        .create(BufWriter::new(File::create(path).unwrap()))
        .unwrap();
    let schema = writer
        .add_schema("std_msgs/msg/String", "ros2msg", STRING_SCHEMA.as_bytes())
        .unwrap();
    let channel = writer
        .add_channel(schema, "/chatter", "cdr", &BTreeMap::new())
        .unwrap();
    for n in 0..count {
        let data = string_message(&format!("Hello World: {n}"));
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: u32::try_from(n).unwrap(),
            log_time: 1_000_000_000 + n * 10_000_000,
            publish_time: 1_000_000_000 + n * 10_000_000,
        };
        writer.write_to_known_channel(&header, &data).unwrap();
    }
    for (name, entries) in metadata {
        let metadata = mcap::records::Metadata {
            name: (*name).to_owned(),
            metadata: entries
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect(),
        };
        writer.write_metadata(&metadata).unwrap();
    }
    writer.finish().unwrap();
}

fn without_summary() -> mcap::WriteOptions {
    mcap::WriteOptions::new()
        .compression(None)
        .emit_summary_records(false)
        .emit_summary_offsets(false)
}

#[test]
fn a_file_without_summary_is_scanned() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no_summary.mcap");
    write_recording(&path, without_summary().chunk_size(Some(256)), 25, &[]);
    assert!(
        mcap::Summary::read(&std::fs::read(&path).unwrap())
            .unwrap()
            .is_none()
    );
    let report = inspect(&path, &options(3, false)).unwrap();
    assert_eq!(report.source, CountSource::Scan);
    assert_eq!(report.damage, None);
    assert!(report.chunk_count > 1, "{}", report.chunk_count);
    expect![[r#"
        library: mcap-rust/0.26.0 | profile: ros2
        messages: 25 chunks: 6 start: 1000000000 end: 1240000000
        compression: none: 6
        1 /chatter std_msgs/msg/String 25
    "#]]
    .assert_eq(&table(&report));
    let rate = report.channels[0].rate_hz.unwrap();
    assert!((rate - 25.0 / 0.24).abs() < 1e-9, "{rate}");
    let texts: Vec<Cow<'_, str>> = report
        .messages
        .iter()
        .map(|m| {
            m.value
                .as_ref()
                .unwrap()
                .get("data")
                .unwrap()
                .as_str()
                .unwrap()
                .into()
        })
        .collect();
    assert_eq!(
        texts,
        ["Hello World: 0", "Hello World: 1", "Hello World: 2"]
    );
}

#[test]
fn a_truncated_file_is_reported_with_what_could_be_read_and_a_recover_hint() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mcap");
    write_recording(
        &whole,
        mcap::WriteOptions::new()
            .compression(None)
            .chunk_size(Some(256)),
        40,
        &[],
    );
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();

    let report = inspect(&cut, &options(1, false)).unwrap();
    let damage = report.damage.clone().unwrap();
    assert!(damage.truncated, "{damage:?}");
    assert_eq!(
        damage.hint,
        format!("run `lewis recover {} -o FIXED.mcap`", cut.display())
    );
    assert_eq!(report.source, CountSource::Scan);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    assert_eq!(report.channels.len(), 1);
    assert!(
        report.message_count > 0 && report.message_count < 40,
        "{}",
        report.message_count
    );
    let text = human(&report);
    assert!(
        text.contains(
            "truncated: the file ends in the middle of a record; what is listed is what could be read"
        ),
        "{text}"
    );
    assert!(
        text.contains("hint: run `lewis recover FILE -o FIXED.mcap`"),
        "{text}"
    );
}

#[test]
fn a_file_cut_anywhere_never_fails_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.mcap");
    write_recording(
        &whole,
        mcap::WriteOptions::new().chunk_size(Some(512)),
        20,
        &[],
    );
    let bytes = std::fs::read(&whole).unwrap();
    let cut = dir.path().join("cut.mcap");
    // Past the magic and the Header record, every length gives a report.
    let header_end = 8 + 1 + 8 + 4 + "ros2".len() + 4 + "mcap-rust/0.26.0".len();
    for len in header_end..bytes.len() {
        std::fs::write(&cut, &bytes[..len]).unwrap();
        let report = inspect(&cut, &options(2, false)).unwrap();
        let damage = report
            .damage
            .unwrap_or_else(|| panic!("cut at {len} not reported"));
        assert!(damage.truncated, "cut at {len}: {damage:?}");
    }
    std::fs::write(&cut, &bytes[..4]).unwrap();
    let error = inspect(&cut, &options(0, false)).unwrap_err();
    assert!(error.to_string().contains("is not an MCAP file"), "{error}");
}

#[test]
fn lost_message_counts_are_read_from_the_loss_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let losses: &[(&str, &[(&str, &str)])] = &[
        ("rosbag2", &[("k", "v")]),
        ("lewis.loss", &[("/chatter", "3"), ("/gone", "7")]),
    ];
    for (name, write_options) in [
        ("summary.mcap", mcap::WriteOptions::new()),
        ("no_summary.mcap", without_summary()),
    ] {
        let path = dir.path().join(name);
        write_recording(&path, write_options, 5, losses);
        let report = inspect(&path, &options(0, false)).unwrap();
        assert_eq!(report.metadata_names, ["rosbag2", "lewis.loss"], "{name}");
        assert_eq!(report.channels[0].lost_count, Some(3), "{name}");
        let expected = BTreeMap::from([("/chatter".to_owned(), 3), ("/gone".to_owned(), 7)]);
        assert_eq!(report.lost_messages, expected, "{name}");
        let text = human(&report);
        assert!(
            text.contains("lost on topics without a channel: /gone: 7"),
            "{text}"
        );
    }
}

#[test]
fn a_loss_count_that_is_not_a_number_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad_loss.mcap");
    write_recording(
        &path,
        mcap::WriteOptions::new(),
        2,
        &[("lewis.loss", &[("/chatter", "many")])],
    );
    let report = inspect(&path, &options(0, false)).unwrap();
    assert_eq!(report.channels[0].lost_count, None);
    assert_eq!(report.warnings[0].kind, WarningKind::BadLossMetadata);
    assert_eq!(
        report.warnings[0].message,
        "the `lewis.loss` count of topic `/chatter` is `many`, not a number"
    );
}

#[test]
fn a_missing_file_is_an_io_error_naming_it() {
    let error = inspect(Path::new("/nonexistent/x.mcap"), &options(0, false)).unwrap_err();
    assert_eq!(
        error.to_string(),
        "cannot read /nonexistent/x.mcap: No such file or directory (os error 2)"
    );
}
