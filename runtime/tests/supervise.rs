//! Process supervision with real processes (`/bin/sh`, `sleep`, `true`) and real signals.
//!
//! Nothing here sleeps to wait: exits are awaited on pidfds, lines on channels, each under a
//! watchdog that only turns a hang into a failure.

#![allow(
    clippy::expect_used,
    reason = "the helpers below are test code: a failed expectation is a failed test"
)]

use std::io::{BufRead, BufReader};
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc::{Receiver, sync_channel};
use std::time::Duration;

use lewis_robot::RestartPolicy;
use lewis_runtime::supervise::{
    ChildSpec, ExitStatus, LogLine, MAX_LINE_BYTES, Restart, StartError, Stream, Supervisor,
    SupervisorEvent,
};
use nix::sys::signal::Signal;
use rustix::event::{PollFd, PollFlags, poll};
use rustix::process::{Pid, PidfdFlags, pidfd_open};

/// Turns a hang into a failure; never reached when things work.
const WATCHDOG: Duration = Duration::from_secs(30);

const SIGTERM: i32 = 15;
const SIGKILL: i32 = 9;

fn sh(name: &str, script: &str) -> ChildSpec {
    ChildSpec::new(name, "/bin/sh").args(["-c", script])
}

fn supervisor_with_lines() -> (Supervisor, Receiver<LogLine>) {
    let (sink, lines) = sync_channel(1024);
    let supervisor = Supervisor::with_log_sink(sink).expect("supervisor");
    (supervisor, lines)
}

fn next_event(supervisor: &mut Supervisor) -> SupervisorEvent {
    supervisor
        .wait_event(Some(WATCHDOG))
        .expect("wait for an event")
        .expect("an event before the watchdog")
}

fn next_line(lines: &Receiver<LogLine>) -> LogLine {
    lines
        .recv_timeout(WATCHDOG)
        .expect("a log line before the watchdog")
}

/// Waits for the process `pid` (not necessarily our child) to be gone.
fn assert_gone(pid: u32) {
    let pid = Pid::from_raw(i32::try_from(pid).expect("pid fits i32")).expect("non-zero pid");
    let pidfd = match pidfd_open(pid, PidfdFlags::empty()) {
        Ok(fd) => fd,
        Err(rustix::io::Errno::SRCH) => return,
        Err(e) => panic!("pidfd_open({pid:?}): {e}"),
    };
    assert!(
        readable_within_watchdog(&pidfd),
        "process {pid:?} is still alive"
    );
}

fn readable_within_watchdog(fd: &OwnedFd) -> bool {
    let timeout = rustix::time::Timespec::try_from(WATCHDOG).expect("timespec");
    let mut fds = [PollFd::new(fd, PollFlags::IN)];
    poll(&mut fds, Some(&timeout)).expect("poll") == 1
}

fn exited(code: i32) -> ExitStatus {
    ExitStatus::Exited { code }
}

fn signalled(signal: i32) -> ExitStatus {
    ExitStatus::Signalled {
        signal,
        core_dumped: false,
    }
}

#[test]
fn exit_codes_and_signals_are_reported_with_the_name_and_pid() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    for (name, script, expected) in [
        ("clean", "exit 0", exited(0)),
        ("three", "exit 3", exited(3)),
        ("killed", "kill -KILL $$", signalled(SIGKILL)),
    ] {
        let pid = supervisor.start(sh(name, script)).expect("start");
        match next_event(&mut supervisor) {
            SupervisorEvent::Exited {
                name: got_name,
                pid: got_pid,
                status,
            } => assert_eq!((got_name.as_str(), got_pid, status), (name, pid, expected)),
            other => panic!("expected the exit of {name}, got {other:?}"),
        }
        assert_eq!(supervisor.pid(name), None);
    }
}

#[test]
fn any_name_is_accepted_even_one_no_thread_could_be_named_after() {
    let (mut supervisor, lines) = supervisor_with_lines();
    let name = "nul\0in name";
    supervisor
        .start(ChildSpec::new(name, "echo").arg("hello"))
        .expect("start");
    assert!(
        matches!(next_event(&mut supervisor), SupervisorEvent::Exited { name: n, .. } if n == name)
    );
    assert_eq!(&*next_line(&lines).name, name);
}

#[test]
fn a_program_that_cannot_start_is_a_typed_error_naming_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let not_executable = dir.path().join("data.txt");
    std::fs::write(&not_executable, "not a program").expect("write");
    let missing = PathBuf::from("/nonexistent/lewis-ghost");

    let check = |spec: ChildSpec, matches: &dyn Fn(&StartError) -> bool, mentions: &Path| {
        let mut supervisor = Supervisor::new().expect("supervisor");
        let error = supervisor.start(spec).expect_err("start must fail");
        assert!(matches(&error), "unexpected error {error:?}");
        let message = error.to_string();
        assert!(
            message.contains(&*mentions.to_string_lossy()),
            "{message:?} does not name {mentions:?}"
        );
        assert!(supervisor.running().is_empty());
        assert!(supervisor.try_event().expect("try_event").is_none());
    };
    check(
        ChildSpec::new("ghost", &missing),
        &|e| matches!(e, StartError::ProgramNotFound { name, program } if name == "ghost" && *program == missing),
        &missing,
    );
    check(
        ChildSpec::new("bare", "lewis-no-such-program-in-path"),
        &|e| matches!(e, StartError::ProgramNotFound { .. }),
        Path::new("lewis-no-such-program-in-path"),
    );
    check(
        ChildSpec::new("text", &not_executable),
        &|e| matches!(e, StartError::NotExecutable { .. }),
        &not_executable,
    );
    check(
        ChildSpec::new("lost", "true").cwd(dir.path().join("missing-dir")),
        &|e| matches!(e, StartError::WorkingDirNotFound { .. }),
        &dir.path().join("missing-dir"),
    );
}

#[test]
fn a_name_cannot_be_started_twice_while_running() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    let pid = supervisor
        .start(ChildSpec::new("once", "sleep").arg("1000"))
        .expect("start");
    let error = supervisor
        .start(ChildSpec::new("once", "sleep").arg("1000"))
        .expect_err("second start");
    assert!(matches!(error, StartError::AlreadyRunning { pid: p, .. } if p == pid));
}

#[test]
fn stdout_and_stderr_lines_arrive_tagged_with_the_name_and_stream() {
    let (mut supervisor, lines) = supervisor_with_lines();
    let pid = supervisor
        .start(sh(
            "talker",
            r"printf 'out one\nout two\r\n'; printf 'err \377\n' >&2; printf 'no newline'",
        ))
        .expect("start");
    let mut got: Vec<(Stream, String)> = (0..4)
        .map(|_| {
            let line = next_line(&lines);
            assert_eq!(
                (&*line.name, line.pid, line.continues),
                ("talker", pid, false)
            );
            (line.stream, line.text)
        })
        .collect();
    // Streams interleave as the threads read them; within a stream the order is kept.
    got.sort_by_key(|(stream, _)| *stream);
    assert_eq!(
        got,
        [
            (Stream::Stdout, "out one".to_owned()),
            (Stream::Stdout, "out two".to_owned()),
            (Stream::Stdout, "no newline".to_owned()),
            (Stream::Stderr, "err \u{fffd}".to_owned()),
        ]
    );
}

#[test]
fn a_very_long_line_arrives_split_into_marked_pieces() {
    let (mut supervisor, lines) = supervisor_with_lines();
    let length = 2 * MAX_LINE_BYTES + 100;
    supervisor
        .start(sh(
            "long",
            &format!("head -c {length} /dev/zero | tr '\\0' x; echo; echo after"),
        ))
        .expect("start");
    let pieces: Vec<(usize, bool)> = (0..4)
        .map(|_| {
            let line = next_line(&lines);
            assert!(line.text.chars().all(|c| c == 'x') || line.text == "after");
            (line.text.len(), line.continues)
        })
        .collect();
    assert_eq!(
        pieces,
        [
            (MAX_LINE_BYTES, true),
            (MAX_LINE_BYTES, true),
            (100, false),
            (5, false),
        ]
    );
}

#[test]
fn stop_sends_sigterm_first() {
    let (mut supervisor, lines) = supervisor_with_lines();
    supervisor
        .start(sh("polite", "echo ready; exec sleep 1000"))
        .expect("start");
    assert_eq!(next_line(&lines).text, "ready");
    assert_eq!(
        supervisor.stop("polite").expect("stop"),
        Some(signalled(SIGTERM))
    );
    assert_eq!(supervisor.pid("polite"), None);
    assert!(supervisor.try_event().expect("try_event").is_none());
}

#[test]
fn stop_escalates_to_sigkill_when_sigterm_is_caught_and_ignored() {
    let (mut supervisor, lines) = supervisor_with_lines();
    supervisor
        .start(
            sh(
                "stubborn",
                "trap 'echo caught TERM' TERM; echo ready; while :; do sleep 1000 & wait; done",
            )
            // Long enough for the shell to run its trap before SIGKILL, even on a busy machine.
            .stop_grace(Duration::from_secs(2)),
        )
        .expect("start");
    assert_eq!(next_line(&lines).text, "ready");
    assert_eq!(
        supervisor.stop("stubborn").expect("stop"),
        Some(signalled(SIGKILL))
    );
    assert_eq!(next_line(&lines).text, "caught TERM");
}

#[test]
fn stop_kills_the_whole_process_group_grandchildren_included() {
    let (mut supervisor, lines) = supervisor_with_lines();
    supervisor
        .start(
            // SIG_IGN is inherited: the background sleep ignores SIGTERM too.
            sh("family", "trap '' TERM; sleep 1000 & echo $!; wait")
                .stop_grace(Duration::from_millis(100)),
        )
        .expect("start");
    let grandchild: u32 = next_line(&lines).text.parse().expect("grandchild pid");
    assert_eq!(
        supervisor.stop("family").expect("stop"),
        Some(signalled(SIGKILL))
    );
    assert_gone(grandchild);
}

#[test]
fn stop_all_stops_in_reverse_start_order() {
    let dir = tempfile::tempdir().expect("temp dir");
    let record = dir.path().join("order");
    let (mut supervisor, lines) = supervisor_with_lines();
    for name in ["first", "second", "third"] {
        supervisor
            .start(
                sh(
                    name,
                    "trap 'echo $NAME >> \"$RECORD\"; exit 0' TERM; echo ready; sleep 1000 & wait",
                )
                .env("NAME", name)
                .env("RECORD", &record),
            )
            .expect("start");
    }
    for _ in 0..3 {
        assert_eq!(next_line(&lines).text, "ready");
    }
    let results: Vec<(String, Option<ExitStatus>)> = supervisor
        .stop_all()
        .into_iter()
        .map(|(name, result)| (name, result.expect("stop")))
        .collect();
    let clean = Some(exited(0));
    assert_eq!(
        results,
        [
            ("third".to_owned(), clean),
            ("second".to_owned(), clean),
            ("first".to_owned(), clean),
        ]
    );
    // Each stop finishes before the next begins, so the children saw SIGTERM in this order.
    assert_eq!(
        std::fs::read_to_string(&record).expect("record"),
        "third\nsecond\nfirst\n"
    );
    assert!(supervisor.running().is_empty());
}

#[test]
fn a_failing_child_is_restarted_with_backoff_up_to_the_limit_then_given_up() {
    let policy = RestartPolicy {
        max_restarts: 2,
        window_ms: 600_000,
        backoff_initial_ms: 1,
        backoff_max_ms: 1_000,
    };
    let mut supervisor = Supervisor::new().expect("supervisor");
    supervisor
        .start(sh("flaky", "exit 7").restart(Restart::OnFailure(policy)))
        .expect("start");
    let mut got = Vec::new();
    loop {
        let event = next_event(&mut supervisor);
        let done = matches!(event, SupervisorEvent::GaveUp { .. });
        got.push(match event {
            SupervisorEvent::Exited { status, .. } => status.to_string(),
            SupervisorEvent::RestartScheduled {
                attempt, delay_ms, ..
            } => format!("restart {attempt} in {delay_ms} ms"),
            SupervisorEvent::Restarted { attempt, .. } => format!("restarted {attempt}"),
            SupervisorEvent::GaveUp { failures, .. } => format!("gave up after {failures}"),
            SupervisorEvent::RestartFailed { error, .. } => format!("restart failed: {error}"),
        });
        if done {
            break;
        }
    }
    assert_eq!(
        got,
        [
            "exited with code 7",
            "restart 1 in 1 ms",
            "restarted 1",
            "exited with code 7",
            "restart 2 in 2 ms",
            "restarted 2",
            "exited with code 7",
            "gave up after 3",
        ]
    );
    assert_eq!(supervisor.pid("flaky"), None);
    assert!(supervisor.try_event().expect("try_event").is_none());
}

#[test]
fn a_clean_exit_is_not_restarted_on_failure_only() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    supervisor
        .start(ChildSpec::new("done", "true").restart(Restart::OnFailure(RestartPolicy::default())))
        .expect("start");
    assert!(matches!(
        next_event(&mut supervisor),
        SupervisorEvent::Exited { status, .. } if status == exited(0)
    ));
    assert!(supervisor.try_event().expect("try_event").is_none());
}

#[test]
fn stopping_a_child_that_waits_for_a_restart_cancels_the_restart() {
    let policy = RestartPolicy {
        max_restarts: 5,
        window_ms: 600_000,
        backoff_initial_ms: 600_000,
        backoff_max_ms: 600_000,
    };
    let mut supervisor = Supervisor::new().expect("supervisor");
    supervisor
        .start(ChildSpec::new("later", "false").restart(Restart::Always(policy)))
        .expect("start");
    assert!(matches!(
        next_event(&mut supervisor),
        SupervisorEvent::Exited { .. }
    ));
    assert!(matches!(
        next_event(&mut supervisor),
        SupervisorEvent::RestartScheduled { attempt: 1, .. }
    ));
    assert_eq!(supervisor.stop("later").expect("stop"), None);
    assert!(supervisor.try_event().expect("try_event").is_none());
}

#[test]
fn a_signal_sent_to_a_child_ends_in_an_exit_event() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    let pid = supervisor
        .start(ChildSpec::new("victim", "sleep").arg("1000"))
        .expect("start");
    supervisor
        .signal("victim", Signal::SIGKILL)
        .expect("signal");
    match next_event(&mut supervisor) {
        SupervisorEvent::Exited { pid: p, status, .. } => {
            assert_eq!((p, status), (pid, signalled(SIGKILL)));
        }
        other => panic!("expected an exit, got {other:?}"),
    }
}

#[test]
fn the_supervisor_fd_polls_readable_when_a_child_exits() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    supervisor
        .start(ChildSpec::new("quick", "true"))
        .expect("start");
    let fd = supervisor.as_fd().try_clone_to_owned().expect("dup");
    assert!(readable_within_watchdog(&fd));
    assert!(matches!(
        supervisor.try_event().expect("try_event"),
        Some(SupervisorEvent::Exited { .. })
    ));
}

#[test]
fn dropping_the_supervisor_kills_its_children() {
    let mut supervisor = Supervisor::new().expect("supervisor");
    let pid = supervisor
        .start(ChildSpec::new("left", "sleep").arg("1000"))
        .expect("start");
    drop(supervisor);
    assert_gone(pid);
}

#[test]
fn a_child_started_from_a_short_lived_thread_outlives_that_thread() {
    // PR_SET_PDEATHSIG fires when the forking *thread* exits: the supervisor must fork from a
    // thread of its own, or this child would be SIGKILLed when the scoped thread ends.
    // PIDFD_THREAD (Linux 6.9) has the value of O_EXCL.
    let pidfd_thread =
        PidfdFlags::from_bits_retain(u32::try_from(nix::libc::O_EXCL).expect("flag"));
    let mut supervisor = Supervisor::new().expect("supervisor");
    let thread_pidfd = std::thread::scope(|scope| {
        scope
            .spawn(|| {
                supervisor
                    .start(ChildSpec::new("orphan-of-thread", "sleep").arg("1000"))
                    .expect("start");
                let tid = Pid::from_raw(nix::unistd::gettid().as_raw()).expect("tid");
                pidfd_open(tid, pidfd_thread).expect("thread pidfd")
            })
            .join()
            .expect("thread")
    });
    // Readable once the thread has fully exited, death signals to its children included.
    assert!(readable_within_watchdog(&thread_pidfd));
    assert_eq!(
        supervisor.stop("orphan-of-thread").expect("stop"),
        Some(signalled(SIGTERM))
    );
}

#[test]
fn no_child_survives_its_supervisor_process_being_killed_with_sigkill() {
    let mut parent = Command::new(env!("CARGO_BIN_EXE_lewis-supervise-probe"))
        .args(["child", "sleep", "1000"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start the probe");
    let stdout = parent.stdout.take().expect("probe stdout");
    let mut first = String::new();
    BufReader::new(stdout)
        .read_line(&mut first)
        .expect("read the probe's first line");
    let child: u32 = first
        .trim()
        .strip_prefix("pid ")
        .and_then(|pid| pid.parse().ok())
        .unwrap_or_else(|| panic!("unexpected probe output {first:?}"));
    parent.kill().expect("SIGKILL the probe");
    parent.wait().expect("reap the probe");
    assert_gone(child);
}

#[test]
fn no_grandchild_survives_its_supervisor_process_being_killed_with_sigkill() {
    // The child starts a helper of its own and says its pid through a FIFO: the helper is
    // in the child's process group, but the death signal does not reach it.
    let dir = tempfile::tempdir().expect("a temporary directory");
    let fifo = dir.path().join("grandchild.pid");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).expect("mkfifo");
    let script = format!("sleep 1000 & echo $! > '{}'; wait", fifo.display());
    let mut parent = Command::new(env!("CARGO_BIN_EXE_lewis-supervise-probe"))
        .args(["child", "/bin/sh", "-c", &script])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start the probe");
    let stdout = parent.stdout.take().expect("probe stdout");
    let mut first = String::new();
    BufReader::new(stdout)
        .read_line(&mut first)
        .expect("read the probe's first line");
    let child: u32 = first
        .trim()
        .strip_prefix("pid ")
        .and_then(|pid| pid.parse().ok())
        .unwrap_or_else(|| panic!("unexpected probe output {first:?}"));
    // Opening a FIFO blocks until the writer comes: read it on a thread, under the watchdog.
    let (tx, rx) = sync_channel(1);
    std::thread::spawn(move || {
        let _ = tx.send(std::fs::read_to_string(&fifo));
    });
    let grandchild: u32 = rx
        .recv_timeout(WATCHDOG)
        .expect("the child said its helper's pid")
        .expect("the FIFO can be read")
        .trim()
        .parse()
        .expect("a pid");
    parent.kill().expect("SIGKILL the probe");
    parent.wait().expect("reap the probe");
    assert_gone(child);
    assert_gone(grandchild);
}
