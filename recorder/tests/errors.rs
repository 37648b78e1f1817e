//! A path that does not exist, a read-only folder, an existing file, a full disk: a clear
//! error naming the path, and the file closed valid up to that point.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::traffic;
use common::{Digests, doctor, options, python_read, sample};
use lewis_recorder::{RecordError, Recorder, recover};

#[test]
fn a_missing_folder_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no/such/folder/run.mcap");
    let error = Recorder::create(options(&path)).err().unwrap();
    assert!(
        matches!(&error, RecordError::MissingFolder { path: p, folder } if *p == path && *folder == dir.path().join("no/such/folder")),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(message.contains("does not exist"), "{message}");
}

#[test]
fn an_existing_recording_is_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    std::fs::write(&path, b"precious").unwrap();
    let error = Recorder::create(options(&path)).err().unwrap();
    assert!(
        matches!(&error, RecordError::AlreadyExists { path: p } if *p == path),
        "{error:?}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), b"precious");
}

/// A tmpfs mounted at `dir` for the test (the tests run as root in CI); unmounted on drop.
struct Mount {
    dir: PathBuf,
}

impl Mount {
    fn tmpfs(dir: &Path, options: &str) -> Option<Self> {
        let status = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(dir)
            .status()
            .ok()?;
        status.success().then(|| Self {
            dir: dir.to_path_buf(),
        })
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.dir).status();
    }
}

/// Whether the effective user is root (`/proc/self/status`, line `Uid: real effective ...`).
fn is_root() -> bool {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let uid_line = status.lines().find(|l| l.starts_with("Uid:")).unwrap();
    uid_line.split_whitespace().nth(2) == Some("0")
}

#[test]
fn a_read_only_folder_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("ro");
    std::fs::create_dir(&folder).unwrap();
    // Root writes through permission bits: a read-only mount it is, then.
    let _mount = if is_root() {
        Some(Mount::tmpfs(&folder, "ro,size=1m").expect("root can mount a tmpfs"))
    } else {
        let mut permissions = std::fs::metadata(&folder).unwrap().permissions();
        permissions.set_readonly(true);
        std::fs::set_permissions(&folder, permissions).unwrap();
        None
    };
    let path = folder.join("run.mcap");
    let error = Recorder::create(options(&path)).err().unwrap();
    assert!(
        matches!(&error, RecordError::ReadOnly { path: p, .. } if *p == path),
        "{error:?}"
    );
    let message = error.to_string();
    assert!(message.contains(&path.display().to_string()), "{message}");
    assert!(message.contains("read-only"), "{message}");
}

/// Records the stress mix into a 2 MiB tmpfs until the disk is full; returns the error,
/// the digests of the messages the recorder accepted (the one that met the full disk
/// included when the file was closed valid) and the file.
fn fill_the_disk(reserve_bytes: u64, mount_dir: &Path) -> (RecordError, Digests, PathBuf) {
    let path = mount_dir.join("full.mcap");
    let mut options = options(&path);
    options.disk_reserve_bytes = reserve_bytes;
    options.chunk_size_bytes = 64 * 1024;
    options.compression = lewis_recorder::Compression::None;
    let mut recorder = Recorder::create(options).unwrap();
    let channels = traffic::stress_channels();
    let ids: Vec<_> = channels
        .iter()
        .map(|c| recorder.add_channel(c.clone()).unwrap())
        .collect();
    let mut digests = Digests::default();
    for m in traffic::stress_mix(60 * lewis_recorder::SECOND_NS) {
        match recorder.write(&sample(ids[m.channel], &m)) {
            Ok(()) => digests.add(&channels[m.channel].topic, m.seq, &m.data),
            Err(error) => {
                if matches!(
                    error,
                    RecordError::DiskFull {
                        closed_valid: true,
                        ..
                    }
                ) {
                    digests.add(&channels[m.channel].topic, m.seq, &m.data);
                }
                // Stopped: everything after is refused, and says why.
                let again = recorder.write(&sample(ids[m.channel], &m)).unwrap_err();
                assert!(matches!(again, RecordError::Stopped { .. }), "{again:?}");
                return (error, digests, path);
            }
        }
    }
    panic!("a 2 MiB disk never filled up");
}

fn with_small_disk(test: impl FnOnce(&Path, &Path)) {
    let dir = tempfile::tempdir().unwrap();
    let mount_dir = dir.path().join("disk");
    std::fs::create_dir(&mount_dir).unwrap();
    if !is_root() {
        // Without root there is no small disk to fill: the reserve logic is still run by
        // every other test.
        return;
    }
    let mount = Mount::tmpfs(&mount_dir, "size=2m").expect("root can mount a tmpfs");
    test(&mount.dir, dir.path());
}

#[test]
fn a_full_disk_stops_the_recorder_with_the_file_closed_valid() {
    with_small_disk(|disk, _| {
        let (error, digests, path) = fill_the_disk(256 * 1024, disk);
        assert!(
            matches!(&error, RecordError::DiskFull { path: p, closed_valid: true } if *p == path),
            "{error:?}"
        );
        assert!(error.to_string().contains("disk is full"), "{error}");
        assert!(
            !disk.join(".full.mcap.reserve").exists(),
            "the reserve is given back"
        );
        doctor(&path);
        let view = python_read(&[path]);
        assert_eq!(view.digests(), digests.finish());
        assert!(view.loss(0).values().all(|&n| n == 0));
    });
}

#[test]
fn a_full_disk_without_reserve_leaves_a_file_that_recover_repairs() {
    with_small_disk(|disk, elsewhere| {
        let (error, digests, path) = fill_the_disk(0, disk);
        assert!(
            matches!(&error, RecordError::DiskFull { path: p, closed_valid: false } if *p == path),
            "{error:?}"
        );
        assert!(error.to_string().contains("lewis recover"), "{error}");
        let fixed = elsewhere.join("fixed.mcap");
        let report = recover(&path, &fixed).unwrap();
        assert!(!report.input_complete);
        doctor(&fixed);
        let view = python_read(&[fixed]);
        let got = view.digests();
        let written = digests.finish();
        // Every message recovered is one that was written, in order; the last chunk may
        // be lost.
        for (topic, digest) in &got {
            assert_eq!(digest.seq_runs.len(), 1, "{topic}");
            assert!(digest.count <= written[topic].count, "{topic}");
            assert_eq!(digest.seq_runs[0][0], 1, "{topic}");
        }
        assert!(report.messages > 0);
    });
}
