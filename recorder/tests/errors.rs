//! A path that does not exist, a read-only folder, an existing file, a full disk: a clear
//! error naming the path, and the file closed valid up to that point.
//!
//! The full disk is a small tmpfs when one can be mounted, else a file size limit on a
//! child process ([`SmallDisk`]); each test checks the outcome of the kind it got.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::os::unix::fs::PermissionsExt as _;
use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::traffic;
use common::{Digests, options, python_read, sample};
use lewis_recorder::{RecordError, Recorder, recover};
use lewis_testkit::doctor;
use lewis_testkit::small_disk::{Kind, SmallDisk, mount_tmpfs};

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

/// Whether the effective user is root (`/proc/self/status`, line `Uid: real effective ...`).
fn is_root() -> bool {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let uid_line = status.lines().find(|l| l.starts_with("Uid:")).unwrap();
    uid_line.split_whitespace().nth(2) == Some("0")
}

/// The user `nobody`, for a test run as root that must meet permission bits.
const NOBODY: u32 = 65534;

/// Set in the child process that runs the read-only test as `nobody`.
const AS_NOBODY_ENV: &str = "LEWIS_TEST_AS_NOBODY";

#[test]
fn a_read_only_folder_is_named_in_the_error() {
    let check = |folder: &Path| {
        let path = folder.join("run.mcap");
        let error = Recorder::create(options(&path)).err().unwrap();
        assert!(
            matches!(&error, RecordError::ReadOnly { path: p, .. } if *p == path),
            "{error:?}"
        );
        let message = error.to_string();
        assert!(message.contains(&path.display().to_string()), "{message}");
        assert!(message.contains("read-only"), "{message}");
    };
    if let Some(folder) = std::env::var_os(AS_NOBODY_ENV) {
        check(Path::new(&folder));
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("ro");
    std::fs::create_dir(&folder).unwrap();
    // Root writes through permission bits: a read-only mount it is, when root may mount;
    // else the check runs as `nobody` in a child process.
    let mounted = is_root() && mount_tmpfs(&folder, "ro,size=1m").is_ok();
    if mounted {
        eprintln!("read-only folder: a read-only tmpfs");
        check(&folder);
        let _ = Command::new("umount").arg(&folder).status();
        return;
    }
    let mut permissions = std::fs::metadata(&folder).unwrap().permissions();
    permissions.set_readonly(true);
    std::fs::set_permissions(&folder, permissions).unwrap();
    if !is_root() {
        eprintln!("read-only folder: permission bits");
        check(&folder);
        return;
    }
    eprintln!("read-only folder: permission bits, checked as nobody (root cannot mount here)");
    // `nobody` must reach the folder through the temporary directory.
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let output = Command::new(std::env::current_exe().unwrap())
        .args([
            // Its name in the test binary, whose modules are the files of `tests/`.
            concat!(module_path!(), "::a_read_only_folder_is_named_in_the_error")
                .split_once("::")
                .map_or("", |(_, name)| name),
            "--exact",
            "--nocapture",
        ])
        .env(AS_NOBODY_ENV, &folder)
        .uid(NOBODY)
        .gid(NOBODY)
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success() && printed.contains("1 passed"),
        "the check as nobody failed:\n{printed}"
    );
}

/// Records the stress mix onto a 2 MiB disk until it is full; returns the error, the
/// digests of the messages the recorder accepted (the one that met the full disk included
/// when the file was closed valid) and the file.
fn fill_the_disk(reserve_bytes: u64, disk: &Path) -> (RecordError, Digests, PathBuf) {
    let (error, digests, _, path) = fill_the_disk_to(reserve_bytes, disk);
    (error, digests, path)
}

/// [`fill_the_disk`], also giving the topic of the message whose write failed: unless the
/// file was closed valid, that message may or may not be in it (its chunk may be whole on
/// disk with what follows the chunk cut off).
fn fill_the_disk_to(reserve_bytes: u64, disk: &Path) -> (RecordError, Digests, String, PathBuf) {
    let path = disk.join("full.mcap");
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
                if closed_valid(&error) {
                    digests.add(&channels[m.channel].topic, m.seq, &m.data);
                }
                // Stopped: everything after is refused, and says why.
                let again = recorder.write(&sample(ids[m.channel], &m)).unwrap_err();
                assert!(matches!(again, RecordError::Stopped { .. }), "{again:?}");
                return (error, digests, channels[m.channel].topic.clone(), path);
            }
        }
    }
    panic!("a 2 MiB disk never filled up");
}

fn closed_valid(error: &RecordError) -> bool {
    matches!(
        error,
        RecordError::DiskFull {
            closed_valid: true,
            ..
        } | RecordError::FileTooLarge {
            closed_valid: true,
            ..
        }
    )
}

/// The size of the small disk.
const DISK_BYTES: u64 = 2 * 1024 * 1024;

/// Runs `test` on a small disk (a tmpfs, or a file size limit in a child process: see
/// [`SmallDisk`]); `test` gets the disk and a folder elsewhere.
fn with_small_disk(name: &str, test: impl FnOnce(&SmallDisk, &Path)) {
    let dir = tempfile::tempdir().unwrap();
    let disk_dir = dir.path().join("disk");
    std::fs::create_dir_all(&disk_dir).unwrap();
    let disk = SmallDisk::new(&disk_dir, DISK_BYTES);
    disk.run(name, |disk| {
        let elsewhere = tempfile::tempdir().unwrap();
        test(disk, elsewhere.path());
    });
}

#[test]
fn a_full_disk_stops_the_recorder_with_the_file_closed_valid() {
    with_small_disk(
        "a_full_disk_stops_the_recorder_with_the_file_closed_valid",
        |disk, _| {
            let (error, digests, path) = fill_the_disk(256 * 1024, disk.dir());
            // A full tmpfs gives the reserve back; a file size limit keeps the reserve's
            // size as headroom below it. Either way the file is closed valid.
            match disk.kind() {
                Kind::Tmpfs => {
                    assert!(
                        matches!(&error, RecordError::DiskFull { path: p, closed_valid: true } if *p == path),
                        "{error:?}"
                    );
                    assert!(error.to_string().contains("disk is full"), "{error}");
                }
                Kind::FileSizeLimit => {
                    assert!(
                        matches!(&error, RecordError::FileTooLarge { path: p, closed_valid: true } if *p == path),
                        "{error:?}"
                    );
                    assert!(error.to_string().contains("largest size"), "{error}");
                    assert!(std::fs::metadata(&path).unwrap().len() <= DISK_BYTES);
                }
            }
            assert!(
                !disk.dir().join(".full.mcap.reserve").exists(),
                "the reserve is given back"
            );
            doctor(&path);
            let view = python_read(&[path]);
            assert_eq!(view.digests(), digests.finish());
            assert!(view.loss(0).values().all(|&n| n == 0));
        },
    );
}

#[test]
fn a_full_disk_without_reserve_leaves_a_file_that_recover_repairs() {
    with_small_disk(
        "a_full_disk_without_reserve_leaves_a_file_that_recover_repairs",
        |disk, elsewhere| {
            let (error, digests, failed_topic, path) = fill_the_disk_to(0, disk.dir());
            match disk.kind() {
                Kind::Tmpfs => assert!(
                    matches!(&error, RecordError::DiskFull { path: p, closed_valid: false } if *p == path),
                    "{error:?}"
                ),
                Kind::FileSizeLimit => assert!(
                    matches!(&error, RecordError::FileTooLarge { path: p, closed_valid: false } if *p == path),
                    "{error:?}"
                ),
            }
            assert!(error.to_string().contains("lewis recover"), "{error}");
            let fixed = elsewhere.join("fixed.mcap");
            let report = recover(&path, &fixed).unwrap();
            assert!(!report.input_complete);
            doctor(&fixed);
            let view = python_read(&[fixed]);
            let got = view.digests();
            let written = digests.finish();
            // Every message recovered is one that was written, in order; the last chunk may
            // be lost, and the message whose write failed may be there.
            for (topic, digest) in &got {
                assert_eq!(digest.seq_runs.len(), 1, "{topic}");
                let offered = written[topic].count + u64::from(*topic == failed_topic);
                assert!(
                    digest.count <= offered,
                    "{topic}: {} recovered of {offered}",
                    digest.count
                );
                assert_eq!(digest.seq_runs[0][0], 1, "{topic}");
            }
            assert!(report.messages > 0);
        },
    );
}
