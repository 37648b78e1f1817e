//! The simulated B21r end to end, real processes: `lewis up robots/sim.toml --goal X,Y`
//! drives the robot from the lobby through the entrance door into the corridor, with the
//! obstacle_avoider commanding the vector_mover, which drives sim-base; the laser and the
//! sonar ring render the world from sim-base's GroundTruth. The simulator counts
//! collisions; `lewis up` exits 0 only when the Mover says arrived and none was counted.
//!
//! The paper's demonstration: during the same drive the laser is killed (`lewis fault laser
//! --kill`) until it is beyond its restart limit; the broker moves the obstacle_avoider's
//! RangeFinder to the sonar, and the robot still arrives, without a collision.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, BrokerStatus, Mover};
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::names;
use lewis_tests::{lewis_exe, repo_root, wait_child_within};

/// Goals in the world frame: from the lobby (3, 12.5) through the entrance door (x 8) into
/// the corridor, about 9 m, and a shorter one for the drive that ends on sonar (slower: the
/// ring sees less, so the avoider picks nearer waypoints).
const GOAL: &str = "12,13";
const SONAR_GOAL: &str = "10,13";

/// One simulated robot at a time: two at once on a small machine starve each other (and
/// the brokers' heartbeat deadlines) of CPU.
static ONE_ROBOT: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The time `lewis up` gives the robot, and the watchdog of the whole drive.
const GOAL_TIMEOUT_SECS: u64 = 50;

/// `robots/sim.toml` with the world's folder made absolute, written into `dir`.
fn sim_robot(dir: &std::path::Path) -> PathBuf {
    let root = repo_root();
    let text = std::fs::read_to_string(root.join("robots/sim.toml"))
        .expect("robots/sim.toml is in the repository");
    let world = root.join("robots/worlds/conference");
    let relative = "world = \"robots/worlds/conference\"";
    assert!(
        text.contains(relative),
        "robots/sim.toml names its world as {relative}"
    );
    let text = text.replace(
        relative,
        &format!("world = {:?}", world.display().to_string()),
    );
    let path = dir.join("sim.toml");
    std::fs::write(&path, text).expect("the robot file can be written");
    path
}

/// A running `lewis up ... --goal`, its stderr collected line by line.
struct GoalDrive {
    child: Child,
    namespace: Namespace,
    _dir: tempfile::TempDir,
    lines: Receiver<String>,
    seen: Vec<String>,
}

impl GoalDrive {
    fn start(tag: &str, goal: &str) -> Self {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let robot = sim_robot(dir.path());
        let namespace = Namespace::unique(tag);
        let mut child = Command::new(lewis_exe())
            .arg("up")
            .arg(&robot)
            .args(["--namespace", namespace.as_str(), "--stop-grace-ms", "500"])
            .args(["--no-record", "--goal", goal])
            .args(["--goal-timeout", &GOAL_TIMEOUT_SECS.to_string()])
            .current_dir(dir.path())
            .env("RUST_LOG", "info")
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
            _dir: dir,
            lines,
            seen: Vec::new(),
        }
    }

    /// Waits (watchdog) for a line containing `needle`.
    fn wait_line(&mut self, needle: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.lines.recv_timeout(left) {
                Ok(line) => {
                    self.seen.push(line.clone());
                    if line.contains(needle) {
                        return line;
                    }
                }
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                    panic!("lewis up never wrote `{needle}`; it wrote:\n{}", self.log())
                }
            }
        }
    }

    /// Waits for `lewis up` to end by itself (it gives the robot GOAL_TIMEOUT_SECS, then
    /// stops); returns its exit status.
    fn wait_end(&mut self) -> ExitStatus {
        let status =
            wait_child_within(&mut self.child, Duration::from_secs(GOAL_TIMEOUT_SECS + 30));
        while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(10)) {
            self.seen.push(line);
        }
        status
    }

    /// Runs `lewis fault SERVICE --kill` against this robot; whether it killed something.
    fn kill(&self, service: &str) -> bool {
        let output = Command::new(lewis_exe())
            .args([
                "fault",
                service,
                "--kill",
                "--namespace",
                self.namespace.as_str(),
            ])
            .args(["--timeout", "10"])
            .output()
            .expect("lewis fault runs");
        let said = String::from_utf8_lossy(&output.stdout);
        match output.status.code() {
            Some(0) => {
                assert!(said.contains(&format!("{service}: killed (pid")), "{said}");
                true
            }
            // The process was gone already (between the report and the kill).
            Some(1) => false,
            _ => panic!(
                "lewis fault failed ({}): {said}{}",
                output.status,
                String::from_utf8_lossy(&output.stderr)
            ),
        }
    }

    fn log(&self) -> String {
        self.seen.join("\n")
    }
}

impl Drop for GoalDrive {
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

/// The broker's status report.
fn status(ipc: &Ipc) -> String {
    let mut broker = ipc
        .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        .expect("the broker's command channel opens");
    lewis_runtime::client::call_blocking(
        &mut broker,
        &BrokerStatus::default(),
        Duration::from_secs(10),
    )
    .expect("the broker answers")
    .report
}
/// The pid of `service`'s process in a broker status report.
fn pid_in(report: &str, service: &str) -> Option<u32> {
    report.lines().find_map(|line| {
        let (name, pid) = line.strip_prefix("process ")?.split_once(": pid ")?;
        (name == service).then(|| pid.trim().parse().ok())?
    })
}

/// Every decision published on `/lewis/broker` since the last call.
fn drain(decisions: &mut Subscriber, into: &mut Vec<Broker>) {
    while let Some(sample) = decisions.receive().expect("decisions can be received") {
        into.push(cdr::from_bytes(sample.bytes()).expect("a broker decision decodes"));
    }
}

/// The channels the obstacle_avoider's Mover publications say they were computed from.
fn drain_inputs(status: &mut Subscriber, into: &mut Vec<String>) {
    while let Some(sample) = status.receive().expect("Mover samples can be received") {
        let message: Mover = cdr::from_bytes(sample.bytes()).expect("a Mover sample decodes");
        for input in message.header.inputs {
            if !into.contains(&input.channel) {
                into.push(input.channel);
            }
        }
    }
}

fn assert_arrived_without_collision(drive: &GoalDrive, status: ExitStatus) {
    let log = drive.log();
    assert!(status.success(), "lewis up exited with {status}:\n{log}");
    assert!(log.contains("goal reached"), "{log}");
    assert!(log.contains(", 0 collisions"), "{log}");
}

#[test]
fn the_simulated_robot_reaches_a_goal_through_the_door_without_a_collision() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut drive = GoalDrive::start("sim-drive", GOAL);
    drive.wait_line("goal 1 sent to obstacle_avoider");
    let status = drive.wait_end();
    assert_arrived_without_collision(&drive, status);
}

#[test]
fn laser_killed_beyond_its_restart_limit_the_robot_arrives_on_sonar() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut drive = GoalDrive::start("sim-failover", SONAR_GOAL);
    let ipc = Ipc::open(&drive.namespace, "test-watch").expect("the test's IPC node opens");
    let mut decisions = ipc
        .subscriber(names::BROKER_CHANNEL, &names::broker_config())
        .expect("the broker's decisions can be read");
    drive.wait_line("goal 1 sent to obstacle_avoider");
    let mut mover = ipc
        .subscriber(
            &names::data_channel("obstacle_avoider", "Mover"),
            &names::data_config(),
        )
        .expect("the obstacle_avoider's Mover status can be read");

    // Kill every laser process the broker starts, until it gives the laser up.
    let mut seen = Vec::new();
    let mut killed = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    let rebound = |seen: &[Broker]| {
        seen.iter().any(|d| {
            d.action == "rebind"
                && d.client == "obstacle_avoider"
                && d.interface == "RangeFinder"
                && d.from_service == "laser"
                && d.to_service == "sonar"
        })
    };
    loop {
        drain(&mut decisions, &mut seen);
        if rebound(&seen) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the broker never moved the obstacle_avoider to the sonar; killed {killed:?}; decisions: {seen:#?}"
        );
        if let Some(pid) = pid_in(&status(&ipc), "laser")
            && !killed.contains(&pid)
            && drive.kill("laser")
        {
            killed.push(pid);
            continue;
        }
        // No new laser process yet: the broker announces each start (and the failure) on
        // /lewis/broker.
        WaitSet::new(WakeMode::Event)
            .wait(&[&decisions], Some(deadline))
            .expect("the test can wait");
    }
    assert!(
        seen.iter()
            .any(|d| d.action == "service-failed" && d.service == "laser"),
        "the laser was given up: {seen:#?}"
    );

    // The obstacle_avoider goes on, now computing from the sonar's readings.
    let mut inputs = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    while !inputs.iter().any(|c| c == "/sonar/RangeFinder") {
        assert!(
            Instant::now() < deadline,
            "the obstacle_avoider never used the sonar; its inputs: {inputs:?}"
        );
        drain_inputs(&mut mover, &mut inputs);
        WaitSet::new(WakeMode::Event)
            .wait(&[&mover], Some(deadline))
            .expect("the test can wait");
    }

    let status = drive.wait_end();
    assert_arrived_without_collision(&drive, status);
    let log = drive.log();
    assert!(
        log.contains("rebind obstacle_avoider from laser to sonar"),
        "{log}"
    );
}
