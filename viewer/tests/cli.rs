//! `lewis view` as a user runs it (the real binary, with a PATH the test controls): a
//! `rerun` on the PATH is started and receives the run; without one, `RUN.rrd` is written
//! next to the recording with a hint on how to open it; an address where nothing listens
//! is a clear error.
//!
//! The `rerun` on the PATH is a script that records its arguments and then runs the real
//! Rerun CLI (the PyPI `rerun-sdk` in `.venv`) as a headless server that saves what it
//! receives, so the test sees what a viewer would have been sent.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use std::time::{Duration, Instant};

use lewis_testkit::{
    WATCHDOG, Watched, lewis_exe, python_tool, repository_root, run_ok, wait_child,
};

/// The folders every test's PATH has besides its own: the system's tools, never a `rerun`.
const SYSTEM_PATH: &str = "/usr/bin:/bin";

/// What `lewis view` did: its exit status and what it printed.
struct Ran {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
}

impl Ran {
    fn printed(&self) -> String {
        format!("{}{}", self.stdout, self.stderr)
    }
}

/// Runs `lewis view ARGS` in `dir` with `path` as PATH (and `env`), under a watchdog. Its
/// output goes to files: a viewer it starts inherits them and outlives it.
fn lewis_view(dir: &Path, args: &[&std::ffi::OsStr], path: &str, env: &[(&str, &Path)]) -> Ran {
    let (stdout, stderr) = (dir.join("view.out"), dir.join("view.err"));
    let mut command = Command::new(lewis_exe());
    command
        .arg("view")
        .args(args)
        .env("PATH", path)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&stdout).unwrap())
        .stderr(std::fs::File::create(&stderr).unwrap());
    for (key, value) in env {
        command.env(key, value);
    }
    let mut child = command.spawn().unwrap();
    let status = wait_child(&mut child);
    Ran {
        status,
        stdout: std::fs::read_to_string(stdout).unwrap(),
        stderr: std::fs::read_to_string(stderr).unwrap(),
    }
}

/// Stops the viewer whose pid is in a file, if it was started, when the test ends however
/// it ends: its process group, which the SDK made for it.
struct ViewerGuard(PathBuf);

impl ViewerGuard {
    fn group(&self) -> Option<nix::unistd::Pid> {
        let pid: i32 = std::fs::read_to_string(&self.0).ok()?.trim().parse().ok()?;
        Some(nix::unistd::Pid::from_raw(pid))
    }
}

impl Drop for ViewerGuard {
    fn drop(&mut self) {
        if let Some(group) = self.group() {
            let _ = nix::sys::signal::killpg(group, nix::sys::signal::Signal::SIGKILL);
        }
    }
}

/// Held by a test while it uses a port from [`free_port`]: a port found free and let go
/// could be found free again by a test running beside it.
static PORTS: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// A free TCP port on localhost, for a viewer of this test only (hold [`PORTS`]).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Writes the `rerun` stand-in into `bin` (see the module's documentation).
fn fake_rerun(bin: &Path) {
    std::fs::create_dir_all(bin).unwrap();
    let script = bin.join("rerun");
    std::fs::write(
        &script,
        "#!/bin/sh\n\
         printf '%s\\n' \"$*\" >> \"$LEWIS_TEST_RERUN_ARGS\"\n\
         if [ \"$1\" = \"--version\" ]; then echo 'rerun (stand-in)'; exit 0; fi\n\
         echo $$ > \"$LEWIS_TEST_RERUN_PID\"\n\
         exec \"$LEWIS_TEST_RERUN_REAL\" \"$@\" --save \"$LEWIS_TEST_RERUN_SAVE\"\n",
    )
    .unwrap();
    std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// What Rerun's reader finds in the file a viewer saves as it receives, once it holds the
/// blueprint (sent last); watchdog [`WATCHDOG`]. Nothing announces the write: the file is
/// read again every 200 ms.
fn wait_saved(saved: &Path) -> serde_json::Value {
    let script = repository_root().join("tools/python/check_rrd.py");
    let deadline = Instant::now() + WATCHDOG;
    let mut last = String::new();
    loop {
        if saved.is_file() {
            let out = python_tool("python")
                .arg(&script)
                .arg(saved)
                .output()
                .unwrap();
            last = String::from_utf8_lossy(&out.stdout).into_owned()
                + &String::from_utf8_lossy(&out.stderr);
            if let Ok(read) = serde_json::from_slice::<serde_json::Value>(&out.stdout)
                && read["blueprints"] == 1
            {
                return read;
            }
        }
        assert!(
            Instant::now() < deadline,
            "the viewer never saved the whole run to {}; last read:\n{last}",
            saved.display()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn with_rerun_on_the_path_lewis_view_starts_it_and_sends_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let bin = dir.path().join("bin");
    fake_rerun(&bin);
    let (args, pid, saved) = (
        dir.path().join("rerun-args.txt"),
        dir.path().join("rerun.pid"),
        dir.path().join("received.rrd"),
    );
    let _ports = PORTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let real = repository_root().join(".venv/bin/rerun");
    assert!(
        real.is_file(),
        "run scripts/setup-python.sh to install rerun-sdk in .venv"
    );
    let port = free_port();
    let guard = ViewerGuard(pid.clone());
    let output = lewis_view(
        dir.path(),
        &[
            run.as_os_str(),
            "--port".as_ref(),
            port.to_string().as_ref(),
        ],
        &format!("{}:{SYSTEM_PATH}", bin.display()),
        &[
            ("LEWIS_TEST_RERUN_ARGS", &args),
            ("LEWIS_TEST_RERUN_PID", &pid),
            ("LEWIS_TEST_RERUN_SAVE", &saved),
            ("LEWIS_TEST_RERUN_REAL", &real),
        ],
    );
    // The viewer outlives `lewis view`, as a viewer should. It writes what it received
    // at its own pace: wait until the file holds the layout, sent last, then kill it (its
    // process group, which the SDK made for it). SIGKILL: what it saved has been read, and
    // the PyPI viewer was seen to ignore SIGINT for over 30 s on a loaded machine.
    let group = guard
        .group()
        .unwrap_or_else(|| panic!("the viewer was not started: {}", output.printed()));
    let read = wait_saved(&saved);
    let watched = Watched::new(u32::try_from(group.as_raw()).unwrap());
    nix::sys::signal::killpg(group, nix::sys::signal::Signal::SIGKILL).unwrap();
    assert!(watched.wait_gone(), "the viewer {group} did not stop");

    assert!(output.status.success(), "{}", output.printed());
    assert!(
        output
            .stdout
            .contains(&format!("sent to the Rerun viewer on port {port}")),
        "{}",
        output.printed()
    );
    let calls = std::fs::read_to_string(&args).unwrap();
    let started = calls
        .lines()
        .find(|l| l.starts_with("--port="))
        .unwrap_or_else(|| panic!("rerun was never started as a viewer: {calls}"));
    assert!(
        started.starts_with(&format!("--port={port} ")) && started.contains("--expect-data-soon"),
        "{started}"
    );
    assert!(
        !run.with_extension("rrd").exists(),
        "no file is written when a viewer is there"
    );
    assert_eq!(read["rows"]["/world/robot/pose"], 20, "{read}");
    assert_eq!(read["rows"]["/events/broker"], 1, "{read}");
    assert_eq!(read["blueprints"], 1, "the layout was sent too: {read}");
}

#[test]
fn without_rerun_on_the_path_lewis_view_writes_run_rrd_and_says_how_to_open_it() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    // A `rerun` that cannot be executed is no viewer.
    let bin = dir.path().join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::write(bin.join("rerun"), "not a program").unwrap();
    let output = lewis_view(
        dir.path(),
        &[run.as_os_str()],
        &format!("{}:{SYSTEM_PATH}", bin.display()),
        &[],
    );
    assert!(output.status.success(), "{}", output.printed());
    let rrd: PathBuf = run.with_extension("rrd");
    let stdout = &output.stdout;
    assert!(
        stdout.contains(&format!("wrote {}", rrd.display())),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!(
            "no `rerun` viewer on the PATH: install it with `pip install rerun-sdk=={}`, then \
             run `rerun {}`",
            lewis_viewer::RERUN_SDK_PIP_VERSION,
            rrd.display()
        )),
        "{stdout}"
    );
    let _ = run_ok(python_tool("rerun").args(["rrd", "verify"]).arg(&rrd));
}

#[test]
fn connecting_where_no_viewer_listens_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let run = common::failover_run(dir.path());
    let _ports = PORTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let address = format!("rerun+http://127.0.0.1:{}/proxy", free_port());
    let output = lewis_view(
        dir.path(),
        &[run.as_os_str(), "--connect".as_ref(), address.as_ref()],
        SYSTEM_PATH,
        &[],
    );
    assert_eq!(output.status.code(), Some(2), "{}", output.printed());
    let stderr = &output.stderr;
    assert!(
        stderr.contains(&format!(
            "error: cannot send to the Rerun viewer at {address}"
        )) && stderr.contains("is `rerun` running there?"),
        "{stderr}"
    );
}
