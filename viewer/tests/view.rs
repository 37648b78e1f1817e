//! `lewis_viewer::view` on a recording made with the recorder, on foreign ROS 2
//! recordings and on broken input; the .rrd files are checked with Rerun's own reader
//! (the PyPI `rerun-sdk`, in the environment of `scripts/setup-python.sh`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_tests::{python_tool, repo_root, run_ok, shared_data};
use lewis_viewer::{Target, ViewError, ViewOptions, ViewReport, view};

fn save(inputs: &[PathBuf], out: &Path) -> Result<ViewReport, ViewError> {
    view(
        inputs,
        &ViewOptions {
            target: Target::Save(out.to_owned()),
            progress: false,
        },
    )
}

/// Checks the rows logged on each of `expected`'s entities.
fn check_rows(entities: &BTreeMap<String, u64>, expected: &[(&str, u64)]) {
    let got: Vec<(&str, u64)> = expected
        .iter()
        .map(|(path, _)| (*path, entities.get(*path).copied().unwrap_or(0)))
        .collect();
    assert_eq!(
        got, expected,
        "rows per entity; all entities: {entities:#?}"
    );
}

/// The expected rows of the failover run (`common::failover_run`).
const FAILOVER_ROWS: &[(&str, u64)] = &[
    ("/world/robot/pose", 20),
    ("/world/robot/path", 1),
    ("/world/odometry/pose", 20),
    ("/world/odometry/path", 1),
    ("/robot/body", 1),
    ("/robot/scans/laser/RangeFinder", 10),
    ("/world/scans/laser/RangeFinder", 10),
    ("/robot/scans/laser/RangeFinder/rays", 0),
    ("/robot/scans/sonar/RangeFinder", 10),
    ("/robot/scans/sonar/RangeFinder/rays", 10),
    ("/world/scans/sonar/RangeFinder", 10),
    ("/world/scans/sonar/RangeFinder/rays", 10),
    ("/events/broker", 1),
    ("/status/bindings/avoider/RangeFinder", 1),
    ("/status/health/laser", 2),
    ("/events/health", 2),
    ("/events/log/laser", 1),
    ("/camera/camera/ImageSource/image", 1),
    ("/camera/camera/ImageSource/blobs/blobs/Blobs", 1),
    ("/world/mover/goal", 20),
    ("/world/mover/waypoint", 20),
    ("/status/mover/mover/Mover", 2),
    ("/events/mover/mover/Mover", 2),
    ("/plots/mover/Mover/distance_to_goal", 20),
    ("/plots/sim-base/Egomotion/translation_velocity", 20),
    ("/plots/sim-base/GroundTruth/pose/theta", 20),
    ("/plots/base/Power/voltage", 20),
    ("/plots/base/Power/charging", 20),
];

#[test]
fn a_failover_run_draws_every_interface_on_its_entity() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    check_rows(&report.entities, FAILOVER_ROWS);
    assert_eq!(report.counts.failed, 0, "{report}");
    assert!(report.damage.is_empty(), "{report}");
    assert!(report.failures.is_empty(), "{report}");
}

/// The bytes of an .rrd file before its footer (Rerun's `End` message and stream footer),
/// where Rerun lists the stores' manifests in hash-map order.
fn before_footer(rrd: &[u8]) -> &[u8] {
    use rerun::external::re_log_encoding::{Decodable, MessageHeader, StreamFooter};
    let tail = &rrd[rrd.len() - StreamFooter::ENCODED_SIZE_BYTES..];
    let footer = StreamFooter::from_rrd_bytes(tail).unwrap();
    let start = footer.entries[0]
        .rrd_footer_byte_span_from_start_excluding_header
        .start;
    let end_message = usize::try_from(start).unwrap() - MessageHeader::ENCODED_SIZE_BYTES;
    &rrd[..end_message]
}

#[test]
fn the_same_recording_gives_the_same_rrd_messages() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let first = dir.path().join("first.rrd");
    let second = dir.path().join("second.rrd");
    save(std::slice::from_ref(&run), &first).unwrap();
    save(&[run], &second).unwrap();
    let (a, b) = (
        std::fs::read(first).unwrap(),
        std::fs::read(second).unwrap(),
    );
    let (a, b) = (before_footer(&a), before_footer(&b));
    assert!(a.len() > 1000, "the file is too small: {} bytes", a.len());
    assert!(a == b, "two conversions of one recording differ");
}

/// What Rerun's own reader finds in an .rrd file: rows per entity (static rows included).
fn rerun_reads(rrd: &Path) -> BTreeMap<String, u64> {
    let script = repo_root().join("viewer/tests/python/check_rrd.py");
    let out = run_ok(python_tool("python").arg(script).arg(rrd));
    let json: serde_json::Value = serde_json::from_str(&out)
        .unwrap_or_else(|e| panic!("check_rrd.py printed no JSON ({e}):\n{out}"));
    json["rows"]
        .as_object()
        .unwrap_or_else(|| panic!("no rows in {json}"))
        .iter()
        .map(|(path, rows)| (path.clone(), rows.as_u64().unwrap()))
        .collect()
}

#[test]
fn rerun_reads_the_rrd_with_the_expected_entities_and_rows() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let rrd = dir.path().join("run.rrd");
    save(&[run], &rrd).unwrap();
    let _ = run_ok(python_tool("rerun").args(["rrd", "verify"]).arg(&rrd));
    check_rows(&rerun_reads(&rrd), FAILOVER_ROWS);
}

#[test]
fn foreign_ros2_recordings_go_to_generic_entities_without_failing() {
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "talker.mcap",
        "cdr_test_0.mcap",
        "test_bag_for_seek_0.mcap",
        "rewriter_b_0.mcap",
        "topics_and_services.mcap",
    ] {
        let input = shared_data(&format!("mcap/{name}"));
        let rrd = dir.path().join(name).with_extension("rrd");
        let report = save(&[input], &rrd).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(report.counts.messages > 0, "{name}: {report}");
        assert_eq!(
            report.counts.generic + report.counts.failed,
            report.counts.messages,
            "{name}: {report}"
        );
        let topics = report
            .entities
            .keys()
            .filter(|e| e.starts_with("/topics/"))
            .count();
        assert!(topics > 0, "{name}: no generic entity: {report}");
    }
}

#[test]
fn a_file_that_is_not_mcap_is_refused_with_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("notes.mcap");
    std::fs::write(&input, "not a recording").unwrap();
    let error = save(std::slice::from_ref(&input), &dir.path().join("out.rrd")).unwrap_err();
    assert!(
        matches!(&error, ViewError::NotMcap { path, .. } if *path == input),
        "{error:?}"
    );
    assert!(error.to_string().contains("notes.mcap"), "{error}");
}

#[test]
fn a_missing_file_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.rrd");
    let error = save(&[dir.path().join("missing.mcap")], &out).unwrap_err();
    assert!(matches!(error, ViewError::Read { .. }), "{error:?}");
    assert!(!out.exists(), "{} was created", out.display());
}

#[test]
fn a_recording_cut_short_is_shown_up_to_the_damage() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let bytes = std::fs::read(&run).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let report = save(&[cut], &dir.path().join("cut.rrd")).unwrap();
    assert_eq!(report.damage.len(), 1, "{report}");
    assert!(report.counts.messages > 0, "{report}");
}
