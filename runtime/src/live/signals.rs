//! The one signal catcher of Lewis: the signals that ask a process to stop (SIGTERM and
//! SIGINT, and SIGHUP where a caller wants it) as a file descriptor to wait on (the
//! self-pipe trick). The handler only writes a byte and sets a flag; the event loop sees the
//! socket readable and stops cleanly, knowing which signal asked.
//!
//! A [`StopHandle`] asks the same from inside the process (a goal reached, a mission
//! over): the loop wakes as it would for Ctrl-C, and no thread signals its own process.

use std::io::{self, Read, Write};
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
    handle: StopHandle,
}

/// Asks a [`StopSignals`] holder to stop, from any thread, as a stop signal would.
#[derive(Debug, Clone)]
pub struct StopHandle {
    write: Arc<UnixStream>,
    requested: Arc<AtomicBool>,
}

impl StopHandle {
    /// Asks to stop: the holder's descriptor becomes readable and its next
    /// [`StopSignals::take`] says so.
    pub fn stop(&self) {
        // The flag first: once the byte wakes the reader, the flag is already set.
        self.requested.store(true, Ordering::Release);
        // A full socket already holds a wake-up; nothing else can go wrong that matters.
        let _ = (&*self.write).write(&[1]);
    }

    /// Whether a stop was asked for (and not yet taken).
    #[must_use]
    pub fn is_requested(&self) -> bool {
        self.requested.load(Ordering::Acquire)
    }
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
        let handle = StopHandle {
            write: Arc::new(write),
            requested: Arc::new(AtomicBool::new(false)),
        };
        Ok(Self {
            read,
            caught,
            ids,
            handle,
        })
    }

    /// A handle that stops this holder as a signal would, for other threads.
    #[must_use]
    pub fn handle(&self) -> StopHandle {
        self.handle.clone()
    }

    /// Whether a stop signal arrived or a [`StopHandle`] asked to stop since the last call
    /// (consumes both).
    pub fn take(&self) -> bool {
        let signalled = !self.take_signals().is_empty();
        self.take_requested() || signalled
    }

    /// Whether a [`StopHandle`] asked to stop since the last call (consumes it; signals
    /// stay to be taken).
    pub fn take_requested(&self) -> bool {
        self.handle.requested.swap(false, Ordering::AcqRel)
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

    #[test]
    fn a_stop_handle_wakes_the_descriptor_without_a_signal() {
        let signals = StopSignals::install_for(&[Signal::SIGHUP]).unwrap_or_else(|e| panic!("{e}"));
        let handle = signals.handle();
        std::thread::spawn(move || handle.stop())
            .join()
            .unwrap_or_else(|_| panic!("the stopping thread panicked"));
        let mut fds = [rustix::event::PollFd::new(
            &signals,
            rustix::event::PollFlags::IN,
        )];
        let ready = rustix::event::poll(&mut fds, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ready, 1);
        assert!(signals.take_signals().is_empty(), "no signal was raised");
        assert!(signals.take());
        assert!(!signals.take(), "a request is taken once");
    }
}
