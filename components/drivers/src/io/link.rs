//! A driver's serial link: the open port (or none while the device is away), reads bounded by a
//! timeout (and ended early by a [`Cancel`], for a device reader whose owner goes away),
//! writes, and the reason the link went down.

use std::io::{Read, Write};
use std::os::fd::{AsRawFd, BorrowedFd};
use std::path::{Path, PathBuf};
use std::time::Duration;

use nix::poll::{PollFd, PollFlags};
use serialport::{ClearBuffer, SerialPort, TTYPort};

use super::cancel::{Cancel, poll_fds};
use super::port::{LineParity, PortError, open_port, set_baud};

/// How long a write may wait for room in the port's buffer.
const WRITE_TIMEOUT: Duration = Duration::from_secs(1);

/// The port went away or failed: the reason, for health reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct LinkDown {
    pub(crate) reason: String,
    /// The owner asked the reader to stop: the port is still open and fine.
    pub(crate) stopped: bool,
}

/// A serial port that may be closed (device away) and reopened at the same path.
#[derive(Debug)]
pub(crate) struct SerialLink {
    path: PathBuf,
    parity: LineParity,
    baud_bps: u32,
    port: Option<TTYPort>,
    cancel: Option<Cancel>,
}

impl SerialLink {
    /// Opens `path`.
    pub(crate) fn open(path: &Path, baud_bps: u32, parity: LineParity) -> Result<Self, PortError> {
        let port = open_port(path, baud_bps, parity)?;
        Ok(Self {
            path: path.to_path_buf(),
            parity,
            baud_bps,
            port: Some(port),
            cancel: None,
        })
    }

    /// Makes reads end as soon as `cancel` is set, with [`LinkDown::stopped`].
    pub(crate) fn set_cancel(&mut self, cancel: Option<Cancel>) {
        self.cancel = cancel;
    }

    /// The speed last set.
    pub(crate) fn baud_bps(&self) -> u32 {
        self.baud_bps
    }

    /// Whether the port is open.
    pub(crate) fn is_open(&self) -> bool {
        self.port.is_some()
    }

    /// The open port's descriptor, for a caller's poll.
    pub(crate) fn fd(&self) -> Option<BorrowedFd<'_>> {
        self.port.as_ref().map(|port| {
            // SAFETY: the port owns this descriptor and keeps it open while borrowed: the
            // result cannot outlive `&self`, and closing the port needs `&mut self`.
            unsafe { BorrowedFd::borrow_raw(port.as_raw_fd()) }
        })
    }

    /// Opens the port again at `baud_bps` after it went down.
    pub(crate) fn reopen(&mut self, baud_bps: u32) -> Result<(), PortError> {
        self.port = None;
        self.port = Some(open_port(&self.path, baud_bps, self.parity)?);
        self.baud_bps = baud_bps;
        Ok(())
    }

    /// Closes the port (the device went away).
    pub(crate) fn close(&mut self) {
        self.port = None;
    }

    /// Changes the speed; a failure closes the link.
    pub(crate) fn set_baud(&mut self, baud_bps: u32) -> Result<(), LinkDown> {
        let path = self.path.clone();
        let port = self.port_mut()?;
        let result = set_baud(port, &path, baud_bps);
        match result {
            Ok(()) => {
                self.baud_bps = baud_bps;
                Ok(())
            }
            Err(error) => Err(self.down(&error.to_string())),
        }
    }

    /// Drops whatever the device sent that was not read yet.
    pub(crate) fn clear_input(&mut self) -> Result<(), LinkDown> {
        let port = self.port_mut()?;
        match port.clear(ClearBuffer::Input) {
            Ok(()) => Ok(()),
            Err(error) => Err(self.down(&format!("cannot clear the input: {error}"))),
        }
    }

    /// Writes all of `bytes`; a failure closes the link.
    pub(crate) fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkDown> {
        let port = self.port_mut()?;
        let result = port
            .set_timeout(WRITE_TIMEOUT)
            .map_err(std::io::Error::from)
            .and_then(|()| port.write_all(bytes));
        result.map_err(|error| self.down(&format!("write failed: {error}")))
    }

    /// Reads what arrives within `timeout` into `buf`: the byte count, 0 when nothing came.
    /// A hang-up or an error closes the link.
    pub(crate) fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkDown> {
        let cancel = self.cancel.clone();
        let path = self.path.clone();
        let port = self.port_mut()?;
        let mut timeout = timeout;
        if let Some(cancel) = cancel {
            let port_fd = port.as_raw_fd();
            // SAFETY: the port owns the descriptor and outlives this borrow.
            let port_fd = unsafe { BorrowedFd::borrow_raw(port_fd) };
            let mut fds = [
                PollFd::new(port_fd, PollFlags::POLLIN),
                PollFd::new(cancel.fd(), PollFlags::POLLIN),
            ];
            poll_fds(&mut fds, timeout);
            if fds[1].revents().is_some_and(|events| !events.is_empty()) {
                return Err(LinkDown {
                    reason: format!("{}: the reader was stopped", path.display()),
                    stopped: true,
                });
            }
            if fds[0].revents().is_none_or(|events| events.is_empty()) {
                return Ok(0);
            }
            // Readable (or hung up): the read below does not wait.
            timeout = Duration::ZERO;
        }
        let result = port
            .set_timeout(timeout)
            .map_err(std::io::Error::from)
            .and_then(|()| port.read(buf));
        match result {
            Ok(0) => Err(self.down("the device hung up (end of file)")),
            Ok(count) => Ok(count),
            Err(error) if error.kind() == std::io::ErrorKind::TimedOut => Ok(0),
            Err(error) if error.kind() == std::io::ErrorKind::Interrupted => Ok(0),
            Err(error) if error.kind() == std::io::ErrorKind::BrokenPipe => {
                Err(self.down("the device hung up (unplugged?)"))
            }
            Err(error) => Err(self.down(&format!("read failed: {error}"))),
        }
    }

    fn port_mut(&mut self) -> Result<&mut TTYPort, LinkDown> {
        self.port.as_mut().ok_or_else(|| LinkDown {
            reason: format!("{} is not open", self.path.display()),
            stopped: false,
        })
    }

    fn down(&mut self, reason: &str) -> LinkDown {
        self.port = None;
        LinkDown {
            reason: format!("{}: {reason}", self.path.display()),
            stopped: false,
        }
    }
}
