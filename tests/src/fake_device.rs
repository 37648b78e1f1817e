//! `lewis fake-device` as a user runs it, for the tests of the B21r on its emulators.

use std::io::{BufRead as _, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use crate::{lewis_exe, repo_root, signal, wait_child};

/// A `lewis fake-device` process, run from the repository's root (where the worlds are),
/// killed when dropped.
pub struct FakeDeviceProcess {
    child: Child,
}

impl FakeDeviceProcess {
    /// Starts `lewis fake-device DEVICE --pty PTY ARGS` and waits for the path it prints,
    /// which it prints once the device answers there.
    ///
    /// # Panics
    /// When it cannot start or does not print the link it made.
    #[must_use]
    pub fn start(device: &str, pty: &Path, args: &[&str]) -> Self {
        Self::start_with("--pty", device, pty, args)
    }

    /// As [`FakeDeviceProcess::start`], naming the pseudo-terminal with `option`.
    ///
    /// # Panics
    /// When it cannot start or does not print the link it made.
    #[must_use]
    pub fn start_with(option: &str, device: &str, pty: &Path, args: &[&str]) -> Self {
        let mut child = Command::new(lewis_exe())
            .args(["fake-device", device, option])
            .arg(pty)
            .args(args)
            .current_dir(repo_root())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("lewis fake-device starts");
        let stdout = child.stdout.take().expect("stdout is piped");
        let mut line = String::new();
        // The line comes at once or the process ended (an error on stderr): no watchdog
        // needed, the read ends either way.
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("lewis fake-device's output can be read");
        assert_eq!(
            line.trim_end(),
            pty.to_str().expect("test paths are UTF-8"),
            "lewis fake-device {device} prints the link it made"
        );
        Self { child }
    }

    /// Kills it as a crash would (the link is left dangling: the device is gone).
    pub fn kill(&mut self) {
        signal(self.child.id(), nix::sys::signal::Signal::SIGKILL);
        let _ = wait_child(&mut self.child);
    }
}

impl Drop for FakeDeviceProcess {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}
