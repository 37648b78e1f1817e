//! SIGTERM and SIGINT as a file descriptor to wait on (the self-pipe trick): the handler
//! only writes a byte, the event loop sees the socket readable and stops cleanly.

use std::io::{self, Read};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;

use signal_hook::SigId;
use signal_hook::consts::{SIGINT, SIGTERM};

/// Catches SIGTERM and SIGINT while it lives.
#[derive(Debug)]
pub struct StopSignals {
    read: UnixStream,
    ids: Vec<SigId>,
}

impl StopSignals {
    /// Installs the handlers.
    ///
    /// # Errors
    /// When the socket pair or the handlers cannot be made.
    pub fn install() -> io::Result<Self> {
        let (read, write) = UnixStream::pair()?;
        read.set_nonblocking(true)?;
        let mut ids = Vec::new();
        for signal in [SIGTERM, SIGINT] {
            ids.push(signal_hook::low_level::pipe::register(
                signal,
                write.try_clone()?,
            )?);
        }
        Ok(Self { read, ids })
    }

    /// Whether a stop signal arrived since the last call (consumes it).
    pub fn take(&self) -> bool {
        let mut buf = [0u8; 64];
        let mut got = false;
        let mut read = &self.read;
        while let Ok(n) = read.read(&mut buf) {
            if n == 0 {
                break;
            }
            got = true;
        }
        got
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
