//! `lewis up` as a process: isolation by namespace, no orphans when it is killed, clear
//! errors for bad robot files and missing programs.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead as _, BufReader};
use std::process::{Command, Stdio};

use lewis_runtime::ipc::NodeLiveness;
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::{RangeApp, Up, Watched, descendants, lewis_exe, open_ipc};

#[test]
fn two_robots_in_different_namespaces_do_not_see_each_other() {
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        ..TestRobot::default()
    });
    let mut a = Up::start("ns-a", &robot);
    let mut b = Up::start("ns-b", &robot);
    a.wait_line("broker up");
    b.wait_line("broker up");
    let ipc_a = open_ipc(&a.namespace, "test-a");
    let ipc_b = open_ipc(&b.namespace, "test-b");
    // Ready means the laser's harness has its IPC node and has sent its first heartbeat.
    let [laser_a, laser_b] = [&a, &b].map(|up| {
        up.wait_status("the laser ready", |r| r.contains("service laser: ready"));
        up.pid_of("laser")
    });
    assert_ne!(laser_a, laser_b);
    for (ipc, laser) in [(&ipc_a, laser_a), (&ipc_b, laser_b)] {
        let lasers: Vec<i32> = ipc
            .nodes()
            .unwrap()
            .into_iter()
            .filter(|n| n.liveness == NodeLiveness::Alive && n.name.as_deref() == Some("laser"))
            .filter_map(|n| n.pid)
            .collect();
        assert_eq!(lasers, [i32::try_from(laser).unwrap()]);
    }
    let mut app = RangeApp::connect(&ipc_a);
    app.wait_for("laser", 3);
    let status = Command::new(lewis_exe())
        .args(["status", "--namespace", b.namespace.as_str()])
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&status.stdout);
    assert!(status.status.success(), "{report}");
    assert!(
        report.contains(&format!("process laser: pid {laser_b}")),
        "{report}"
    );
    assert!(!report.contains("client app"), "{report}");
    a.stop();
    b.stop();
}

#[test]
fn sigkill_of_lewis_up_leaves_no_process_behind_grandchildren_included() {
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        sonar_start: "standby",
        // A service whose program starts a helper of its own: a grandchild of lewis up,
        // which the death signal of the services does not reach.
        extra: r#"
[[services]]
name = "spawner"
command = ["/bin/sh", "-c", "sleep 600 & echo grandchild $!; wait"]
start = "always"
startup_deadline_ms = 600000
provides = [{ interface = "Distance", quality = 1, cost = 1 }]
"#,
        ..TestRobot::default()
    });
    let mut up = Up::start("sigkill-up", &robot);
    let line = up.wait_line("grandchild ");
    let grandchild: u32 = line
        .split("grandchild ")
        .nth(1)
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|pid| pid.parse().ok())
        .unwrap_or_else(|| panic!("no pid in {line}"));
    up.wait_status("laser and sonar running", |r| {
        r.contains("service laser: ready") && r.contains("service sonar: ready")
    });
    let (laser, sonar, spawner) = (up.pid_of("laser"), up.pid_of("sonar"), up.pid_of("spawner"));

    // Every process under lewis up: the services, the recorder, the spawner's helper.
    let all = descendants(up.pid());
    for (what, pid) in [
        ("laser", laser),
        ("sonar", sonar),
        ("spawner", spawner),
        ("grandchild", grandchild),
    ] {
        assert!(
            all.contains(&pid),
            "{what} (pid {pid}) is not under lewis up: {all:?}"
        );
    }
    assert!(all.len() >= 5, "the recorder runs too: {all:?}");
    let watched: Vec<Watched> = all.iter().map(|pid| Watched::new(*pid)).collect();
    up.kill();
    for process in &watched {
        assert!(
            process.wait_gone(),
            "process {} outlived lewis up (of {all:?}, laser {laser}, sonar {sonar}, spawner {spawner}, grandchild {grandchild})",
            process.pid()
        );
    }
}

#[test]
fn a_run_that_ended_leaves_nothing_in_shared_memory() {
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        ..TestRobot::default()
    });
    let mut up = Up::start("leaves-nothing", &robot);
    up.wait_line("broker up");
    // Its channels, its nodes and every process's publication ledger exist by now.
    up.wait_status("the laser ready", |r| r.contains("service laser: ready"));
    let prefix = up.namespace.iceoryx2_prefix();
    assert!(!entries_named(&prefix).is_empty(), "the run made nothing?");
    assert!(up.stop().success(), "{}", up.log());
    assert_eq!(entries_named(&prefix), Vec::<String>::new(), "{}", up.log());
}

/// Every file or folder under `/dev/shm` and `/tmp/iceoryx2` whose name starts with
/// `prefix`, at any depth.
fn entries_named(prefix: &str) -> Vec<String> {
    fn walk(dir: &std::path::Path, prefix: &str, found: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if entry.file_name().to_string_lossy().starts_with(prefix) {
                found.push(path.display().to_string());
            } else if entry.file_type().is_ok_and(|t| t.is_dir()) {
                walk(&path, prefix, found);
            }
        }
    }
    let mut found = Vec::new();
    for root in ["/dev/shm", "/tmp/iceoryx2"] {
        walk(std::path::Path::new(root), prefix, &mut found);
    }
    found
}

#[test]
fn malformed_robot_file_gives_a_line_numbered_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(
        &path,
        "[robot]\nname = \"bad\"\n\n[[services]]\nname = \"laser\"\nkind = \"test-range\"\nstart = \"sometimes\"\n",
    )
    .unwrap();
    let output = Command::new(lewis_exe())
        .arg("up")
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.toml:7:"), "{stderr}");
}

#[test]
fn missing_service_program_is_reported_and_not_retried() {
    let robot = test_robot(&TestRobot {
        extra: r#"
[[services]]
name = "ghost"
command = ["/nonexistent/lewis-ghost-driver"]
start = "always"
provides = [{ interface = "Distance", quality = 1, cost = 1 }]
"#,
        ..TestRobot::default()
    });
    let mut up = Up::start("ghost", &robot);
    let line = up.wait_line("ghost failed");
    assert!(line.contains("not found"), "{line}");
    let status = Command::new(lewis_exe())
        .args(["status", "--namespace", up.namespace.as_str()])
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&status.stdout);
    assert!(report.contains("service ghost: failed,"), "{report}");
    up.stop();
    let starts = up.seen.iter().filter(|l| l.contains("start ghost")).count();
    assert_eq!(starts, 1, "{}", up.log());
}

#[test]
fn a_client_killed_without_release_loses_its_bindings() {
    let robot = test_robot(&TestRobot::default());
    let mut up = Up::start("dead-client", &robot);
    up.wait_line("broker up");
    let mut client = Command::new(env!("CARGO_BIN_EXE_lewis-test-client"))
        .arg("doomed")
        .env("LEWIS_NAMESPACE", up.namespace.as_str())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(client.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert_eq!(line.trim(), "bound to laser");
    assert!(up.status().contains("client doomed RangeFinder -> laser"));
    client.kill().unwrap();
    client.wait().unwrap();
    up.wait_status("the dead client gone", |r| !r.contains("client doomed"));
    up.stop();
    assert!(
        up.log().contains("client doomed died without a release"),
        "{}",
        up.log()
    );
}
