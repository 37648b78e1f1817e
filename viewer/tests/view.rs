//! `lewis_viewer::view` on a recording made with the recorder, on foreign ROS 2
//! recordings and on broken input; the .rrd files are checked with Rerun's own reader
//! (the PyPI `rerun-sdk`, in the environment of `scripts/setup-python.sh`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_testkit::{python_tool, repository_root, run_ok, shared_data};
use lewis_viewer::{CameraFrames, MapStatus, Target, ViewError, ViewOptions, ViewReport, view};

fn save(inputs: &[PathBuf], out: &Path) -> Result<ViewReport, ViewError> {
    view(
        inputs,
        &ViewOptions {
            target: Target::Save(out.to_owned()),
            progress: false,
            camera: CameraFrames::ALL,
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
    ("/world/mission/path", 1),
    ("/robot/body", 1),
    // 10 scans, then cleared a second after the last one: the laser is gone.
    ("/robot/scans/laser/RangeFinder", 11),
    ("/world/scans/laser/RangeFinder", 11),
    ("/robot/scans/laser/RangeFinder/rays", 0),
    ("/robot/scans/sonar/RangeFinder", 10),
    ("/robot/scans/sonar/RangeFinder/rays", 10),
    ("/world/scans/sonar/RangeFinder", 10),
    ("/world/scans/sonar/RangeFinder/rays", 10),
    ("/events/broker", 1),
    // The lanes have their colours besides their changes, for all times.
    ("/status/bindings/avoider/RangeFinder", 1 + 1),
    ("/status/health/laser", 2 + 1),
    ("/events/health", 2),
    ("/events/log/laser", 1),
    ("/camera/camera/ImageSource/image", 1),
    ("/camera/camera/ImageSource/blobs/blobs/Blobs", 1),
    ("/world/odometry/mover/mover/goal", 20),
    ("/world/odometry/mover/mover/waypoint", 20),
    ("/status/mover/mover/Mover", 2 + 1),
    ("/events/mover/mover/Mover", 2),
    ("/plots/mover/Mover/distance_to_goal", 20),
    ("/plots/sim-base/Egomotion/translation_velocity", 20),
    ("/plots/sim-base/GroundTruth/pose/theta", 20),
    ("/plots/base/Power/voltage", 20),
    ("/plots/base/Power/charging", 20),
    ("/world/map", 2),
    ("/world/blobs3d/blobfinder3d/Blobs3D", 1),
    ("/world/signs/signs/Signs", 1),
    ("/camera/camera/ImageSource/signs/signs/Signs", 1),
    ("/camera/camera/ImageSource/signs/signs/Signs/arrows", 1),
    ("/events/sequencer", common::MISSION_RECORDS),
    // door, sign (its restart stays on sign), oops, asking the supervisor, sign, stop.
    ("/status/sequencer", 6 + 1),
];

/// The expected rows of the replay's output (`common::replay_run`): the recorded broker
/// and mover and the re-simulated ones on entities of their own, the fault marked.
const REPLAY_ROWS: &[(&str, u64)] = &[
    ("/events/broker", 1),
    ("/status/bindings/avoider/RangeFinder", 1 + 1),
    ("/events/replay/broker", 2),
    ("/status/replay/bindings/avoider/RangeFinder", 2 + 1),
    ("/status/replay/health/laser", 1 + 1),
    ("/events/replay/health", 1),
    ("/world/odometry/mover/mover/goal", 20),
    ("/world/odometry/replay/mover/mover/goal", 20),
    ("/status/mover/mover/Mover", 1 + 1),
    ("/status/replay/mover/mover/Mover", 1 + 1),
    ("/events/replay/faults", 2),
    ("/status/replay/faults/laser", 2 + 1),
    ("/world/replay/faults", 1),
    ("/events/log/laser", 0),
    ("/events/replay/log/laser", 0),
    ("/world/map", 0),
];

#[test]
fn camera_frames_are_decimated_and_compressed_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    // 20 frames 100 ms apart.
    let run = common::camera_run(dir.path(), 20);
    let image = "/camera/camera/ImageSource/image";
    let (all, slim) = (dir.path().join("all.rrd"), dir.path().join("slim.rrd"));
    let report = save(std::slice::from_ref(&run), &all).unwrap();
    assert_eq!(report.entities.get(image), Some(&20), "{report}");
    assert_eq!(report.frames_skipped, 0);
    let options = ViewOptions {
        target: Target::Save(slim.clone()),
        progress: false,
        camera: CameraFrames {
            every_ns: 500_000_000,
            jpeg_quality: Some(50),
        },
    };
    let report = view(&[run], &options).unwrap();
    // One frame in each 500 ms: at 0, 0.5, 1.0 and 1.5 s.
    assert_eq!(report.entities.get(image), Some(&4), "{report}");
    assert_eq!(report.frames_skipped, 16);
    assert!(
        report.to_string().contains("16 camera frames left out"),
        "{report}"
    );
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(
        size(&slim) < size(&all) / 2,
        "{} bytes, all frames raw {}",
        size(&slim),
        size(&all)
    );
}

#[test]
fn a_failover_run_draws_every_interface_on_its_entity() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    check_rows(&report.entities, FAILOVER_ROWS);
    assert_eq!(report.counts.failed, 0, "{report}");
    assert!(report.damage.is_empty(), "{report}");
    assert!(report.failures.is_empty(), "{report}");
    assert!(
        !report
            .entities
            .keys()
            .any(|e| e.starts_with("/plots/lewis/sequencer")),
        "sequencer records are not plotted: {report}"
    );
}

#[test]
fn the_world_map_named_by_the_robot_description_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    assert_eq!(
        report.map,
        Some(MapStatus::Drawn {
            image: PathBuf::from(common::conference_world()).join("map.png"),
            width_px: 800,
            height_px: 500,
        })
    );
    assert!(report.to_string().contains("world map "), "{report}");
}

#[test]
fn a_relative_world_is_found_above_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let world = dir.path().join("worlds/copy");
    std::fs::create_dir_all(&world).unwrap();
    let conference = PathBuf::from(common::conference_world());
    for file in ["world.toml", "map.png"] {
        std::fs::copy(conference.join(file), world.join(file)).unwrap();
    }
    let logs = dir.path().join("logs");
    std::fs::create_dir_all(&logs).unwrap();
    let run = common::failover_run_in(&logs, Some("worlds/copy"));
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    assert!(
        matches!(&report.map, Some(MapStatus::Drawn { image, .. }) if image.ends_with("worlds/copy/map.png")),
        "{report}"
    );
    assert_eq!(report.entities.get("/world/map"), Some(&2), "{report}");
}

#[test]
fn a_world_that_is_not_found_is_reported_and_the_rest_is_drawn() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run_in(dir.path(), Some("robots/worlds/nowhere"));
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    let Some(MapStatus::Missing { world, detail }) = &report.map else {
        panic!("the map is not reported missing: {report}");
    };
    assert_eq!(world, "robots/worlds/nowhere");
    assert!(
        detail.contains("no world.toml in robots/worlds/nowhere"),
        "{detail}"
    );
    assert!(
        report
            .to_string()
            .contains("no world map drawn for world `robots/worlds/nowhere`"),
        "{report}"
    );
    assert_eq!(report.entities.get("/world/map"), None, "{report}");
    assert_eq!(
        report.entities.get("/world/robot/pose"),
        Some(&20),
        "{report}"
    );
}

#[test]
fn a_recording_without_a_world_names_no_map() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run_in(dir.path(), None);
    let report = save(&[run], &dir.path().join("run.rrd")).unwrap();
    assert_eq!(report.map, None, "{report}");
}

#[test]
fn a_replays_outputs_are_drawn_beside_the_recorded_ones_and_faults_are_marked() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::replay_run(dir.path());
    let rrd = dir.path().join("replay.rrd");
    let report = save(&[run], &rrd).unwrap();
    check_rows(&report.entities, REPLAY_ROWS);
    assert_eq!(report.counts.failed, 0, "{report}");
    let read = rerun_reads(&rrd);
    check_rows(&read.rows, REPLAY_ROWS);
    assert_eq!(
        read.texts["/events/replay/faults"],
        [
            "fault injected: laser stall (laser@1s-1.5s:stall)",
            "fault ends: laser recovers (laser@1s-1.5s:stall)"
        ]
    );
    assert_eq!(
        read.states["/status/replay/faults/laser"],
        ["fault: stall", "no fault"]
    );
    assert_eq!(
        read.states["/status/bindings/avoider/RangeFinder"],
        ["laser"]
    );
    assert_eq!(
        read.states["/status/replay/bindings/avoider/RangeFinder"],
        ["laser", "sonar"]
    );
    let names: Vec<&str> = read.views.iter().map(|v| v.name.as_str()).collect();
    assert!(
        names.contains(&"Re-simulated: bindings, services, health, faults")
            && names.contains(&"Re-simulated events and injected faults"),
        "{names:?}"
    );
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

/// A view of the blueprint, as Rerun's reader finds it.
#[derive(Debug, serde::Deserialize)]
struct BlueprintView {
    name: String,
    class: String,
    origin: String,
    contents: Vec<String>,
}

/// What Rerun's own reader finds in an .rrd file.
#[derive(Debug, serde::Deserialize)]
struct RerunRead {
    /// Rows per entity (static rows included).
    rows: BTreeMap<String, u64>,
    /// The texts of every text log, in row order.
    texts: BTreeMap<String, Vec<String>>,
    /// The values of every state lane, in row order.
    states: BTreeMap<String, Vec<String>>,
    /// The blueprint's views.
    views: Vec<BlueprintView>,
}

fn rerun_reads(rrd: &Path) -> RerunRead {
    let script = repository_root().join("tools/python/check_rrd.py");
    let out = run_ok(python_tool("python").arg(script).arg(rrd));
    serde_json::from_str(&out)
        .unwrap_or_else(|e| panic!("check_rrd.py printed no JSON I can read ({e}):\n{out}"))
}

#[test]
fn rerun_reads_the_rrd_with_the_expected_entities_and_rows() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let rrd = dir.path().join("run.rrd");
    save(&[run], &rrd).unwrap();
    let _ = run_ok(python_tool("rerun").args(["rrd", "verify"]).arg(&rrd));
    let read = rerun_reads(&rrd);
    check_rows(&read.rows, FAILOVER_ROWS);
    assert_eq!(
        read.states["/status/sequencer"],
        [
            "door",
            "sign",
            "oops",
            "asking the supervisor",
            "sign",
            "stop"
        ]
    );
    let sequencer = &read.texts["/events/sequencer"];
    for line in [
        "mission challenge.seq started: states door, sign, oops; the supervisor: page",
        "door exited with code 0",
        "transition door -> sign on exit code 0",
        "sign was killed by signal 11",
        "restart sign attempt 2",
        "recovery from sign",
        "help: the supervisor is asked where to resume (door, sign, oops or stop, suggested \
         stop): recovery `oops` is over (exit code 0)",
        "the supervisor chose sign",
        "resume at sign",
        "transition sign -> stop on exit code 0",
        "mission finished",
        "started sign attempt 1 (pid 4242)",
    ] {
        assert!(
            sequencer.iter().any(|l| l == line),
            "no `{line}` in {sequencer:#?}"
        );
    }
}

#[test]
fn the_blueprint_opens_on_the_views_of_a_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let rrd = dir.path().join("run.rrd");
    save(&[run], &rrd).unwrap();
    let views: Vec<String> = rerun_reads(&rrd)
        .views
        .iter()
        .map(|v| {
            format!(
                "{} | {} | {} | {}",
                v.name,
                v.class,
                v.origin,
                v.contents.join(", ")
            )
        })
        .collect();
    assert_eq!(
        views,
        [
            "World | 2D | / | + /world/**",
            "Bindings, services, health, sequencer | StateTimeline | /status | + $origin/**, - $origin/replay/**",
            "Robot frame | 2D | / | + /robot/**",
            "Camera | 2D | /camera | + $origin/**",
            "Broker, health, sequencer | TextLog | /events | + $origin/**, - $origin/commands/**, - $origin/log/**, - $origin/mover/**, - $origin/replay/**",
            "Motion | TextLog | /events/mover | + $origin/**",
            "Commands | TextLog | /events/commands | + $origin/**",
            "Services' output | TextLog | /events/log | + $origin/**",
            "Other topics | TextLog | /topics | + $origin/**",
            "/base/Power | TimeSeries | /plots/base/Power | + $origin/**",
            "/lewis/recorder/stats | TimeSeries | /plots/lewis/recorder/stats | + $origin/**",
            "/mover/Mover | TimeSeries | /plots/mover/Mover | + $origin/**",
            "/sim-base/Egomotion | TimeSeries | /plots/sim-base/Egomotion | + $origin/**",
            "/sim-base/GroundTruth | TimeSeries | /plots/sim-base/GroundTruth | + $origin/**",
        ],
        "{views:#?}"
    );
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
