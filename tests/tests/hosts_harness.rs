//! The harness of several hosts on one machine (`lewis_tests::hosts`): its hosts reach each
//! other over the segment, keep their shared memory apart, lose each other while a link is
//! cut, run programs where and as they are told, and leave nothing behind.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead, BufReader};
use std::net::Ipv4Addr;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::channel;
use std::time::{Duration, Instant};

use lewis_tests::hosts::Host;
use lewis_tests::{WATCHDOG, hosts_or_skip, run_ok};

/// The port of the servers of these tests: every host has its own.
const PORT: &str = "7000";

/// A TCP server answering each connection with its host's name and closing it.
const SERVER: &str = r#"
import socket, sys
s = socket.socket()
s.bind(("0.0.0.0", int(sys.argv[1])))
s.listen()
print("listening", flush=True)
while True:
    c, _ = s.accept()
    c.sendall(sys.argv[2].encode() + b"\n")
    c.close()
"#;

/// Connects (1 s at most) and prints the server's line, or the error and exits 1.
const CLIENT: &str = r#"
import socket, sys
try:
    c = socket.create_connection((sys.argv[1], int(sys.argv[2])), timeout=1)
    print(c.makefile().readline().strip())
except OSError as e:
    print(e)
    sys.exit(1)
"#;

/// A running server in `host`, killed with the test.
struct Server(Child);

impl Server {
    /// Starts the server in `host` and waits (watchdog) until it listens.
    fn start(host: &Host) -> Self {
        let mut child = host
            .command("python3")
            .args(["-c", SERVER, PORT, host.name()])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .expect("python3 starts");
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let _ = BufReader::new(stdout).read_line(&mut line);
            let _ = tx.send(line);
        });
        let server = Self(child);
        let line = rx.recv_timeout(WATCHDOG).unwrap_or_default();
        assert_eq!(
            line.trim(),
            "listening",
            "the server in {} does not listen",
            host.name()
        );
        server
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Connects from `from` to the server at `to`: the server's host name, or why not.
fn connect(from: &Host, to: Ipv4Addr) -> Result<String, String> {
    let out = from
        .command("python3")
        .args(["-c", CLIENT, &to.to_string(), PORT])
        .output()
        .expect("python3 runs");
    let said = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    if out.status.success() {
        Ok(said)
    } else {
        Err(said)
    }
}

/// `readlink /proc/self/ns/KIND` as a program in `host` sees it.
fn namespace_in(host: &Host, kind: &str) -> String {
    run_ok(
        host.command("readlink")
            .arg(format!("/proc/self/ns/{kind}")),
    )
}

#[test]
fn hosts_reach_each_other_over_the_segment() {
    let hosts = hosts_or_skip!(&["base", "robot", "drone"]);
    let (base, robot, drone) = (hosts.host("base"), hosts.host("robot"), hosts.host("drone"));
    assert_eq!(base.address(), Ipv4Addr::new(10, 0, 0, 1));
    assert_eq!(robot.address(), Ipv4Addr::new(10, 0, 0, 2));
    assert_eq!(drone.address(), Ipv4Addr::new(10, 0, 0, 3));

    let _servers = [Server::start(base), Server::start(robot)];
    // Over the cable to the switch, over the switch between two cables, and back.
    assert_eq!(connect(base, robot.address()), Ok("robot".into()));
    assert_eq!(connect(drone, robot.address()), Ok("robot".into()));
    assert_eq!(connect(robot, base.address()), Ok("base".into()));
    // Each host has its own loopback: the robot's own server, not the base's.
    assert_eq!(connect(robot, Ipv4Addr::LOCALHOST), Ok("robot".into()));
    // The drone has no server, and nothing of the others is on its loopback.
    assert!(connect(drone, Ipv4Addr::LOCALHOST).is_err());
}

#[test]
fn shared_memory_stays_in_its_host() {
    let hosts = hosts_or_skip!(&["base", "robot"]);
    let (base, robot) = (hosts.host("base"), hosts.host("robot"));
    for kind in ["net", "ipc", "mnt"] {
        let in_base = namespace_in(base, kind);
        assert_eq!(
            in_base,
            namespace_in(base, kind),
            "two programs of one host, {kind}"
        );
        assert_ne!(in_base, namespace_in(robot, kind), "two hosts, {kind}");
        let own = std::fs::read_link(format!("/proc/self/ns/{kind}")).unwrap();
        assert_ne!(
            in_base.trim(),
            own.to_str().unwrap(),
            "a host and the test, {kind}"
        );
    }

    for dir in ["/dev/shm", "/tmp/iceoryx2"] {
        let probe = format!("{dir}/lewis-hosts-probe-{}", std::process::id());
        assert_eq!(
            run_ok(
                base.command("sh")
                    .args(["-c", "echo here > \"$0\"", &probe])
            ),
            ""
        );
        let seen = |host: &Host| {
            host.command("test")
                .args(["-e", &probe])
                .status()
                .unwrap()
                .success()
        };
        assert!(seen(base), "a later program of the base sees {probe}");
        assert!(!seen(robot), "the robot sees the base's {probe}");
        assert!(
            !std::path::Path::new(&probe).exists(),
            "the test sees the base's {probe}"
        );
    }
}

#[test]
fn programs_keep_their_directory_and_environment() {
    let hosts = hosts_or_skip!(&["base", "robot"]);
    let robot = hosts.host("robot");
    let dir = tempfile::tempdir().unwrap();
    let out = run_ok(
        robot
            .command("bash")
            .args([
                "-c",
                "pwd; echo \"$LEWIS_PROBE\"; env | grep '^odd.name='; echo made > made",
            ])
            .current_dir(dir.path())
            .env("LEWIS_PROBE", "probe value")
            .env("odd.name", "kept"),
    );
    let dir_path = dir.path().canonicalize().unwrap();
    assert_eq!(
        out.lines().collect::<Vec<_>>(),
        [dir_path.to_str().unwrap(), "probe value", "odd.name=kept"]
    );
    // The test's temporary directory is the same directory in the host.
    assert_eq!(
        std::fs::read_to_string(dir.path().join("made")).unwrap(),
        "made\n"
    );
    // A relative path from there is resolved in the host's mounts, not the test's.
    let out = run_ok(
        robot
            .command("sh")
            .args([
                "-c",
                "echo in-host > /dev/shm/lewis-hosts-cwd && cat lewis-hosts-cwd",
            ])
            .current_dir("/dev/shm"),
    );
    assert_eq!(out, "in-host\n");
    assert!(!std::path::Path::new("/dev/shm/lewis-hosts-cwd").exists());
}

#[test]
fn a_cut_link_stops_traffic_until_restored() {
    let hosts = hosts_or_skip!(&["base", "robot", "drone"]);
    let (base, robot, drone) = (hosts.host("base"), hosts.host("robot"), hosts.host("drone"));
    let _servers = [
        Server::start(base),
        Server::start(robot),
        Server::start(drone),
    ];
    assert_eq!(connect(base, robot.address()), Ok("robot".into()));

    hosts.link_down("base", "robot");
    // At once: each attempt waits out its timeout.
    std::thread::scope(|scope| {
        for (from, to) in [(base, robot), (robot, base), (drone, robot), (robot, drone)] {
            scope.spawn(move || {
                let got = connect(from, to.address());
                assert!(
                    got.is_err(),
                    "{} reaches {} over a cut link: {got:?}",
                    from.name(),
                    to.name()
                );
            });
        }
    });
    // The other cable still carries.
    assert_eq!(connect(drone, base.address()), Ok("base".into()));

    // Either end names the link; once up, it carries at once.
    hosts.link_up("robot", "base");
    assert_eq!(connect(base, robot.address()), Ok("robot".into()));
    assert_eq!(connect(robot, drone.address()), Ok("drone".into()));
}

#[test]
fn nothing_is_left_after_drop() {
    let hosts = hosts_or_skip!(&["base", "robot"]);
    let (base, robot) = (hosts.host("base"), hosts.host("robot"));
    assert_eq!(base.processes(), Vec::<u32>::new());
    assert_eq!(robot.processes(), Vec::<u32>::new());

    let mut left = robot.command("sleep").arg("1000").spawn().unwrap();
    let pid = left.id();
    // It is in the robot once nsenter has entered it, and then becomes sleep itself.
    let deadline = Instant::now() + WATCHDOG;
    while robot.processes() != [pid]
        || std::fs::read_link(format!("/proc/{pid}/exe")).is_ok_and(|exe| !exe.ends_with("sleep"))
    {
        assert!(
            Instant::now() < deadline,
            "{pid} never runs sleep in the robot"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    assert_eq!(base.processes(), Vec::<u32>::new());

    assert_eq!(run_ok(&mut robot.command("true")), "");
    assert_eq!(robot.processes(), [pid], "a program that ended is not left");

    let netns: Vec<String> = [base, robot].map(|h| h.netns().to_owned()).into();
    let anchors = [base.anchor_pid(), robot.anchor_pid()];
    drop(hosts);

    let status = left.wait().unwrap();
    assert!(
        !status.success(),
        "the program left in the robot was killed: {status}"
    );
    let list = run_ok(Command::new("ip").args(["netns", "list"]));
    for name in &netns {
        assert!(
            !list.split_whitespace().any(|n| n == name),
            "{name} is still there:\n{list}"
        );
    }
    for anchor in anchors {
        assert!(!std::path::Path::new(&format!("/proc/{anchor}")).exists());
    }
}
