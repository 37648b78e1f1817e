//! The processes of an end-to-end test: the `lewis` binary, a command run to completion,
//! a child or any process awaited under a watchdog (on its pidfd, never by polling), and
//! the independent Python readers that check an MCAP file.

// Helpers of tests: a failed expectation is the test's failure, said with its reason.
#![allow(clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::OnceLock;
use std::time::Duration;

use crate::repository_root;

/// The longest any end-to-end wait may take before the test fails: a watchdog against
/// deadlocks, not a timing assertion.
pub const WATCHDOG: Duration = Duration::from_secs(30);

/// The `lewis` binary, built once per test process.
///
/// `CARGO_BIN_EXE_lewis` exists only for the `lewis` package's own tests, so the binary is
/// located in the target directory of this test executable (`target/<profile>/lewis`) after
/// `cargo build -p lewis --bin lewis` into that same directory (fast when it is up to date,
/// and never stale). `LEWIS_EXE` overrides it.
///
/// It only builds and locates: the end-to-end tests' `lewis_tests::lewis_exe` also wipes
/// what ended test runs left in shared memory, which needs the runtime.
///
/// # Panics
/// When the binary cannot be built.
#[must_use]
pub fn lewis_exe() -> PathBuf {
    static EXE: OnceLock<PathBuf> = OnceLock::new();
    EXE.get_or_init(|| {
        if let Some(exe) = std::env::var_os("LEWIS_EXE") {
            return PathBuf::from(exe);
        }
        let test_exe = std::env::current_exe().expect("the test executable has a path");
        // target/<profile>/deps/<test executable>
        let profile_dir = test_exe
            .parent()
            .and_then(Path::parent)
            .expect("the test executable lives in target/<profile>/deps");
        let target_dir = profile_dir.parent().expect("target/<profile> has a parent");
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut build = Command::new(cargo);
        build
            .args(["build", "--quiet", "-p", "lewis", "--bin", "lewis"])
            .env("CARGO_TARGET_DIR", target_dir)
            .current_dir(repository_root());
        if profile_dir.file_name().is_some_and(|n| n == "release") {
            build.arg("--release");
        }
        let status = build.status().expect("cargo can be run to build lewis");
        assert!(status.success(), "cargo build -p lewis failed: {status}");
        profile_dir.join("lewis")
    })
    .clone()
}

/// A command running a program of the Python environment made by
/// `scripts/setup-python.sh` (`python`, `pymcap-cli`, ...).
///
/// # Panics
/// When the environment is missing, saying how to make it.
#[must_use]
pub fn python_tool(name: &str) -> Command {
    let venv = std::env::var_os("LEWIS_VENV")
        .map_or_else(|| repository_root().join(".venv"), PathBuf::from);
    let program = venv.join("bin").join(name);
    assert!(
        program.exists(),
        "{} is missing: run scripts/setup-python.sh to install the independent MCAP readers",
        program.display()
    );
    Command::new(program)
}

/// Runs a command to completion and returns its stdout, or panics with everything it
/// printed.
///
/// # Panics
/// When the command cannot start or exits unsuccessfully.
#[must_use]
pub fn run_ok(command: &mut Command) -> String {
    let output = command
        .output()
        .unwrap_or_else(|err| panic!("cannot run {command:?}: {err}"));
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{command:?} failed ({}):\n{stdout}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

/// Checks an MCAP file with independent tools: `pymcap-cli doctor` and Rerun's `rerun mcap
/// check` must both pass (the latter exits 0 and marks what it finds wrong with PROBLEM,
/// e.g. a channel whose chunks go back in time).
///
/// # Panics
/// When either tool reports a problem, or cannot run.
pub fn doctor(file: &Path) {
    let out = run_ok(python_tool("pymcap-cli").arg("doctor").arg(file));
    // Its summary counts errors ("0 errors, 15 warnings"); a warning (an incompressible
    // chunk of camera noise stored compressed) is advice, not a problem of the file.
    let errors = out
        .split(|c: char| !c.is_ascii_alphanumeric())
        .collect::<Vec<_>>()
        .windows(2)
        .any(|w| w[1].starts_with("error") && w[0] != "0");
    assert!(
        !errors && !out.contains("Error"),
        "pymcap-cli doctor reports a problem in {}:\n{out}",
        file.display()
    );
    let out = run_ok(python_tool("rerun").args(["mcap", "check"]).arg(file));
    assert!(
        !out.contains("PROBLEM"),
        "rerun mcap check reports a problem in {}:\n{out}",
        file.display()
    );
}

/// Sends a signal to a process.
///
/// # Panics
/// When the pid does not fit or the signal cannot be sent.
pub fn signal(pid: u32, signal: nix::sys::signal::Signal) {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(pid).expect("pids fit an i32"));
    nix::sys::signal::kill(pid, signal).expect("the signal can be sent");
}

/// Waits (watchdog) for a child to end.
///
/// # Panics
/// When it is still running after [`WATCHDOG`].
pub fn wait_child(child: &mut Child) -> std::process::ExitStatus {
    wait_child_within(child, WATCHDOG)
}

/// Waits for a child to end, at most `limit` (a watchdog, not a timing assertion), on its
/// pidfd.
///
/// # Panics
/// When it is still running after `limit`.
pub fn wait_child_within(child: &mut Child, limit: Duration) -> std::process::ExitStatus {
    let pidfd = rustix::process::pidfd_open(
        rustix::process::Pid::from_child(child),
        rustix::process::PidfdFlags::empty(),
    )
    .expect("pidfd_open works on this kernel");
    assert!(
        wait_readable(&pidfd, limit),
        "process {} still runs after {limit:?}",
        child.id()
    );
    child.wait().expect("the child can be reaped")
}

/// Waits (at most `timeout`) for a descriptor to become readable; returns whether it did.
fn wait_readable(fd: &impl std::os::fd::AsFd, timeout: Duration) -> bool {
    let mut fds = [nix::poll::PollFd::new(
        fd.as_fd(),
        nix::poll::PollFlags::POLLIN,
    )];
    let timeout = nix::poll::PollTimeout::try_from(timeout).unwrap_or(nix::poll::PollTimeout::MAX);
    matches!(nix::poll::poll(&mut fds, timeout), Ok(n) if n > 0)
}

/// A process that is not our child, watched through a pidfd so that its end can be awaited.
#[derive(Debug)]
pub struct Watched {
    pid: u32,
    pidfd: std::os::fd::OwnedFd,
}

impl Watched {
    /// Starts watching process `pid`.
    ///
    /// # Panics
    /// When the process does not exist.
    #[must_use]
    pub fn new(pid: u32) -> Self {
        let raw = rustix::process::Pid::from_raw(i32::try_from(pid).expect("pids fit an i32"))
            .expect("a pid is not zero");
        let pidfd = rustix::process::pidfd_open(raw, rustix::process::PidfdFlags::empty())
            .unwrap_or_else(|e| panic!("process {pid} does not exist: {e}"));
        Self { pid, pidfd }
    }

    /// Waits at most [`WATCHDOG`] for it to end; returns whether it did.
    #[must_use]
    pub fn wait_gone(&self) -> bool {
        wait_readable(&self.pidfd, WATCHDOG)
    }

    /// Its pid.
    #[must_use]
    pub fn pid(&self) -> u32 {
        self.pid
    }
}

/// The process of Lewis service `service` (`lewis service NAME`) descended from `pid`,
/// found by its command line: for a process the local broker does not report (one on
/// another host).
///
/// # Panics
/// When `/proc` cannot be read.
#[must_use]
pub fn service_process_under(pid: u32, service: &str) -> Option<u32> {
    descendants(pid).into_iter().find(|pid| {
        std::fs::read(format!("/proc/{pid}/cmdline")).is_ok_and(|cmdline| {
            let words: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
            words
                .windows(2)
                .any(|w| w[0] == b"service" && w[1] == service.as_bytes())
        })
    })
}

/// Every process descended from `pid` (children, their children, ...), from `/proc`.
///
/// # Panics
/// When `/proc` cannot be read.
#[must_use]
pub fn descendants(pid: u32) -> Vec<u32> {
    let mut parent_of = Vec::new();
    for entry in std::fs::read_dir("/proc")
        .expect("/proc can be read")
        .flatten()
    {
        let Some(child) = entry
            .file_name()
            .to_str()
            .and_then(|n| n.parse::<u32>().ok())
        else {
            continue;
        };
        // `pid (comm) state ppid ...`: comm may hold spaces and parentheses, so the fields
        // are counted from the last `)`.
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else {
            continue;
        };
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        if let Some(ppid) = ppid {
            parent_of.push((child, ppid));
        }
    }
    let mut found = vec![pid];
    let mut i = 0;
    while i < found.len() {
        let parent = found[i];
        found.extend(
            parent_of
                .iter()
                .filter(|(_, p)| *p == parent)
                .map(|(c, _)| *c),
        );
        i += 1;
    }
    found.remove(0);
    found.sort_unstable();
    found
}
