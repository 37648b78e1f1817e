//! The one signal catcher of Lewis: the signals that ask a process to stop (SIGTERM and
//! SIGINT, and SIGHUP where a caller wants it) as a file descriptor to wait on (the
//! self-pipe trick). The handler only writes a byte and sets a flag; the event loop sees the
//! socket readable and stops cleanly, knowing which signal asked.

use std::io::{self, Read};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use nix::sys::signal::Signal;
use signal_hook::SigId;

/// Catches stop signals while it lives.
#[derive(Debug)]
pub struct StopSignals {
    read: UnixStream,
    caught: Vec<(Signal, Arc<AtomicBool>)>,
    ids: Vec<SigId>,
}

impl StopSignals {
    /// Installs the handlers for SIGTERM and SIGINT.
    ///
    /// # Errors
    /// When the socket pair or the handlers cannot be made.
    pub fn install() -> io::Result<Self> {
        Self::install_for(&[Signal::SIGTERM, Signal::SIGINT])
    }

    /// Installs the handlers for `signals`.
    ///
    /// # Errors
    /// When the socket pair or the handlers cannot be made.
    pub fn install_for(signals: &[Signal]) -> io::Result<Self> {
        let (read, write) = UnixStream::pair()?;
        read.set_nonblocking(true)?;
        write.set_nonblocking(true)?;
        let mut ids = Vec::new();
        let mut caught = Vec::new();
        for &signal in signals {
            let flag = Arc::new(AtomicBool::new(false));
            // The flag first: once the byte wakes the reader, the flag is already set.
            ids.push(signal_hook::flag::register(
                signal as i32,
                Arc::clone(&flag),
            )?);
            ids.push(signal_hook::low_level::pipe::register(
                signal as i32,
                write.try_clone()?,
            )?);
            caught.push((signal, flag));
        }
        Ok(Self { read, caught, ids })
    }

    /// Whether a stop signal arrived since the last call (consumes it).
    pub fn take(&self) -> bool {
        !self.take_signals().is_empty()
    }

    /// The signals that arrived since the last call, in the order they were installed
    /// (consumes them).
    pub fn take_signals(&self) -> Vec<Signal> {
        let mut buf = [0u8; 64];
        let mut read = &self.read;
        while let Ok(n) = read.read(&mut buf) {
            if n == 0 {
                break;
            }
        }
        self.caught
            .iter()
            .filter(|(_, flag)| flag.swap(false, Ordering::AcqRel))
            .map(|(signal, _)| *signal)
            .collect()
    }
}

impl AsFd for StopSignals {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.read.as_fd()
    }
}

impl Drop for StopSignals {
    fn drop(&mut self) {
        for id in self.ids.drain(..) {
            signal_hook::low_level::unregister(id);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_raised_signal_wakes_the_descriptor_and_is_named_once() {
        let signals = StopSignals::install_for(&[Signal::SIGHUP]).unwrap_or_else(|e| panic!("{e}"));
        assert!(signals.take_signals().is_empty());
        nix::sys::signal::raise(Signal::SIGHUP).unwrap_or_else(|e| panic!("{e}"));
        let mut fds = [rustix::event::PollFd::new(
            &signals,
            rustix::event::PollFlags::IN,
        )];
        let ready = rustix::event::poll(&mut fds, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ready, 1);
        assert_eq!(signals.take_signals(), vec![Signal::SIGHUP]);
        assert!(!signals.take());
    }
}
