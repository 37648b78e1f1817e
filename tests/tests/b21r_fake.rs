//! The real robot's description against the device emulators, end to end: `lewis
//! fake-device` for the laser and the base, `lewis up` on a copy of `robots/b21r.toml`
//! pointing at their pseudo-terminals, a client of RangeFinder receiving laser scans; then the
//! laser's emulator dies and the broker moves the client to the base's sonar ring.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use lewis_runtime::ipc::Namespace;
use lewis_tests::{RangeApp, Up, lewis_exe, open_ipc, repo_root, signal, wait_child};

/// A `lewis fake-device` process, killed when dropped.
struct FakeDevice {
    child: Child,
}

impl FakeDevice {
    /// Starts `lewis fake-device DEVICE --link LINK` and waits for the path it prints, which
    /// it prints once the device answers there.
    fn start(device: &str, link: &Path) -> Self {
        let mut child = Command::new(lewis_exe())
            .args(["fake-device", device, "--link"])
            .arg(link)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("lewis fake-device starts");
        let stdout = child.stdout.take().expect("stdout is piped");
        let mut line = String::new();
        // The line comes at once or the process ended (an error on stderr): no watchdog
        // needed, the read ends either way.
        BufReader::new(stdout).read_line(&mut line).unwrap();
        assert_eq!(
            line.trim_end(),
            link.to_str().unwrap(),
            "lewis fake-device {device} prints the link it made"
        );
        Self { child }
    }

    /// Kills it as a crash would (the link is left dangling: the device is gone).
    fn kill(&mut self) {
        signal(self.child.id(), nix::sys::signal::Signal::SIGKILL);
        let _ = wait_child(&mut self.child);
    }
}

impl Drop for FakeDevice {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// `robots/b21r.toml` with its ports replaced by `laser` and `base`.
fn b21r_with_ports(laser: &Path, base: &Path) -> String {
    let path: PathBuf = repo_root().join("robots/b21r.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{} ships with the repository: {e}", path.display()));
    let replace = |text: &str, from: &str, to: &Path| {
        let line = format!("port = \"{from}\"");
        assert_eq!(text.matches(&line).count(), 1, "b21r.toml has one `{line}`");
        text.replace(&line, &format!("port = \"{}\"", to.display()))
    };
    replace(&replace(&text, "/dev/ttyS0", laser), "/dev/ttyS1", base)
}

#[test]
fn laser_scans_reach_the_client_and_the_sonar_takes_over_when_the_laser_dies() {
    let dir = tempfile::tempdir().unwrap();
    let laser_port = dir.path().join("ttySICK");
    let base_port = dir.path().join("ttyRFLEX");
    let mut laser_device = FakeDevice::start("sick", &laser_port);
    let _base_device = FakeDevice::start("rflex", &base_port);
    let robot = b21r_with_ports(&laser_port, &base_port);

    let mut up = Up::start_in(dir, Namespace::unique("b21r-fake"), &robot);
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    laser_device.kill();
    app.wait_for("base", 5);
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to base"), "{log}");
    assert!(
        log.contains("ttySICK"),
        "the laser's reason names its port: {log}"
    );
}
