//! A small disk for the disk-full tests, whatever the privileges of the test.
//!
//! - A **tmpfs** of the given size, when one can be mounted (root with `CAP_SYS_ADMIN`):
//!   the file system really fills up and `write` fails with `ENOSPC`.
//! - Otherwise a **file size limit** (`RLIMIT_FSIZE`) on the process that writes, in an
//!   ordinary folder: `write` fails with `EFBIG` once a file reaches the size (the process
//!   ignores `SIGXFSZ`, which would otherwise kill it). No privilege is needed; the
//!   recorder meets the same kind of failure in the middle of a file.
//!
//! Which one a test got is printed, and the test checks the outcome that one must give:
//! nothing passes silently. `LEWIS_TEST_SMALL_DISK=fsize` forces the second (to test it
//! where a tmpfs could be mounted).
//!
//! With a file size limit, a test body that writes in-process runs in a child process
//! ([`SmallDisk::run`]: the test binary again, filtered to that one test), so that the
//! limit never touches the other tests of the binary.

// Helpers of tests: a failed expectation is the test's failure, said with its reason.
#![allow(clippy::expect_used, clippy::print_stderr)]

use std::os::unix::process::CommandExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Forces the kind of small disk: `fsize` for the file size limit.
pub const KIND_ENV: &str = "LEWIS_TEST_SMALL_DISK";

/// Set in a child test process that runs a body under a file size limit: the folder.
const CHILD_DIR_ENV: &str = "LEWIS_TEST_SMALL_DISK_CHILD_DIR";
/// Set in that child: the limit in bytes.
const CHILD_BYTES_ENV: &str = "LEWIS_TEST_SMALL_DISK_CHILD_BYTES";

/// What kind of small disk a test got.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A tmpfs that fills up (`ENOSPC`).
    Tmpfs,
    /// A file size limit on the writing process (`EFBIG`).
    FileSizeLimit,
}

/// A small disk in a folder, unmounted on drop.
#[derive(Debug)]
pub struct SmallDisk {
    dir: PathBuf,
    bytes: u64,
    kind: Kind,
    mounted: bool,
}

impl SmallDisk {
    /// A small disk of `bytes` at the existing empty folder `dir`: a tmpfs if one can be
    /// mounted there, else a file size limit (see the module docs). Says which on stderr.
    ///
    /// # Panics
    /// Never on a lack of privileges; only when `dir` is not a folder.
    #[must_use]
    pub fn new(dir: &Path, bytes: u64) -> Self {
        assert!(dir.is_dir(), "{} is not a folder", dir.display());
        if let (Some(child_dir), Some(child_bytes)) = (
            std::env::var_os(CHILD_DIR_ENV),
            std::env::var(CHILD_BYTES_ENV).ok(),
        ) {
            // The child process of `run`: the limit is already on this process.
            return Self {
                dir: PathBuf::from(child_dir),
                bytes: child_bytes.parse().expect("the limit is a number"),
                kind: Kind::FileSizeLimit,
                mounted: false,
            };
        }
        let forced = std::env::var(KIND_ENV).is_ok_and(|k| k == "fsize");
        let mount = if forced {
            Err("LEWIS_TEST_SMALL_DISK=fsize".to_owned())
        } else {
            mount_tmpfs(dir, &format!("size={bytes}"))
        };
        match mount {
            Ok(()) => {
                eprintln!(
                    "small disk: a tmpfs of {bytes} bytes mounted at {}",
                    dir.display()
                );
                Self {
                    dir: dir.to_path_buf(),
                    bytes,
                    kind: Kind::Tmpfs,
                    mounted: true,
                }
            }
            Err(why) => {
                eprintln!(
                    "small disk: no tmpfs ({why}): a file size limit (RLIMIT_FSIZE) of {bytes} bytes on the writer instead, in {}",
                    dir.display()
                );
                Self {
                    dir: dir.to_path_buf(),
                    bytes,
                    kind: Kind::FileSizeLimit,
                    mounted: false,
                }
            }
        }
    }

    /// The folder to write in.
    #[must_use]
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// What kind of disk it is.
    #[must_use]
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// Makes the process `command` starts write on this disk: for a file size limit, it
    /// gets the limit and ignores `SIGXFSZ`; a tmpfs needs nothing.
    pub fn apply(&self, command: &mut Command) {
        if self.kind == Kind::FileSizeLimit {
            limit_file_size(command, self.bytes);
        }
    }

    /// Runs `body` with this disk's folder where the disk applies: in this process for a
    /// tmpfs (or in the child that is already under the limit); for a file size limit, in
    /// a child process running only the test `test` of this binary, whose success it
    /// asserts. `test` is the test function's path within the binary (its name for a test
    /// at the top of the file).
    ///
    /// # Panics
    /// When the child fails (its output is shown).
    pub fn run(&self, test: &str, body: impl FnOnce(&SmallDisk)) {
        if self.kind == Kind::Tmpfs || std::env::var_os(CHILD_DIR_ENV).is_some() {
            body(self);
            return;
        }
        let exe = std::env::current_exe().expect("the test binary has a path");
        let mut child = Command::new(exe);
        child
            .args([test, "--exact", "--nocapture", "--test-threads", "1"])
            .env(CHILD_DIR_ENV, &self.dir)
            .env(CHILD_BYTES_ENV, self.bytes.to_string());
        limit_file_size(&mut child, self.bytes);
        let output = child.output().expect("the test binary runs again");
        let printed = format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(
            output.status.success() && printed.contains("1 passed"),
            "{test} under a file size limit failed ({}):\n{printed}",
            output.status
        );
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        if self.mounted {
            let _ = Command::new("umount").arg(&self.dir).status();
        }
    }
}

/// Mounts a tmpfs with `options` at `dir`; `Err` says why not.
pub fn mount_tmpfs(dir: &Path, options: &str) -> Result<(), String> {
    let output = Command::new("mount")
        .args(["-t", "tmpfs", "-o", options, "tmpfs"])
        .arg(dir)
        .output()
        .map_err(|e| format!("cannot run mount: {e}"))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(format!(
            "mount says: {}",
            String::from_utf8_lossy(&output.stderr)
                .lines()
                .next()
                .unwrap_or("")
                .trim()
        ))
    }
}

/// Gives the process `command` starts a file size limit of `bytes` and makes it ignore
/// `SIGXFSZ`, so that a write past the limit fails with `EFBIG` instead of killing it.
fn limit_file_size(command: &mut Command, bytes: u64) {
    // SAFETY: between fork and exec the closure only makes two system calls (setrlimit and
    // sigaction), both async-signal-safe; it allocates nothing and takes no lock.
    unsafe {
        command.pre_exec(move || {
            rustix::process::setrlimit(
                rustix::process::Resource::Fsize,
                rustix::process::Rlimit {
                    current: Some(bytes),
                    maximum: Some(bytes),
                },
            )
            .map_err(std::io::Error::from)?;
            nix::sys::signal::signal(
                nix::sys::signal::Signal::SIGXFSZ,
                nix::sys::signal::SigHandler::SigIgn,
            )
            .map_err(std::io::Error::from)?;
            Ok(())
        });
    }
}
