//! Load beside a test or a benchmark: `stress-ng --cpu N` (Debian package `stress-ng`,
//! installed by `.ci/run`), stopped when dropped.

use std::process::{Child, Command, Stdio};

/// A running `stress-ng --cpu N`; dropping it stops it.
pub struct Stress(Child);

impl Stress {
    /// Keeps `cpus` cores busy with other work.
    ///
    /// # Panics
    /// When stress-ng is not installed: say so rather than measure an idle machine.
    #[must_use]
    pub fn cpus(cpus: u32) -> Self {
        let child = Command::new("stress-ng")
            .args(["--cpu", &cpus.to_string(), "--quiet"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!("stress-ng cannot run ({e}): install the Debian package stress-ng")
            });
        Self(child)
    }
}

impl Drop for Stress {
    fn drop(&mut self) {
        crate::signal(self.0.id(), nix::sys::signal::Signal::SIGTERM);
        let _ = self.0.wait();
    }
}
