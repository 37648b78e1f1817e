//! Ctrl-C: SIGINT, SIGTERM and SIGHUP to the sequencer become [`Controller::interrupt`], so
//! the mission stops its program and ends as aborted instead of dying with it. The signals
//! are caught by the runtime's one catcher ([`StopSignals`]); a thread waits on it.

use std::io::{self, Write as _};
use std::os::unix::net::UnixStream;
use std::thread::JoinHandle;

use lewis_runtime::live::StopSignals;
use nix::sys::signal::Signal;
use rustix::event::{PollFd, PollFlags, poll};

use super::control::Controller;

/// Forwards the signals while it lives; dropping it stops forwarding and uninstalls the
/// handlers.
#[derive(Debug)]
pub struct SignalForwarder {
    stop: UnixStream,
    thread: Option<JoinHandle<()>>,
}

impl SignalForwarder {
    /// Catches SIGINT, SIGTERM and SIGHUP and interrupts the mission of `controller` on
    /// each.
    ///
    /// # Errors
    /// When the handlers cannot be installed or the thread cannot start.
    pub fn start(controller: Controller) -> io::Result<Self> {
        let signals = StopSignals::install_for(&[Signal::SIGINT, Signal::SIGTERM, Signal::SIGHUP])?;
        let (stop, stopped) = UnixStream::pair()?;
        let thread = std::thread::Builder::new()
            .name("lewis-seq-signals".into())
            .spawn(move || forward(&signals, &stopped, &controller))?;
        Ok(Self {
            stop,
            thread: Some(thread),
        })
    }
}

/// Waits for a signal or for the forwarder to be dropped.
fn forward(signals: &StopSignals, stopped: &UnixStream, controller: &Controller) {
    loop {
        let mut fds = [
            PollFd::new(signals, PollFlags::IN),
            PollFd::new(stopped, PollFlags::IN),
        ];
        match poll(&mut fds, None) {
            Ok(_) => {}
            Err(rustix::io::Errno::INTR) => continue,
            Err(e) => {
                tracing::error!("cannot wait for signals any more: {e}");
                return;
            }
        }
        if !fds[1].revents().is_empty() {
            return;
        }
        for signal in signals.take_signals() {
            let name = signal.as_str().to_owned();
            tracing::info!("{name} received: stopping the mission");
            controller.interrupt(name);
        }
    }
}

impl Drop for SignalForwarder {
    fn drop(&mut self) {
        // A byte, or the end of the stream if it cannot be written: either wakes the thread.
        let _ = self.stop.write_all(&[0]);
        let _ = self.stop.shutdown(std::net::Shutdown::Both);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
