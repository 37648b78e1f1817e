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

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Blob3D, Blobs3D, Broker, GroundTruth, Mover};
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::names;
use lewis_tests::robot::with_absolute_paths;
use lewis_tests::{RangeApp, Up, lewis_exe, open_ipc, wait_child_within};

/// The goal in the world frame: from the lobby (3, 12.5) through the entrance door (x 8)
/// into the corridor, about 9 m.
const GOAL: &str = "12,13";

/// Where the laser dies in the failover drive: past the entrance door (x 8), so the sonar
/// takes over while the robot drives along the corridor, as in the paper's demonstration.
/// Through the 1.5 m door itself the ring's wide cones made the avoider dither (it arrived
/// in most runs, not all).
const LASER_DIES_PAST_X_M: f64 = 8.6;

/// One simulated robot at a time: two at once on a small machine starve each other (and
/// the brokers' heartbeat deadlines) of CPU.
static ONE_ROBOT: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The time `lewis up` gives the robot, and the watchdog of the whole drive.
const GOAL_TIMEOUT_SECS: u64 = 50;

/// `robots/sim.toml` with its paths (the world, the colour file) made absolute, written
/// into `dir`.
fn sim_robot(dir: &std::path::Path) -> PathBuf {
    write_robot(dir, &lewis_tests::robot::shipped_robot("sim.toml"))
}

/// A robot file's text with every `= "robots/..."` path made absolute (the tests run
/// `lewis up` in a temporary directory), written into `dir`.
fn write_robot(dir: &std::path::Path, text: &str) -> PathBuf {
    let path = dir.join("sim.toml");
    std::fs::write(&path, with_absolute_paths(text)).expect("the robot file can be written");
    path
}

/// A running `lewis up ... --goal`, its stderr collected line by line.
struct GoalDrive {
    child: Child,
    namespace: Namespace,
    /// What `lewis up` gives the robot, and the watchdog of each wait.
    timeout: Duration,
    _dir: tempfile::TempDir,
    lines: Receiver<String>,
    seen: Vec<String>,
}

impl GoalDrive {
    /// `lewis up robots/sim.toml --goal GOAL`.
    fn start(tag: &str, goal: &str) -> Self {
        let dir = tempfile::tempdir().expect("a temporary directory");
        let robot = sim_robot(dir.path());
        Self::start_with(tag, dir, &robot, goal, GOAL_TIMEOUT_SECS)
    }

    /// `lewis up ROBOT --goal GOAL --goal-timeout TIMEOUT_SECS`, without recording.
    fn start_with(
        tag: &str,
        dir: tempfile::TempDir,
        robot: &std::path::Path,
        goal: &str,
        timeout_secs: u64,
    ) -> Self {
        let namespace = Namespace::unique(tag);
        let mut child = Command::new(lewis_exe())
            .arg("up")
            .arg(robot)
            .args(["--namespace", namespace.as_str(), "--stop-grace-ms", "500"])
            .args(["--no-record", "--goal", goal])
            .args(["--goal-timeout", &format!("{timeout_secs}s")])
            .current_dir(dir.path())
            .arg("-v")
            .env_remove("RUST_LOG")
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
            timeout: Duration::from_secs(timeout_secs),
            _dir: dir,
            lines,
            seen: Vec::new(),
        }
    }

    /// Waits (watchdog) for a line containing `needle`.
    fn wait_line(&mut self, needle: &str) -> String {
        let deadline = Instant::now() + self.timeout;
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

    /// Waits for `lewis up` to end by itself (it gives the robot its timeout, then stops);
    /// returns its exit status.
    fn wait_end(&mut self) -> ExitStatus {
        let status = wait_child_within(&mut self.child, self.timeout + Duration::from_secs(30));
        self.read_rest();
        status
    }

    /// Reads what `lewis up` wrote until it closed its stderr.
    fn read_rest(&mut self) {
        while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(10)) {
            self.seen.push(line);
        }
    }

    /// Runs `lewis fault SERVICE --kill` against this robot; whether it killed something.
    fn kill(&self, service: &str) -> bool {
        let output = fault(&self.namespace, service, "--kill");
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

/// Runs `lewis fault SERVICE FAULT` against the robot of `namespace`.
fn fault(namespace: &Namespace, service: &str, fault: &str) -> std::process::Output {
    Command::new(lewis_exe())
        .args(["fault", service, fault, "--namespace", namespace.as_str()])
        .args(["--timeout", "10"])
        .output()
        .expect("lewis fault runs")
}

/// The pid of `service`'s process, as the broker's status reply gives it.
fn pid_of(ipc: &Ipc, service: &str) -> Option<u32> {
    let reply = lewis_tests::broker::status_reply(ipc);
    lewis_runtime::broker::status::pid_of(&reply, service).and_then(|pid| u32::try_from(pid).ok())
}

/// Every decision published on `/lewis/broker` since the last call.
fn drain(decisions: &mut Subscriber, into: &mut Vec<Broker>) {
    while let Some(sample) = decisions.receive().expect("decisions can be received") {
        into.push(cdr::from_bytes(sample.bytes()).expect("a broker decision decodes"));
    }
}

/// Whether the broker moved `client`'s `interface` from `from` to `to` among `seen`.
fn moved(seen: &[Broker], client: &str, interface: &str, from: &str, to: &str) -> bool {
    seen.iter().any(|d| {
        d.action == "rebind"
            && d.client == client
            && d.interface == interface
            && d.from_service == from
            && d.to_service == to
    })
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

/// The far goal: the corridor's east end, about 26 m from the lobby (a minute's drive).
const FAR_GOAL: &str = "29.5,12.5";

/// The actions of a decision against a provider: none may come when nothing is wrong.
const AGAINST_A_PROVIDER: [&str; 5] = [
    "restart-scheduled",
    "service-failed",
    "service-degraded",
    "rebind",
    "ask-for-help",
];

#[test]
fn with_every_data_check_on_a_minute_s_drive_moves_no_healthy_provider() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let robot = sim_robot(dir.path());
    assert!(
        std::fs::read_to_string(&robot)
            .expect("the robot file reads")
            .contains("\ndata_checks = true\n"),
        "robots/sim.toml no longer turns the broker's data checks on"
    );
    let mut drive = GoalDrive::start_with("sim-checks", dir, &robot, FAR_GOAL, 150);
    let ipc = Ipc::open(&drive.namespace, "test-watch").expect("the test's IPC node opens");
    let mut decisions = ipc
        .subscriber(names::BROKER_CHANNEL, &names::broker_config())
        .expect("the broker's decisions can be read");
    drive.wait_line("goal 1 sent to obstacle_avoider");
    let started = Instant::now();
    // Read as they come: what the broker sent and nobody read goes with it when it ends.
    let mut seen = Vec::new();
    let deadline = started + drive.timeout + Duration::from_secs(30);
    let status = loop {
        drain(&mut decisions, &mut seen);
        if let Some(status) = drive.child.try_wait().expect("lewis up can be waited for") {
            break status;
        }
        assert!(
            Instant::now() < deadline,
            "lewis up did not end:\n{}",
            drive.log()
        );
        // Woken by the next decision, or after a while to see whether lewis up ended.
        WaitSet::new(WakeMode::Event)
            .wait(
                &[&decisions],
                Some(Instant::now() + Duration::from_millis(500)),
            )
            .expect("the test can wait");
    };
    let drove = started.elapsed();
    drive.read_rest();
    assert_arrived_without_collision(&drive, status);
    let against: Vec<String> = seen
        .iter()
        .filter(|d| AGAINST_A_PROVIDER.contains(&d.action.as_str()))
        .map(|d| format!("{} {}: {}", d.action, d.service, d.reason))
        .collect();
    assert!(
        against.is_empty(),
        "healthy providers were acted against in {drove:?}:\n{}\n{}",
        against.join("\n"),
        drive.log()
    );
    assert!(
        seen.iter()
            .any(|d| d.action == "start" && d.service == "camera"),
        "the camera never ran, so its checks were not tried: {seen:?}"
    );
    eprintln!(
        "{drove:?} of driving, {} decisions, none against a provider",
        seen.len()
    );
}

#[test]
fn laser_killed_beyond_its_restart_limit_the_robot_arrives_on_sonar() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut drive = GoalDrive::start("sim-failover", GOAL);
    let ipc = Ipc::open(&drive.namespace, "test-watch").expect("the test's IPC node opens");
    let mut decisions = ipc
        .subscriber(names::BROKER_CHANNEL, &names::broker_config())
        .expect("the broker's decisions can be read");
    drive.wait_line("goal 1 sent to obstacle_avoider");
    let mut truth = ipc
        .subscriber(
            &names::data_channel("base", "GroundTruth"),
            &names::data_config("GroundTruth"),
        )
        .expect("the base's GroundTruth can be read");
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    let mut x_m = f64::NEG_INFINITY;
    while x_m < LASER_DIES_PAST_X_M {
        assert!(
            Instant::now() < deadline,
            "the robot never passed x {LASER_DIES_PAST_X_M} m on the laser (last x {x_m} m)"
        );
        while let Ok(Some(sample)) = truth.receive() {
            let pose = cdr::from_bytes::<GroundTruth>(sample.bytes())
                .expect("GroundTruth decodes")
                .pose;
            x_m = x_m.max(pose.x);
        }
        WaitSet::new(WakeMode::Event)
            .wait(&[&truth], Some(deadline))
            .expect("the test can wait");
    }
    let mut mover = ipc
        .subscriber(
            &names::data_channel("obstacle_avoider", "Mover"),
            &names::data_config("Mover"),
        )
        .expect("the obstacle_avoider's Mover status can be read");

    // Kill every laser process the broker starts, until it gives the laser up.
    let mut seen = Vec::new();
    let mut killed = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    loop {
        drain(&mut decisions, &mut seen);
        if moved(&seen, "obstacle_avoider", "RangeFinder", "laser", "sonar") {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the broker never moved the obstacle_avoider to the sonar; killed {killed:?}; decisions: {seen:#?}"
        );
        if let Some(pid) = pid_of(&ipc, "laser")
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

/// The simulated base and the VectorMover alone: no range sensor, so nothing avoids
/// anything. The robot stands 1 m from the lobby's west wall (x 0.5), facing it.
const BLIND_ROBOT: &str = r#"
[robot]
name = "sim-blind"
description = "The simulated base driven by the VectorMover alone, facing a wall"

[broker]
heartbeat_period_ms = 50
heartbeat_deadline_ms = 3000
startup_deadline_ms = 15000
fail_back = false
restart = { max_restarts = 1, window_ms = 60000, backoff_initial_ms = 100, backoff_max_ms = 1000 }

[[services]]
name = "base"
kind = "sim-base"
start = "always"
provides = [
    { interface = "GroundTruth", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Synchrodrive", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Egomotion", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Power", quality = 10, cost = 1, data_rate_hz = 1.0 },
]
[services.parameters]
world = "robots/worlds/conference"
start = { x_m = 1.5, y_m = 12.5, heading_deg = 180.0 }
seed = 1

[[services]]
name = "vector_mover"
kind = "vector_mover"
start = "on-demand"
requires = ["Egomotion", "Synchrodrive"]
provides = [{ interface = "Mover", quality = 5, cost = 1, data_rate_hz = 10.0 }]
[services.parameters]
rate_hz = 10.0
max_translation_m_s = 0.5
"#;

#[test]
fn a_goal_inside_a_wall_ends_with_exit_1_when_the_goal_timeout_runs_out() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let robot = sim_robot(dir.path());
    // 0.3 m inside the lobby's west wall: the avoider approaches it and never arrives.
    let mut drive = GoalDrive::start_with("sim-wall-goal", dir, &robot, "0.2,12.5", 12);
    let status = drive.wait_end();
    let log = drive.log();
    assert_eq!(status.code(), Some(1), "{log}");
    assert!(log.contains("goal 1 sent to obstacle_avoider"), "{log}");
    assert!(
        log.contains("goal not reached: --goal-timeout ran out"),
        "{log}"
    );
    assert!(log.contains(", 0 collisions"), "{log}");
}

#[test]
fn a_drive_into_a_wall_ends_with_exit_1_and_names_the_collision() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let robot = write_robot(dir.path(), BLIND_ROBOT);
    // Behind the wall, straight ahead: the VectorMover drives into it.
    let mut drive = GoalDrive::start_with("sim-bump", dir, &robot, "0,12.5", GOAL_TIMEOUT_SECS);
    let status = drive.wait_end();
    let log = drive.log();
    assert_eq!(status.code(), Some(1), "{log}");
    assert!(log.contains("goal 1 sent to vector_mover"), "{log}");
    assert!(
        log.contains("goal not reached: the robot collided ("),
        "{log}"
    );
}

/// The simulated base, laser and sonar ring, with a short heartbeat deadline.
const SIM_SENSORS: &str = r#"
[robot]
name = "sim-sensors"
description = "The simulated base, laser and sonar ring"

[broker]
heartbeat_period_ms = 50
heartbeat_deadline_ms = 1000
startup_deadline_ms = 15000
fail_back = false
restart = { max_restarts = 3, window_ms = 60000, backoff_initial_ms = 100, backoff_max_ms = 1000 }

[[services]]
name = "base"
kind = "sim-base"
start = "always"
provides = [
    { interface = "GroundTruth", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Synchrodrive", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Egomotion", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "Power", quality = 10, cost = 1, data_rate_hz = 1.0 },
]
[services.parameters]
world = "robots/worlds/conference"
start = { x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }

[[services]]
name = "laser"
kind = "sim-laser"
start = "on-demand"
requires = ["GroundTruth"]
provides = [{ interface = "RangeFinder", quality = 10, cost = 3, data_rate_hz = 37.5 }]
[services.parameters]
world = "robots/worlds/conference"

# Not restarted: once stalled and given up, it stays silent.
[[services]]
name = "sonar"
kind = "sim-sonar"
start = "on-demand"
restart = { max_restarts = 0, window_ms = 60000, backoff_initial_ms = 100, backoff_max_ms = 1000 }
requires = ["GroundTruth"]
provides = [{ interface = "RangeFinder", quality = 5, cost = 1, data_rate_hz = 10.0 }]
[services.parameters]
world = "robots/worlds/conference"
"#;

/// Runs `lewis fault` and checks that it says the fault is in effect.
fn inject(up: &Up, service: &str, what: &str, said: &str) {
    let output = fault(&up.namespace, service, what);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success() && stdout.contains(&format!("{service}: {said}")),
        "lewis fault {service} {what}: {}\n{stdout}{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
}

/// Samples waiting on a subscription (taken, so the next call counts anew).
fn count_new(subscriber: &mut Subscriber) -> usize {
    let mut count = 0;
    while subscriber
        .receive()
        .expect("samples can be received")
        .is_some()
    {
        count += 1;
    }
    count
}

#[test]
fn the_simulated_sensors_honour_out_of_service_clear_and_stall() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut up = Up::start("sim-faults", &with_absolute_paths(SIM_SENSORS));
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut laser_data = ipc
        .subscriber(
            &names::data_channel("laser", "RangeFinder"),
            &names::data_config("RangeFinder"),
        )
        .expect("the laser's data channel opens");
    let mut sonar_data = ipc
        .subscriber(
            &names::data_channel("sonar", "RangeFinder"),
            &names::data_config("RangeFinder"),
        )
        .expect("the sonar's data channel opens");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    // Out of service: the laser falls silent and the client moves to the sonar at once.
    inject(&up, "laser", "--out-of-service", "out-of-service");
    count_new(&mut laser_data);
    app.wait_for("sonar", 5);
    assert_eq!(
        count_new(&mut laser_data),
        0,
        "an out-of-service laser publishes nothing"
    );

    // Cleared: it says it is healthy and publishes again (the client stays on the sonar).
    inject(&up, "laser", "--clear", "clear");
    up.wait_status("the laser healthy again", |report| {
        report
            .lines()
            .any(|l| l.starts_with("service laser: ready") && l.contains("health ok"))
    });
    let deadline = Instant::now() + Duration::from_secs(30);
    while count_new(&mut laser_data) == 0 {
        assert!(
            Instant::now() < deadline,
            "the cleared laser never published"
        );
        WaitSet::new(WakeMode::Event)
            .wait(&[&laser_data], Some(deadline))
            .expect("the test can wait");
    }

    // Stalled: the sonar stops publishing and beating; after the heartbeat deadline the
    // broker moves the client back to the laser.
    inject(&up, "sonar", "--stall", "stall");
    count_new(&mut sonar_data);
    app.wait_for("laser", 5);
    assert_eq!(
        count_new(&mut sonar_data),
        0,
        "a stalled sonar publishes nothing"
    );
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to sonar"), "{log}");
    assert!(log.contains("rebind app from sonar to laser"), "{log}");
    assert!(log.contains("heartbeat"), "{log}");
}

/// Blobs3D samples taken on each side of the camera switch.
const PLACED_SAMPLES: usize = 8;

/// The width of the simulated cameras' images (`robots/sim.toml`).
const IMAGE_WIDTH_PX: i32 = 640;

/// The median position (x, y) of each colour's largest placed blob over `count` Blobs3D
/// samples from now on. Blobs cut by the image's side are left out: the two cameras see
/// different parts of such an object, so its centroid is not the same point.
fn placed_by_colour(blobs3d: &mut Subscriber, count: usize) -> BTreeMap<String, (f64, f64)> {
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    count_new(blobs3d);
    let mut seen: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut taken = 0;
    while taken < count {
        assert!(
            Instant::now() < deadline,
            "only {taken} Blobs3D samples came"
        );
        while let Some(sample) = blobs3d.receive().expect("Blobs3D can be received") {
            let message: Blobs3D = cdr::from_bytes(sample.bytes()).expect("Blobs3D decodes");
            let mut largest: BTreeMap<&str, &Blob3D> = BTreeMap::new();
            let whole = |b: &&Blob3D| b.blob.left > 2 && b.blob.right < IMAGE_WIDTH_PX - 3;
            for placed in message.blobs.iter().filter(|b| b.range_valid).filter(whole) {
                let entry = largest.entry(&placed.blob.colour_name).or_insert(placed);
                if placed.blob.area > entry.blob.area {
                    *entry = placed;
                }
            }
            for (colour, placed) in largest {
                seen.entry(colour.to_owned())
                    .or_default()
                    .push((placed.position.x, placed.position.y));
            }
            taken += 1;
        }
        WaitSet::new(WakeMode::Event)
            .wait(&[&*blobs3d], Some(deadline))
            .expect("the test can wait");
    }
    let median = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    seen.into_iter()
        // A colour seen in most samples, not one that flickered in once.
        .filter(|(_, at)| at.len() > count / 2)
        .map(|(colour, at)| {
            let x = median(at.iter().map(|p| p.0).collect());
            let y = median(at.iter().map(|p| p.1).collect());
            (colour, (x, y))
        })
        .collect()
}

/// The paper's example of a failover: Lewis's stereo pair. The left camera goes out of
/// service; the broker moves the blob finder and the sign detector to the right camera
/// (one pan-tilt mount: both at once), and BlobFinder3D, knowing that camera's place 12 cm
/// to the right, puts the same objects where it put them before. The robot stands still.
#[test]
fn the_left_camera_lost_the_right_one_serves_perception_and_blobs_stay_in_place() {
    let _one = ONE_ROBOT
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    // Turned toward the lobby's first sign (on the wall by the entrance door), so that it
    // is whole in both cameras' images.
    let start = "start = { x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }";
    let robot = lewis_tests::robot::shipped_robot("sim.toml");
    assert!(
        robot.contains(start),
        "robots/sim.toml's start pose changed"
    );
    let robot = robot.replace(
        start,
        "start = { x_m = 3.0, y_m = 12.5, heading_deg = 21.0 }",
    );
    let mut up = Up::start("sim-stereo", &robot);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut decisions = ipc
        .subscriber(names::BROKER_CHANNEL, &names::broker_config())
        .expect("the broker's decisions can be read");
    let mut blobs3d = ipc
        .subscriber(
            &names::data_channel("blobfinder3d", "Blobs3D"),
            &names::data_config("Blobs3D"),
        )
        .expect("Blobs3D can be read");
    up.wait_line("broker up");
    let left = placed_by_colour(&mut blobs3d, PLACED_SAMPLES);

    inject(&up, "camera", "--out-of-service", "out-of-service");
    let to_camera2 =
        |seen: &[Broker], client: &str| moved(seen, client, "ImageSource", "camera", "camera2");
    let mut seen = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(GOAL_TIMEOUT_SECS);
    while !(to_camera2(&seen, "blobfinder") && to_camera2(&seen, "sign_detector")) {
        assert!(
            Instant::now() < deadline,
            "perception did not move to camera2: {seen:#?}"
        );
        drain(&mut decisions, &mut seen);
        WaitSet::new(WakeMode::Event)
            .wait(&[&decisions], Some(deadline))
            .expect("the test can wait");
    }
    // Blobs already on their way from the left camera's last images pass first.
    count_new(&mut blobs3d);
    let right = placed_by_colour(&mut blobs3d, PLACED_SAMPLES);
    up.stop();

    eprintln!("through the left camera {left:?}\nthrough the right camera {right:?}");
    let both: Vec<_> = left.keys().filter(|c| right.contains_key(*c)).collect();
    assert!(
        !both.is_empty(),
        "no colour placed through both cameras: left {left:?}, right {right:?}"
    );
    for colour in both {
        let (a, b) = (left[colour], right[colour]);
        let moved_m = (a.0 - b.0).hypot(a.1 - b.1);
        assert!(
            moved_m < 0.05,
            "{colour}: placed at {a:?} through the left camera, {b:?} through the right: {moved_m:.3} m apart"
        );
    }
}
