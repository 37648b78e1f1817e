//! Ctrl-C: SIGINT, SIGTERM and SIGHUP to the sequencer become [`Controller::interrupt`], so
//! the mission stops its program and ends as aborted instead of dying with it.

use std::io;
use std::thread::JoinHandle;

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::{Handle, Signals};

use super::control::Controller;

/// Forwards the signals while it lives; dropping it stops forwarding (the signals are then
/// still caught, and ignored, for the rest of the process's life).
#[derive(Debug)]
pub struct SignalForwarder {
    handle: Handle,
    thread: Option<JoinHandle<()>>,
}

impl SignalForwarder {
    /// Catches SIGINT, SIGTERM and SIGHUP and interrupts the mission of `controller` on
    /// each.
    ///
    /// # Errors
    /// When the handlers cannot be installed or the thread cannot start.
    pub fn start(controller: Controller) -> io::Result<Self> {
        let mut signals = Signals::new([SIGINT, SIGTERM, SIGHUP])?;
        let handle = signals.handle();
        let thread = std::thread::Builder::new()
            .name("lewis-seq-signals".into())
            .spawn(move || {
                for signal in signals.forever() {
                    let name = nix::sys::signal::Signal::try_from(signal)
                        .map_or_else(|_| format!("signal {signal}"), |s| s.as_str().to_owned());
                    tracing::info!("{name} received: stopping the mission");
                    controller.interrupt(name);
                }
            })?;
        Ok(Self {
            handle,
            thread: Some(thread),
        })
    }
}

impl Drop for SignalForwarder {
    fn drop(&mut self) {
        self.handle.close();
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
