//! A recording says which versions of the format, of Lewis and of the interfaces wrote it:
//! `lewis info` shows them, a recording made before versioning is shown as such and still
//! read, and replay refuses a format newer than it knows.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use lewis_mcap::format::{
    FORMAT_VERSION, INTERFACES_METADATA, RECORDING_METADATA, ROBOT_METADATA, interfaces_digest,
};
use lewis_recorder::{Recorder, RecorderOptions};
use lewis_recording::info::{InfoOptions, WarningKind, WrittenBy, inspect};
use lewis_recording::{RecordingError, RecordingFiles};

/// A recording written now, by the recorder.
fn recorded(dir: &Path) -> PathBuf {
    let path = dir.join("now.mcap");
    let mut options = RecorderOptions::new(&path);
    options.sync_on_flush = false;
    options.disk_reserve_bytes = 0;
    Recorder::create(options).unwrap().close().unwrap();
    path
}

/// A recording with the given metadata records and no message, written with the mcap
/// crate (as an older recorder, or another tool, would have).
fn written(dir: &Path, name: &str, metadata: &[(&str, &[(&str, &str)])]) -> PathBuf {
    let path = dir.join(name);
    let mut writer = mcap::WriteOptions::new()
        .profile("ros2")
        .create(BufWriter::new(File::create(&path).unwrap()))
        .unwrap();
    for (name, entries) in metadata {
        let record = mcap::records::Metadata {
            name: (*name).to_owned(),
            metadata: entries
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect(),
        };
        writer.write_metadata(&record).unwrap();
    }
    writer.finish().unwrap();
    path
}

const BEFORE_VERSIONING: &[(&str, &str)] = &[
    ("recorder", "lewis-recorder 0.1.0"),
    ("part", "1"),
    ("stats_topic", "/lewis/recorder/stats"),
];

fn info(path: &Path, scan: bool) -> lewis_recording::info::InfoReport {
    let options = InfoOptions { messages: 0, scan };
    inspect(path, &options).unwrap()
}

#[test]
fn a_recording_made_now_says_which_versions_wrote_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = recorded(dir.path());
    let mut file = lewis_mcap::McapFile::open(&path).unwrap();
    let summary = file.summary().unwrap().unwrap();
    let interfaces = file
        .metadata_named(&summary, INTERFACES_METADATA)
        .unwrap()
        .remove(0)
        .metadata;
    let expected = WrittenBy::Versioned {
        format_version: FORMAT_VERSION,
        lewis_version: env!("CARGO_PKG_VERSION").to_owned(),
        interfaces: interfaces_digest(&interfaces),
    };
    for scan in [false, true] {
        let report = info(&path, scan);
        assert_eq!(report.written_by.as_ref(), Some(&expected), "scan: {scan}");
        let line = format!(
            "lewis:       {} (recording format {FORMAT_VERSION}, interfaces {})",
            env!("CARGO_PKG_VERSION"),
            interfaces_digest(&interfaces)
        );
        assert!(report.to_string().contains(&line), "{report}");
    }
    let json = serde_json::to_value(info(&path, false)).unwrap();
    assert_eq!(json["written_by"]["kind"], "versioned");
    assert_eq!(json["written_by"]["format_version"], FORMAT_VERSION);
}

#[test]
fn a_recording_made_before_versioning_is_shown_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let path = written(
        dir.path(),
        "old.mcap",
        &[(RECORDING_METADATA, BEFORE_VERSIONING)],
    );
    for scan in [false, true] {
        let report = info(&path, scan);
        assert_eq!(report.written_by, Some(WrittenBy::BeforeVersioning));
        assert!(
            report
                .to_string()
                .contains("\nlewis:       written before versioning\n"),
            "{report}"
        );
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    }
    let json = serde_json::to_value(info(&path, false)).unwrap();
    assert_eq!(json["written_by"]["kind"], "before_versioning");
}

#[test]
fn a_file_lewis_did_not_write_says_nothing_of_versions() {
    let dir = tempfile::tempdir().unwrap();
    let path = written(dir.path(), "foreign.mcap", &[]);
    let report = info(&path, false);
    assert_eq!(report.written_by, None);
    assert!(!report.to_string().contains("lewis:"), "{report}");
}

#[test]
fn a_format_version_that_is_not_a_number_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = written(
        dir.path(),
        "odd.mcap",
        &[(RECORDING_METADATA, &[("format_version", "two")])],
    );
    let report = info(&path, false);
    assert_eq!(report.written_by, None);
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert_eq!(report.warnings[0].kind, WarningKind::BadRecordingMetadata);
    assert!(report.warnings[0].message.contains("`two`"));
}

#[test]
fn replay_reads_old_and_current_formats_and_refuses_a_newer_one() {
    let dir = tempfile::tempdir().unwrap();
    let robot: &[(&str, &str)] = &[("robot.toml", "")];
    let old = written(
        dir.path(),
        "old.mcap",
        &[
            (RECORDING_METADATA, BEFORE_VERSIONING),
            (ROBOT_METADATA, robot),
        ],
    );
    assert!(RecordingFiles::open(&[old]).is_ok());
    assert!(RecordingFiles::open(&[recorded(dir.path())]).is_ok());
    let newer_version = (FORMAT_VERSION + 1).to_string();
    let newer = written(
        dir.path(),
        "newer.mcap",
        &[(
            RECORDING_METADATA,
            &[
                ("format_version", newer_version.as_str()),
                ("lewis_version", "9.0.0"),
            ],
        )],
    );
    let error = RecordingFiles::open(std::slice::from_ref(&newer)).unwrap_err();
    match &error {
        RecordingError::NewerFormat {
            path,
            version,
            lewis_version,
            supported,
        } => {
            assert_eq!(path, &newer);
            assert_eq!(*version, FORMAT_VERSION + 1);
            assert_eq!(lewis_version, "9.0.0");
            assert_eq!(*supported, FORMAT_VERSION);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        error
            .to_string()
            .contains("replay it with lewis 9.0.0 or later"),
        "{error}"
    );
}
