//! A live ROS 2 robot, end to end, against an independent ROS 2 peer: Eclipse Cyclone DDS's
//! Python binding (`tools/python/ros2_turtlebot_peer.py`, no Lewis code) plays a TurtleBot
//! 4-shaped session (the real Hokuyo scans of `../shared/data/ros2/` live as `/scan`, with
//! `/odom`, `/tf`, `/tf_static`, `/ir_intensity`, `/hazard_detection` and `/battery_state`
//! made to fit), and `lewis up robots/turtlebot4.toml --goal X,Y --goal-frame odom` drives
//! it through the gateway's processes with Lewis's own Distance and ObstacleAvoider:
//!
//! - the peer receives `/cmd_vel` as `geometry_msgs/msg/Twist`, at the base's 20 Hz, within
//!   the robot file's limits;
//! - the laser's mount in the robot file is checked against the peer's `/tf_static`
//!   (transient local, sent before Lewis started), and the mismatch said;
//! - `/scan` stops: the laser gateway goes out of service and the broker moves the avoider
//!   to the IR ring (decided on `/lewis/broker`) while the base keeps being commanded;
//!   `/scan` resumes: the avoider moves back;
//! - `/scan` carries something else under its type name, from a writer that announces
//!   another type hash than LaserScan's (as Jazzy's writers announce theirs): its samples
//!   counted and left out, said once, the same failover and return, no crash;
//! - a writer of another type (std_msgs/String) on `/scan` all along: said once;
//! - `/scan` floods at ten times its rate: the excess dropped and said once, nobody moved;
//! - the base gateway killed outright: the broker restarts it and the restarted process
//!   holds the robot still (a zero twist) before any new command;
//! - `lewis up` stopped: the last twist the peer receives is zero; its recording replays
//!   with `lewis replay --check` (the gateways fed from it, the avoider run again), and
//!   with the lidar's death injected gives the same bytes twice, whatever the output is
//!   called.
//!
//! Isolation: everything DDS runs in a network namespace of its own with only a loopback
//! device (no packet leaves it, parallel tests never meet), in a DDS domain of its own too.
//! The namespace needs root or user namespaces; where it cannot be made the test is
//! skipped, except under CI (the `CI` variable set), where it fails.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use lewis_runtime::ipc::Namespace;
use lewis_tests::broker::Decisions;
use lewis_tests::{Up, WATCHDOG, lewis_exe};
use serde_json::Value;

/// Made in a fresh network namespace: loopback up with multicast on it (DDS discovers
/// peers by multicast), then a line to say so, then a wait for the end of stdin (the test's
/// pipe), so the namespace ends with the test however it ends.
const ANCHOR: &str = "ip link set lo up && ip link set lo multicast on \
    && ip route add 224.0.0.0/4 dev lo && echo ready && exec cat >/dev/null";

/// A network namespace with only a loopback device, held by an anchor process.
struct NetNs {
    anchor: Child,
}

impl NetNs {
    /// A fresh one, or why not.
    fn new() -> Result<Self, String> {
        let mut anchor = Command::new("unshare")
            .args(["--net", "--", "sh", "-c", ANCHOR])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("cannot run unshare: {e}"))?;
        let mut line = String::new();
        BufReader::new(anchor.stdout.take().expect("piped"))
            .read_line(&mut line)
            .map_err(|e| e.to_string())?;
        if line.trim() != "ready" {
            let _ = anchor.kill();
            let out = anchor.wait_with_output().map_err(|e| e.to_string())?;
            return Err(format!(
                "cannot make a network namespace: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Ok(Self { anchor })
    }

    /// `program` run in the namespace (its network only: shared memory, files and the rest
    /// are the test's, so the test's IPC meets it).
    fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut command = Command::new("nsenter");
        command
            .arg(format!("--target={}", self.anchor.id()))
            .args(["--net", "--"])
            .arg(program);
        command
    }
}

impl Drop for NetNs {
    fn drop(&mut self) {
        let _ = self.anchor.kill();
        let _ = self.anchor.wait();
    }
}

/// The peer: its commands in, its JSON events out.
struct Peer {
    child: Child,
    stdin: ChildStdin,
    events: Receiver<Value>,
    /// Every event received so far.
    seen: Vec<Value>,
}

impl Peer {
    fn start(netns: &NetNs, domain: u16) -> Self {
        let root = repository_root();
        let venv = std::env::var_os("LEWIS_VENV").map_or_else(|| root.join(".venv"), PathBuf::from);
        let python = venv.join("bin/python");
        assert!(
            python.exists(),
            "{} is missing: run scripts/setup-python.sh",
            python.display()
        );
        let mut child = netns
            .command(python)
            .arg(root.join("tools/python/ros2_turtlebot_peer.py"))
            .arg("--bag")
            .arg(root.join("../shared/data/ros2/hokuyo-scan-matcher-demo.mcap"))
            .args(["--domain", &domain.to_string(), "--max-seconds", "150"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("the peer starts");
        let stdin = child.stdin.take().expect("piped");
        let stdout = child.stdout.take().expect("piped");
        let (tx, events) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                let Ok(event) = serde_json::from_str::<Value>(&line) else {
                    continue;
                };
                if tx.send(event).is_err() {
                    break;
                }
            }
        });
        let mut peer = Self {
            child,
            stdin,
            events,
            seen: Vec::new(),
        };
        peer.wait_for("ready", |e| e["event"] == "ready");
        peer
    }

    fn send(&mut self, line: &str) {
        writeln!(self.stdin, "{line}").expect("the peer reads its commands");
    }

    /// Waits (watchdog) for an event `accept` accepts, after every event seen so far.
    fn wait_for(&mut self, what: &str, accept: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + WATCHDOG;
        loop {
            match self
                .events
                .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            {
                Ok(event) => {
                    self.seen.push(event.clone());
                    if accept(&event) {
                        return event;
                    }
                }
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                    // Every event, kept for whoever studies the failure.
                    let kept = std::env::temp_dir()
                        .join(format!("ros2-live-peer-{}.jsonl", std::process::id()));
                    let all: Vec<String> = self.seen.iter().map(Value::to_string).collect();
                    let kept = std::fs::write(&kept, all.join("\n")).map(|()| kept);
                    panic!(
                        "the peer never reported {what}; its last events:\n{}\nall of them: {kept:?}",
                        self.describe()
                    )
                }
            }
        }
    }

    /// The twists received for `span` from now.
    fn twists_for(&mut self, span: Duration) -> Vec<(f64, f64)> {
        let until = Instant::now() + span;
        let mut twists = Vec::new();
        while let Ok(event) = self
            .events
            .recv_timeout(until.saturating_duration_since(Instant::now()))
        {
            self.seen.push(event.clone());
            if let Some(t) = twist(&event) {
                twists.push(t);
            }
        }
        twists
    }

    /// Ends it and returns every event it still had.
    fn quit(&mut self) -> Vec<Value> {
        self.send("quit");
        let mut rest = Vec::new();
        while let Ok(event) = self.events.recv_timeout(WATCHDOG) {
            let done = event["event"] == "done";
            rest.push(event);
            if done {
                break;
            }
        }
        let _ = self.child.wait();
        self.seen.extend(rest.iter().cloned());
        rest
    }

    fn describe(&self) -> String {
        let start = self.seen.len().saturating_sub(30);
        self.seen[start..]
            .iter()
            .map(Value::to_string)
            .collect::<Vec<_>>()
            .join("\n")
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The `(linear.x, angular.z)` of a `cmd_vel` event, after checking its other axes are 0.
fn twist(event: &Value) -> Option<(f64, f64)> {
    if event["event"] != "cmd_vel" {
        return None;
    }
    let axis = |part: &str, i: usize| event[part][i].as_f64().expect("a number");
    for (part, i) in [("linear", 1), ("linear", 2), ("angular", 0), ("angular", 1)] {
        assert_eq!(
            axis(part, i),
            0.0,
            "a planar base gets no {part}[{i}]: {event}"
        );
    }
    Some((axis("linear", 0), axis("angular", 2)))
}

/// The monotonic clock, in s: the peer's `t` (Python's `time.monotonic`) on this machine.
fn monotonic_s() -> f64 {
    let now = nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC).expect("a clock");
    now.tv_sec() as f64 + now.tv_nsec() as f64 * 1e-9
}

fn repository_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ is in the repository")
        .to_owned()
}

#[test]
fn a_ros2_robot_is_driven_over_dds_and_its_lidar_fails_over_to_the_ir_ring() {
    let netns = match NetNs::new() {
        Ok(netns) => netns,
        Err(why) => {
            lewis_testkit::skip_unless_ci!("no network namespace for the ROS 2 test: {why}")
        }
    };
    // Built (when the tests are run without LEWIS_EXE) before the peer's clock starts.
    let lewis = lewis_exe();
    // A domain of its own as well (the namespace already keeps every other test away).
    let domain = u16::try_from(std::process::id() % 200).unwrap() + 20;
    let mut peer = Peer::start(&netns, domain);

    // The robot file as shipped, with a goal that stays ahead of the robot for the whole
    // session (the played scans do not move with it) and patience for a scene that never
    // changes.
    let robot = lewis_testkit::robot_files::shipped_robot("turtlebot4.toml").replace(
        "robot_radius_m = 0.18\n",
        "robot_radius_m = 0.18\nno_progress_timeout_ms = 120000\nfail_after_ms = 120000\n",
    );
    let mut command = netns.command(&lewis);
    command.env("ROS_DOMAIN_ID", domain.to_string());
    let dir = tempfile::tempdir().unwrap();
    let namespace = Namespace::unique("ros2-live");
    let decisions_namespace = namespace.clone();
    let args: Vec<std::ffi::OsString> = [
        "--goal",
        "100,0",
        "--goal-frame",
        "odom",
        "--goal-timeout",
        "120s",
    ]
    .iter()
    .map(Into::into)
    .collect();
    let args: Vec<&std::ffi::OsStr> = args.iter().map(std::ffi::OsString::as_os_str).collect();
    let mut up = Up::start_with_command(dir, namespace, &robot, &args, command);
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&decisions_namespace);

    // Lewis drives: twists of the robot file's type at the base's rate, within its limits.
    up.wait_status("the avoider on the laser", |report| {
        report.contains("client obstacle_avoider RangeFinder -> laser")
    });
    // The peer's /tf_static puts its laser elsewhere than the TurtleBot 4's robot file.
    let mismatch = up.wait_line("mount mismatch");
    assert!(
        mismatch.contains("laser") && mismatch.contains("heading 0.0 deg"),
        "{mismatch}"
    );
    peer.wait_for("a twist that moves", |e| {
        twist(e).is_some_and(|(v, w)| v != 0.0 || w != 0.0)
    });
    let twists = peer.twists_for(Duration::from_secs(2));
    assert!(
        (24..=60).contains(&twists.len()),
        "{} twists in 2 s, not the base's 20 Hz: {twists:?}",
        twists.len()
    );
    assert!(
        twists
            .iter()
            .all(|&(v, w)| v.abs() <= 0.3 + 1e-9 && w.abs() <= 1.9 + 1e-9),
        "a twist beyond the robot file's limits: {twists:?}"
    );

    // The lidar goes silent: the avoider moves to the IR ring, the base keeps being driven.
    peer.send("scan off");
    let moved = decisions.wait_for("the avoider moved to the IR ring", |d| {
        d.action == "rebind"
            && d.client == "obstacle_avoider"
            && d.interface == "RangeFinder"
            && d.from_service == "laser"
            && d.to_service == "ir"
    });
    assert!(
        moved.reason.contains("/scan"),
        "the reason names the silent topic: {}",
        moved.reason
    );
    let on_ir = peer.twists_for(Duration::from_secs(1));
    assert!(
        on_ir.len() >= 10,
        "the base is still commanded on the IR ring: {on_ir:?}"
    );

    // The lidar comes back: so does the avoider.
    peer.send("scan on");
    decisions.wait_for("the avoider back on the laser", |d| {
        d.action == "rebind"
            && d.client == "obstacle_avoider"
            && d.interface == "RangeFinder"
            && d.from_service == "ir"
            && d.to_service == "laser"
    });

    // A publisher of something else under /scan's type name, announcing its own type hash:
    // every sample is left out, counted and said once, the laser out of service again and
    // the avoider on the IR ring; never a crash, and back when real scans return.
    peer.send("scan garbage");
    let moved = decisions.wait_for("the avoider moved away from garbage", |d| {
        d.action == "rebind"
            && d.client == "obstacle_avoider"
            && d.from_service == "laser"
            && d.to_service == "ir"
    });
    assert!(
        moved.reason.contains("type hash differs"),
        "the reason counts the bad samples: {}",
        moved.reason
    );
    peer.send("scan on");
    decisions.wait_for("the avoider back on the laser after the garbage", |d| {
        d.action == "rebind"
            && d.client == "obstacle_avoider"
            && d.from_service == "ir"
            && d.to_service == "laser"
    });
    up.drain();
    let said = |what: &str| up.seen.iter().filter(|l| l.contains(what)).count();
    assert_eq!(
        said("/scan: type hash differs"),
        1,
        "samples of another type hash are said once:\n{}",
        up.log()
    );
    // The stranger's String writer on /scan, never delivered by DDS, is said once.
    assert_eq!(
        said("/scan: wrong type: a writer publishes it as std_msgs/msg/String"),
        1,
        "a writer of the wrong type is said once:\n{}",
        up.log()
    );

    // Ten times the rate: the excess is dropped and said once, the laser keeps serving.
    peer.send("scan flood");
    peer.wait_for("the flood", |e| {
        e["event"] == "scan" && e["mode"] == "flood"
    });
    peer.twists_for(Duration::from_millis(1500));
    peer.send("scan on");
    peer.wait_for("the flood's end", |e| {
        e["event"] == "scan" && e["mode"] == "on"
    });
    decisions.take();
    let since_flood = decisions.seen.len();
    up.drain();
    let flooding = up
        .seen
        .iter()
        .filter(|l| l.contains("/scan: flooding"))
        .count();
    assert_eq!(flooding, 1, "a flood is said once:\n{}", up.log());

    // The base's gateway killed outright: restarted, it holds the robot still before any
    // new command reaches it.
    let base = up.pid_of("base");
    let killed_at = monotonic_s();
    lewis_testkit::process::signal(base, nix::sys::signal::Signal::SIGKILL);
    decisions.wait_for("the base restarted", |d| {
        d.service == "base" && d.action == "restart-scheduled"
    });
    peer.wait_for("a zero twist from the restarted base", |e| {
        e["t"].as_f64().is_some_and(|t| t > killed_at) && twist(e) == Some((0.0, 0.0))
    });

    assert!(
        !decisions.seen[since_flood..]
            .iter()
            .any(|d| d.from_service == "laser" || d.service == "laser"),
        "the flood moved nobody off the laser:\n{}",
        decisions.describe()
    );

    // `lewis up` ends: the last twist is zero.
    peer.wait_for("the robot driven again", |e| {
        twist(e).is_some_and(|(v, w)| v != 0.0 || w != 0.0)
    });
    up.stop();
    let rest = peer.quit();
    let last = peer
        .seen
        .iter()
        .rev()
        .find_map(twist)
        .expect("twists were received");
    assert_eq!(
        last,
        (0.0, 0.0),
        "the last twist after lewis up ended is not zero; the peer's last events:\n{}",
        peer.describe()
    );
    assert!(
        rest.iter().any(|e| e["event"] == "done"),
        "the peer ended: {rest:?}"
    );
    let log = up.log();
    assert!(
        log.contains("stopped: a zero twist sent on /cmd_vel"),
        "the base says it stopped the robot:\n{log}"
    );

    // The session's recording replays as any Lewis recording: the gateways (devices) fed
    // from it, Lewis's own services run again to the same outputs.
    let recording = std::fs::read_dir(up.path("logs"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        .expect("lewis up recorded the session");
    let replay = lewis_testkit::run_ok(
        Command::new(&lewis)
            .arg("replay")
            .arg(&recording)
            .arg("--check")
            .current_dir(up.path("")),
    );
    if !replay.contains("check: outputs match the recording") {
        // A differing replay is studied from its recording: kept where the run's temporary
        // folder would have removed it.
        let kept = std::env::temp_dir().join(format!("ros2-live-{}.mcap", std::process::id()));
        let copied = std::fs::copy(&recording, &kept).map(|_| kept.display().to_string());
        panic!("{replay}\nthe recording, kept: {copied:?}");
    }

    // The lidar's death injected into the live session's recording, twice into files of
    // other names: the same bytes (the avoider re-run on the IR ring, open loop).
    let faulted = |name: &str| {
        let out = up.path(name);
        let _ = lewis_testkit::run_ok(
            Command::new(&lewis)
                .arg("replay")
                .arg(&recording)
                .args(["--inject-fault", "laser@10s", "-o"])
                .arg(&out)
                .current_dir(up.path("")),
        );
        std::fs::read(&out).unwrap()
    };
    assert!(
        faulted("faulted.mcap") == faulted("again-with-another-name.mcap"),
        "two replays of the live session with the laser dead at 10 s differ"
    );
}
