//! `[broker] nice` and `keep_cores_awake`: `lewis up` runs the robot at the robot file's
//! nice value, its services inherit it, it keeps the machine's cores awake while the robot
//! runs, and where the machine does not allow either the run goes on and says why.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, ExitStatus};

use lewis_runtime::ipc::Namespace;
use lewis_runtime::supervise::{cpu_latency_target_us, keep_cores_awake};
use lewis_tests::{Up, lewis_exe};

/// A robot of one test laser, with `broker` among its `[broker]` settings.
fn robot(broker: &str) -> String {
    format!(
        r#"
[robot]
name = "nice"

[broker]
heartbeat_period_ms = 20
heartbeat_deadline_ms = 1000
{broker}

[[services]]
name = "laser"
kind = "test-range"
start = "always"
provides = [{{ interface = "RangeFinder", quality = 10, cost = 1 }}]
"#
    )
}

/// The nice value of process `pid` (field 19 of /proc/PID/stat, after the command name).
fn nice_of(pid: u32) -> i32 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let (_, after_name) = stat.rsplit_once(')').unwrap();
    after_name
        .split_whitespace()
        .nth(16)
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn the_broker_and_its_services_run_at_the_robot_files_nice_value() {
    // Lowering a priority needs no privilege, so this holds on any machine. Its own
    // session: where the kernel groups processes by session, lewis up lowers its session's
    // group too, which must not be the test's.
    let mut up = Up::start_in_own_session("nice", &robot("nice = 7"));
    up.wait_line("the robot runs at nice 7");
    up.wait_line("laser: started");
    assert_eq!(nice_of(up.pid()), 7);
    assert_eq!(nice_of(up.pid_of("laser")), 7);
    assert!(up.stop().success(), "{}", up.log());
}

#[test]
fn a_robot_not_allowed_its_priority_runs_and_says_why() {
    // Without CAP_SYS_NICE (dropped by setpriv where the test runs as root) no process
    // may raise its priority.
    let Ok(setpriv) = which_setpriv() else {
        lewis_testkit::skip_unless_ci!("setpriv (util-linux) is not installed");
    };
    let dir = tempfile::tempdir().unwrap();
    let mut setpriv = Command::new(setpriv);
    setpriv.args(["--bounding-set=-sys_nice", "--inh-caps=-sys_nice"]);
    let (status, stderr) = up_for_a_second(setpriv, dir.path(), &robot("nice = -5"));
    assert!(status.success(), "{stderr}");
    assert!(
        stderr.contains(
            "not allowed to raise the robot's priority to nice -5: give lewis CAP_SYS_NICE"
        ),
        "{stderr}"
    );
    assert!(
        stderr.contains("laser: started") || stderr.contains("broker up"),
        "{stderr}"
    );
}

#[test]
fn the_cores_are_kept_awake_while_the_robot_runs_and_sleep_again_after() {
    // A request made and dropped at once: whether this machine lets the test make one.
    if let Err(e) = keep_cores_awake() {
        lewis_testkit::skip_unless_ci!("{e}");
    }
    // Another process (a benchmark, tuned's latency profile) may hold the cores awake
    // already: the robot's request and its end could not be seen then.
    let before = cpu_latency_target_us();
    if before == Some(0) {
        lewis_testkit::skip_unless_ci!("the cores are kept awake by another process");
    }
    let mut up = Up::start("awake", &robot("keep_cores_awake = true"));
    up.wait_line("the cores are kept awake while the robot runs");
    up.wait_line("laser: started");
    assert_eq!(cpu_latency_target_us(), Some(0), "{}", up.log());
    assert!(up.stop().success(), "{}", up.log());
    assert_eq!(cpu_latency_target_us(), before);
}

#[test]
fn a_robot_whose_machine_refuses_to_keep_the_cores_awake_runs_and_says_why() {
    // In a mount namespace of lewis's own (root only), the device is a read-only file: a
    // write to a device node is allowed on a read-only mount.
    let dir = tempfile::tempdir().unwrap();
    let stand_in = dir.path().join("cpu_dma_latency");
    std::fs::write(&stand_in, []).unwrap();
    let mut unshare = Command::new("unshare");
    unshare
        .args(["--mount", "--propagation", "private", "sh", "-c"])
        .arg(
            "mount --bind \"$0\" /dev/cpu_dma_latency \
             && mount -o remount,bind,ro /dev/cpu_dma_latency && exec \"$@\"",
        )
        .arg(&stand_in);
    let (status, stderr) = up_for_a_second(unshare, dir.path(), &robot("keep_cores_awake = true"));
    if stderr.contains("unshare:") || stderr.contains("mount:") {
        lewis_testkit::skip_unless_ci!("cannot make the device read-only here: {stderr}");
    }
    assert!(status.success(), "{stderr}");
    assert!(
        stderr.contains("cannot keep the cores awake through /dev/cpu_dma_latency"),
        "{stderr}"
    );
    assert!(
        stderr.contains("the cores sleep as the machine has them"),
        "{stderr}"
    );
    assert!(stderr.contains("broker up"), "{stderr}");
}

/// Runs `lewis up` on `robot` (written into `dir`) for a second, not recording, through
/// `wrapper` (a command that ends by running the arguments after its own); its exit status
/// and what it wrote on stderr.
fn up_for_a_second(mut wrapper: Command, dir: &Path, robot: &str) -> (ExitStatus, String) {
    let robot_path = dir.join("robot.toml");
    std::fs::write(&robot_path, robot).unwrap();
    let namespace = Namespace::unique("up-for-a-second");
    let output = wrapper
        .arg(lewis_exe())
        .arg("up")
        .arg(&robot_path)
        .args(["--namespace", namespace.as_str(), "--no-record"])
        .args(["--duration", "1s"])
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap();
    (
        output.status,
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

fn which_setpriv() -> Result<std::path::PathBuf, ()> {
    ["/usr/bin/setpriv", "/bin/setpriv"]
        .into_iter()
        .map(std::path::PathBuf::from)
        .find(|p| p.exists())
        .ok_or(())
}
