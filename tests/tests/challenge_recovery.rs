//! The Robot Challenge's recovery end to end, real processes and a real browser: SignFollower
//! crashes (SIGSEGV from this test) beyond the script's `restart 3`, the sequencer enters the
//! recovery state, whose Recovery program follows the guide in the red cap until the cap is
//! out of sight, and then asks the supervisor on the page; headless Chromium
//! (`tools/node/recover.mjs`) checks that the page shows the robot (the map, the
//! camera, the bindings) and taps `sign`; the mission then completes through queue and
//! register, and `lewis up --script` exits 0 (a mission that resumed after recovery and
//! ended with `register` exiting 0 succeeded).
//!
//! To be short, the mission is `robots/missions/challenge.seq` started at `sign` (the paper's
//! script otherwise unchanged: `door` stays, for the supervisor to choose) and the robot starts
//! past the corridor's turn, heading north for the hall sign, where the red cap is in sight.
//! The sign program is crashed at once, so the robot is still there when Recovery starts.
//!
//! Its own test binary: a closed loop in real time (as `challenge`) that should not share the
//! machine with other end-to-end tests. Needs Debian's `chromium` (or `LEWIS_CHROMIUM`),
//! `node`, and `npm ci --prefix tools/node`; fails with a message saying which is
//! missing. Screenshots go to `$TMPDIR/lewis-challenge-recovery/`.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

use std::io::{BufRead, BufReader, Read};
use std::os::fd::OwnedFd;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use lewis_runtime::ipc::Namespace;
use lewis_sequencer::fsm::{Decision, Event};
use lewis_sequencer::record::{Entry, Record};
use lewis_sequencer::verdict::Verdict;
use lewis_tests::browser::{browser_tools, gui_test_dir};
use lewis_tests::{lewis_exe, repo_root};

/// Where `robots/sim.toml` starts the robot (in the lobby, facing the entrance door).
const LOBBY_START: &str = "start = { x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }";
/// Past the corner sign, heading north for the hall: the red cap (25.6, 19.6) is in sight
/// through the opening to the hall.
const TURN_START: &str = "start = { x_m = 28.7, y_m = 15.5, heading_deg = 90.0 }";
/// A watchdog on the whole run (it takes about 50 s on an idle machine, 2 cores).
const LIMIT: Duration = Duration::from_secs(240);
/// How many times the sign program runs before recovery: 1 + `restart 3`.
const SIGN_RUNS: usize = 4;

#[test]
fn a_crashing_sign_follower_recovers_with_the_red_cap_and_resumes_from_the_page() {
    let chromium = browser_tools();
    let began = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let robot = dir.path().join("robot.toml");
    std::fs::write(&robot, robot_text()).unwrap();
    let script = dir.path().join("challenge.seq");
    std::fs::write(&script, script_text()).unwrap();
    let events = dir.path().join("events.jsonl");
    let shots = std::env::temp_dir().join("lewis-challenge-recovery");
    std::fs::create_dir_all(&shots).unwrap();
    let namespace = Namespace::unique("challenge-recovery");

    let mut up = Command::new(lewis_exe())
        .current_dir(dir.path())
        .arg("up")
        .arg(&robot)
        .arg("--script")
        .arg(&script)
        .args(["--gui-port", "0", "--no-record", "--stop-grace-ms", "500"])
        .args(["--namespace", namespace.as_str()])
        .arg("--events")
        .arg(&events)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lewis up starts");
    let stdout = lines_of(up.stdout.take().unwrap());
    let stderr = lines_of(up.stderr.take().unwrap());
    let mut run = Run {
        up,
        browser: None,
        stdout,
        stderr,
        printed: Vec::new(),
        began,
    };

    // The page's address, then the supervisor at it from the start.
    let url = run.page_url();
    let browser = Command::new("node")
        .arg(gui_test_dir().join("recover.mjs"))
        .arg(&url)
        .arg(&shots)
        .env("LEWIS_CHROMIUM", &chromium)
        .current_dir(gui_test_dir())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("node starts");
    run.browser = Some(browser);

    // Every run of `sign` crashes until the recovery state is entered.
    let crashed = run.crash_sign_until_recovery(&events);
    assert_eq!(crashed.len(), SIGN_RUNS, "crashed pids {crashed:?}");

    // Recovery, the question, the tap, the rest of the mission: `lewis up` ends by itself.
    let status = run.wait_up();
    let (browser_ok, browser_output) = run.wait_browser();
    run.drain();
    let printed = run.printed.join("\n");
    let wall = began.elapsed();
    eprintln!("{browser_output}the run took {wall:.1?} of wall time");
    assert!(
        browser_ok,
        "the browser test failed:\n{browser_output}\n--- lewis up:\n{printed}"
    );
    assert!(
        browser_output.contains("gui-test: ok"),
        "{browser_output}\n--- lewis up:\n{printed}"
    );
    assert!(
        status.success(),
        "lewis up exited with {status}:\n{printed}"
    );

    // The mission, judged from its records.
    let records = read_records(&events, true);
    let verdict = Verdict::of(&records);
    assert!(verdict.succeeded, "{verdict}\n{printed}");
    let states: Vec<&str> = verdict
        .states_visited
        .iter()
        .map(|v| v.state.as_str())
        .collect();
    assert_eq!(
        states,
        ["sign", "oops", "sign", "queue", "register"],
        "{verdict}"
    );
    assert_eq!(verdict.states_visited[0].attempts, 4, "{verdict}");
    assert_eq!((verdict.restarts, verdict.recoveries), (3, 1), "{verdict}");
    let signalled = records
        .iter()
        .filter(|r| {
            matches!(
                r.entry,
                Entry::Observed {
                    event: Event::Signalled { signal: 11 }
                }
            )
        })
        .count();
    assert_eq!(signalled, SIGN_RUNS, "every crash is a SIGSEGV");
    // Recovery finished its task (exit 0), and the supervisor, not the script, chose `sign`.
    let after_oops = records
        .iter()
        .skip_while(|r| !matches!(&r.entry, Entry::ProgramStarted { state, .. } if state == "oops"))
        .find_map(|r| match &r.entry {
            Entry::Observed { event } => Some(event.clone()),
            _ => None,
        });
    assert_eq!(
        after_oops,
        Some(Event::Exited { code: 0 }),
        "Recovery exits 0"
    );
    let resumed: Vec<&str> = records
        .iter()
        .filter_map(|r| match &r.entry {
            Entry::Decided {
                decision: Decision::Resume { state, .. },
            } => Some(state.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(resumed, ["sign"]);
    // Recovery saw the red cap and followed it (the page saw the robot in the hall after).
    assert!(
        printed
            .lines()
            .any(|l| l.starts_with("oops: ") && l.contains("following")),
        "Recovery did not say it follows the cap:\n{printed}"
    );
    for shot in ["recovering.png", "asking.png", "finished.png"] {
        assert!(shots.join(shot).is_file(), "no screenshot {shot}");
    }
}

/// `robots/sim.toml` with the robot past the corridor's turn and every `robots/...` path
/// absolute (`lewis up` runs in a temporary directory).
fn robot_text() -> String {
    let text = lewis_tests::robot::shipped_robot("sim.toml");
    assert!(
        text.contains(LOBBY_START),
        "robots/sim.toml starts the robot with `{LOBBY_START}`"
    );
    text.replace(LOBBY_START, TURN_START)
}

/// `robots/missions/challenge.seq` started at `sign`, its programs by absolute path.
fn script_text() -> String {
    let text = std::fs::read_to_string(repo_root().join("robots/missions/challenge.seq")).unwrap();
    assert!(text.starts_with("start door\n"), "{text}");
    text.replacen("start door\n", "start sign\n", 1).replace(
        " ./bin/",
        &format!(" {}/robots/missions/bin/", repo_root().display()),
    )
}

/// The lines of a child's pipe, as they come.
fn lines_of(pipe: impl Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// The records of the events file written so far; a last line still being written is left
/// for later unless `complete`.
fn read_records(path: &Path, complete: bool) -> Vec<Record> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let whole = if complete {
        text.as_str()
    } else {
        text.rfind('\n').map_or("", |end| &text[..=end])
    };
    whole
        .lines()
        .map(|line| serde_json::from_str(line).expect("an events line is a record"))
        .collect()
}

/// The running `lewis up` and browser, with what they said.
struct Run {
    up: Child,
    browser: Option<Child>,
    stdout: Receiver<String>,
    stderr: Receiver<String>,
    /// Every line of `lewis up` so far, for diagnostics.
    printed: Vec<String>,
    began: Instant,
}

impl Run {
    fn drain(&mut self) {
        self.printed.extend(self.stdout.try_iter());
        self.printed.extend(self.stderr.try_iter());
    }

    /// Fails the test (after stopping everything) if the watchdog ran out.
    fn check_time(&mut self, what: &str) {
        if self.began.elapsed() > LIMIT {
            self.abandon(&format!("{what} after {LIMIT:?}"));
        }
    }

    /// Kills `lewis up` (its services go with it) and the browser, then fails.
    fn abandon(&mut self, why: &str) -> ! {
        let _ = self.up.kill();
        let _ = self.up.wait();
        if let Some(browser) = &mut self.browser {
            let _ = browser.kill();
        }
        let browser = self.browser.take().map(collect).unwrap_or_default();
        self.drain();
        panic!(
            "{why}\n--- browser:\n{browser}\n--- lewis up:\n{}",
            self.printed.join("\n")
        );
    }

    /// Waits for `supervisor's page: URL` on the standard output.
    fn page_url(&mut self) -> String {
        loop {
            match self.stdout.recv_timeout(Duration::from_millis(200)) {
                Ok(line) => {
                    let url = line.strip_prefix("supervisor's page: ").map(str::to_owned);
                    self.printed.push(line);
                    if let Some(url) = url {
                        return url;
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    self.abandon("lewis up ended before it served the page")
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    self.printed.extend(self.stderr.try_iter());
                    self.check_time("no supervisor's page");
                }
            }
        }
    }

    /// Crashes every run of `sign` (its process id from the events file's `program_started`
    /// records) until the sequencer enters recovery; returns the crashed process ids.
    ///
    /// The signal goes through a pidfd, so never to another process. A Rust program survives
    /// its first SIGSEGV from `kill` (std's stack-overflow handler finds no guard-page fault,
    /// restores the default action and returns), so it is sent again, every 100 ms, until
    /// the sequencer records the program's end.
    fn crash_sign_until_recovery(&mut self, events: &Path) -> Vec<u32> {
        let mut crashed = Vec::new();
        let mut target: Option<(u64, OwnedFd)> = None;
        loop {
            self.check_time("no recovery");
            self.drain();
            if let Some(status) = self.up.try_wait().unwrap() {
                self.abandon(&format!("lewis up exited with {status} before recovery"));
            }
            let records = read_records(events, false);
            if records.iter().any(|r| {
                matches!(
                    r.entry,
                    Entry::Decided {
                        decision: Decision::EnterRecovery { .. }
                    }
                )
            }) {
                return crashed;
            }
            // The latest run of `sign` that has not ended yet.
            let running = records.iter().rev().find_map(|r| match &r.entry {
                Entry::ProgramStarted { state, pid, .. } if state == "sign" => Some((r.seq, *pid)),
                _ => None,
            });
            if let Some((seq, pid)) = running {
                let ended = records
                    .iter()
                    .any(|r| r.seq > seq && matches!(r.entry, Entry::Observed { .. }));
                if ended {
                    target = None;
                } else {
                    if target.as_ref().is_none_or(|(s, _)| *s != seq) {
                        target = pidfd(pid).map(|fd| (seq, fd));
                        crashed.push(pid);
                    }
                    if let Some((_, fd)) = &target {
                        // Gone already: the sequencer records its end soon.
                        let _ =
                            rustix::process::pidfd_send_signal(fd, rustix::process::Signal::SEGV);
                    }
                }
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Waits for `lewis up` to end by itself; fails (and stops everything) if the browser
    /// fails first, since then nobody answers the question, or if the watchdog runs out.
    fn wait_up(&mut self) -> std::process::ExitStatus {
        loop {
            if let Some(status) = self.up.try_wait().unwrap() {
                return status;
            }
            if let Some(browser) = &mut self.browser
                && let Some(status) = browser.try_wait().unwrap()
                && !status.success()
            {
                self.abandon(&format!("the browser test failed ({status})"));
            }
            self.drain();
            self.check_time("the mission did not end");
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// Waits for the browser to end: whether it succeeded, and what it said.
    fn wait_browser(&mut self) -> (bool, String) {
        let mut browser = self.browser.take().expect("the browser was started");
        let deadline = Instant::now() + Duration::from_secs(60);
        while browser.try_wait().unwrap().is_none() {
            if Instant::now() > deadline {
                let _ = browser.kill();
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let ok = browser.wait().unwrap().success();
        (ok, collect(browser))
    }
}

/// A pidfd of a process, `None` when it is gone already.
fn pidfd(pid: u32) -> Option<OwnedFd> {
    let pid = rustix::process::Pid::from_raw(i32::try_from(pid).ok()?)?;
    rustix::process::pidfd_open(pid, rustix::process::PidfdFlags::empty()).ok()
}

/// A child's output after it ended (or was killed).
fn collect(mut child: Child) -> String {
    let _ = child.wait();
    let mut out = String::new();
    if let Some(mut pipe) = child.stdout.take() {
        let _ = pipe.read_to_string(&mut out);
    }
    if let Some(mut pipe) = child.stderr.take() {
        let _ = pipe.read_to_string(&mut out);
    }
    out
}
