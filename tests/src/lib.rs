//! Helpers for the end-to-end tests in `tests/tests/`: where the repository, the shared
//! data and the independent Python readers are, and a fresh temporary directory and IPC
//! namespace for each test.

// Helpers of tests: a failed expectation is the test's failure, said with its reason.
#![allow(clippy::expect_used, clippy::print_stderr)]

use std::path::PathBuf;
use std::process::Command;

pub use lewis_testkit::repository_root as repo_root;
// The generic helpers live in the test kit (below the runtime, so the tests of the crates
// used here can share them without a cycle); the end-to-end tests keep naming them here.
pub use lewis_testkit::{
    WATCHDOG, Watched, browser, descendants, doctor, hosts, hosts_or_skip, python_tool, run_ok,
    shared_data, signal, small_disk, wait_child, wait_child_within,
};

pub mod broker;
pub mod fake_device;
pub mod robot;
pub mod stress;

use std::io::{BufRead, BufReader};
use std::process::{Child, Stdio};
use std::rc::Rc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::client::Client;
use lewis_runtime::ipc::{Ipc, Namespace, NodeLiveness, WakeMode};

/// The `lewis` binary, built once per test process ([`lewis_testkit::lewis_exe`]), after
/// wiping what ended test runs left in shared memory ([`wipe_ended_test_namespaces`]).
///
/// # Panics
/// When the binary cannot be built.
#[must_use]
pub fn lewis_exe() -> PathBuf {
    wipe_ended_test_namespaces();
    lewis_testkit::lewis_exe()
}

/// A running `lewis up`, in its own namespace and temporary directory, with its output
/// collected line by line. Dropping it kills it (and so its services).
pub struct Up {
    child: Child,
    /// Its namespace.
    pub namespace: Namespace,
    /// Its temporary directory (the robot file is `robot.toml` there).
    pub dir: tempfile::TempDir,
    lines: Receiver<String>,
    /// Every line it wrote so far (stderr), for diagnostics.
    pub seen: Vec<String>,
}

impl Up {
    /// Writes `robot` to a fresh temporary directory and starts `lewis up` on it in a fresh
    /// namespace named after `tag`.
    ///
    /// # Panics
    /// When the directory or the process cannot be made.
    #[must_use]
    pub fn start(tag: &str, robot: &str) -> Self {
        let dir = tempfile::tempdir().expect("a temporary directory");
        Self::start_in(dir, Namespace::unique(tag), robot)
    }

    /// As [`Up::start`] in a given directory and namespace.
    ///
    /// # Panics
    /// When the robot file or the process cannot be made.
    #[must_use]
    pub fn start_in(dir: tempfile::TempDir, namespace: Namespace, robot: &str) -> Self {
        Self::start_with(dir, namespace, robot, &[])
    }

    /// As [`Up::start_in`] with more arguments for `lewis up` (`-o FILE`, `--no-record`).
    /// It runs in the temporary directory, so its default recording goes to `logs/` there.
    ///
    /// # Panics
    /// When the robot file or the process cannot be made.
    #[must_use]
    pub fn start_with(
        dir: tempfile::TempDir,
        namespace: Namespace,
        robot: &str,
        args: &[&std::ffi::OsStr],
    ) -> Self {
        Self::spawn(dir, namespace, robot, args, Command::new(lewis_exe()))
    }

    /// As [`Up::start_with`], with the command that runs `lewis` given (a `lewis` run
    /// through `nsenter` in a network namespace, with variables of its own).
    ///
    /// # Panics
    /// When the robot file or the process cannot be made.
    #[must_use]
    pub fn start_with_command(
        dir: tempfile::TempDir,
        namespace: Namespace,
        robot: &str,
        args: &[&std::ffi::OsStr],
        command: Command,
    ) -> Self {
        Self::spawn(dir, namespace, robot, args, command)
    }

    /// As [`Up::start`], in a session of its own: what it sets for its session (the
    /// scheduler's session group, by `[broker] nice`) stays its own, not the test's.
    ///
    /// # Panics
    /// When the robot file or the process cannot be made.
    #[must_use]
    pub fn start_in_own_session(tag: &str, robot: &str) -> Self {
        use std::os::unix::process::CommandExt as _;
        let mut command = Command::new(lewis_exe());
        // SAFETY: setsid is async-signal-safe and touches nothing of the parent.
        unsafe {
            command.pre_exec(|| {
                nix::unistd::setsid()
                    .map(drop)
                    .map_err(std::io::Error::from)
            });
        }
        let dir = tempfile::tempdir().expect("a temporary directory");
        Self::spawn(dir, Namespace::unique(tag), robot, &[], command)
    }

    fn spawn(
        dir: tempfile::TempDir,
        namespace: Namespace,
        robot: &str,
        args: &[&std::ffi::OsStr],
        mut command: Command,
    ) -> Self {
        let robot_path = dir.path().join("robot.toml");
        std::fs::write(&robot_path, robot).expect("the robot file can be written");
        let mut child = command
            .arg("up")
            .arg(&robot_path)
            .args(["--namespace", namespace.as_str(), "--stop-grace-ms", "300"])
            .args(args)
            .current_dir(dir.path())
            // `-v`: the tests read the broker's every decision (`start ghost`), which a
            // person sees only when asking for it.
            .arg("-v")
            .env_remove("RUST_LOG")
            // `LEWIS_TEST_LOG=lewis_runtime=trace` to see more of a run under study.
            .envs(
                std::env::var("LEWIS_TEST_LOG")
                    .ok()
                    .map(|f| ("RUST_LOG", f)),
            )
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("lewis up starts");
        let stderr = child.stderr.take().expect("stderr is piped");
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            child,
            namespace,
            dir,
            lines,
            seen: Vec::new(),
        }
    }

    /// The path of a file in the temporary directory.
    #[must_use]
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// The process id of `lewis up`.
    #[must_use]
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Waits (at most [`WATCHDOG`]) for an output line that contains `needle`, and returns it.
    ///
    /// # Panics
    /// When no such line comes, printing everything seen.
    pub fn wait_line(&mut self, needle: &str) -> String {
        self.wait_line_within(needle, WATCHDOG)
    }

    /// [`Up::wait_line`] with a watchdog of `limit` (a run meant to last longer than
    /// [`WATCHDOG`]).
    ///
    /// # Panics
    /// When no such line comes, printing everything seen.
    pub fn wait_line_within(&mut self, needle: &str, limit: Duration) -> String {
        let deadline = Instant::now() + limit;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    self.seen.push(line.clone());
                    if line.contains(needle) {
                        return line;
                    }
                }
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => panic!(
                    "lewis up never wrote a line with `{needle}`; it wrote:\n{}",
                    self.seen.join("\n")
                ),
            }
        }
    }

    /// Takes the lines written so far without waiting.
    pub fn drain(&mut self) {
        while let Ok(line) = self.lines.try_recv() {
            self.seen.push(line);
        }
    }

    /// Stops it with SIGTERM and waits (watchdog) for it to end; returns its exit status.
    ///
    /// # Panics
    /// When it does not end.
    pub fn stop(&mut self) -> std::process::ExitStatus {
        signal(self.child.id(), nix::sys::signal::Signal::SIGTERM);
        let status = wait_child(&mut self.child);
        // The reader thread ends with the pipe; collect what it read.
        while let Ok(line) = self.lines.recv_timeout(WATCHDOG) {
            self.seen.push(line);
        }
        status
    }

    /// Kills it with SIGKILL and reaps it.
    pub fn kill(&mut self) {
        signal(self.child.id(), nix::sys::signal::Signal::SIGKILL);
        let _ = wait_child(&mut self.child);
    }

    /// The broker's status report (`lewis status`), asked in-process.
    ///
    /// # Panics
    /// When the broker does not answer.
    #[must_use]
    pub fn status(&self) -> String {
        let ipc = Ipc::open(&self.namespace, "test-status").expect("the test's IPC node opens");
        broker::status(&ipc)
    }

    /// Asks for the status report until `accept` accepts it (watchdog) and returns it; see
    /// [`broker::wait_status`] (it waits for decisions and heartbeats between two reports).
    ///
    /// # Panics
    /// When no report is accepted in time.
    pub fn wait_status(&self, what: &str, accept: impl Fn(&str) -> bool) -> String {
        broker::wait_status(&self.namespace, what, accept)
    }

    /// The pid of `service`'s process, as the broker reports it (`process NAME: pid PID`).
    ///
    /// # Panics
    /// When the broker reports no process for it.
    #[must_use]
    pub fn pid_of(&self, service: &str) -> u32 {
        let report = self.status();
        report
            .lines()
            .find_map(|l| {
                let (name, pid) = l.strip_prefix("process ")?.split_once(": pid ")?;
                (name == service).then(|| pid.trim().parse().ok())?
            })
            .unwrap_or_else(|| panic!("no process of {service} in the status:\n{report}"))
    }

    /// Its log as one text.
    #[must_use]
    pub fn log(&self) -> String {
        self.seen.join("\n")
    }
}

impl Drop for Up {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        if std::thread::panicking() {
            while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(1)) {
                self.seen.push(line);
            }
            eprintln!("lewis up wrote:\n{}", self.log());
        }
    }
}

/// Removes, once per test process, what the namespaces of earlier test runs left in
/// `/dev/shm` and `/tmp/iceoryx2` once those runs have ended: nothing else removes it, and
/// it adds up run after run. Called on the ways every end-to-end test takes into IPC
/// ([`lewis_exe`], [`open_ipc`]); a namespace some live process uses stays.
pub fn wipe_ended_test_namespaces() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let report = lewis_runtime::ipc::wipe_orphaned_namespaces();
        if report.removed > 0 {
            eprintln!(
                "removed {} leftovers of {} namespaces of ended test runs",
                report.removed, report.wiped
            );
        }
    });
}

/// Opens an IPC node in `namespace` for a test.
///
/// # Panics
/// When it cannot be opened.
#[must_use]
pub fn open_ipc(namespace: &Namespace, name: &str) -> Rc<Ipc> {
    wipe_ended_test_namespaces();
    Rc::new(Ipc::open(namespace, name).expect("the test's IPC node opens"))
}

/// Waits (watchdog) until a live node named `name` is in the namespace, and returns its pid;
/// `except` skips a pid (the process that was just killed).
///
/// # Panics
/// When none appears.
#[must_use]
pub fn wait_node(ipc: &Ipc, name: &str, except: Option<u32>) -> u32 {
    let deadline = Instant::now() + WATCHDOG;
    // Node files appear without any event to wait on: this is the one place that polls,
    // at a modest rate, under the watchdog.
    loop {
        let nodes = ipc.nodes().expect("the node list can be read");
        if let Some(pid) = nodes
            .iter()
            .filter(|n| n.liveness == NodeLiveness::Alive && n.name.as_deref() == Some(name))
            .filter_map(|n| n.pid.and_then(|p| u32::try_from(p).ok()))
            .find(|p| Some(*p) != except)
        {
            return pid;
        }
        assert!(
            Instant::now() < deadline,
            "no live node `{name}` appeared; nodes: {nodes:?}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The test application: it holds a `Client<RangeFinder>` and records which provider each
/// sample came from. It contains no failover logic.
pub struct RangeApp {
    client: Client<RangeFinder>,
    /// Reads samples in place (`recv_view_timeout`) instead of decoding them.
    in_place: bool,
    /// The provider of every sample received, in order.
    pub providers: Vec<String>,
}

impl RangeApp {
    /// Connects as client `app` to the broker of `ipc`'s namespace.
    ///
    /// # Panics
    /// When the broker's channels cannot be opened.
    #[must_use]
    pub fn connect(ipc: &Rc<Ipc>) -> Self {
        Self {
            client: Client::connect(ipc, "app").expect("the client connects"),
            in_place: false,
            providers: Vec::new(),
        }
    }

    /// As [`RangeApp::connect`], reading every sample in place (zero-copy views).
    #[must_use]
    pub fn connect_in_place(ipc: &Rc<Ipc>) -> Self {
        Self {
            in_place: true,
            ..Self::connect(ipc)
        }
    }

    /// This application, busy polling for its samples ([`WakeMode::BusyPoll`]) rather than
    /// waiting for wake-ups.
    #[must_use]
    pub fn busy_polling(self) -> Self {
        Self {
            client: self.client.with_wake_mode(WakeMode::BusyPoll),
            ..self
        }
    }

    /// Receives samples until `count` consecutive ones came from `provider` (watchdog);
    /// returns how many samples that took.
    ///
    /// # Panics
    /// When that does not happen, listing the providers seen.
    pub fn wait_for(&mut self, provider: &str, count: usize) -> usize {
        let deadline = Instant::now() + WATCHDOG;
        let start = self.providers.len();
        let mut run = 0;
        while run < count {
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(
                !left.is_zero(),
                "never got {count} samples in a row from {provider}; got from: {:?}",
                &self.providers[start..]
            );
            let received = if self.in_place {
                self.client
                    .recv_view_timeout(left, |scan| scan.header.provider.to_owned())
            } else {
                self.client
                    .recv_timeout(left)
                    .map(|sample| sample.map(|s| s.message.header.provider))
            };
            if let Some(from) = received.expect("the client works") {
                run = if from == provider { run + 1 } else { 0 };
                self.providers.push(from);
            }
        }
        self.providers.len() - start
    }

    /// The provider the client is bound to now.
    #[must_use]
    pub fn provider(&self) -> Option<&str> {
        self.client.provider()
    }
}
