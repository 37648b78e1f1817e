//! A pseudo-terminal pair for a device emulator: the emulator reads and writes the master, a
//! driver opens the slave like a serial port, optionally through a symbolic link at a chosen
//! path (like socat's `link=`).
//!
//! The slave is put in raw mode at once (a fresh pseudo-terminal echoes and buffers lines,
//! which would turn the emulator's output into its own input) and the emulator keeps a slave
//! descriptor open, so that the master never reports a hang-up while no driver has the port
//! open. Kernel facts this relies on, checked on Linux 6.x: the master's `TCGETS2` returns the
//! slave's termios, so the emulator sees the baud rate the driver set (rates are not enforced
//! on a pseudo-terminal, the emulator compares them in software); parity cannot be set on a
//! pseudo-terminal (the kernel clears `PARENB`), so 8E1 cannot be told from 8N1 here.

use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};
use std::path::{Path, PathBuf};

use nix::errno::Errno;
use nix::fcntl::{FcntlArg, FdFlag, OFlag, fcntl};
use nix::sys::termios::{self, SetArg};

/// Why a pseudo-terminal could not be made or linked.
#[derive(Debug, thiserror::Error)]
pub enum PtyError {
    /// The kernel refused a new pseudo-terminal.
    #[error(
        "cannot open a pseudo-terminal: {errno}: check /dev/ptmx and the limit in /proc/sys/kernel/pty/max"
    )]
    Open {
        /// The error of `openpty`.
        errno: Errno,
    },
    /// The terminal settings could not be read or set.
    #[error("cannot {operation} on the pseudo-terminal: {errno}")]
    Setup {
        /// What was being done.
        operation: &'static str,
        /// The error.
        errno: Errno,
    },
    /// The link path is taken by something that is not a symbolic link.
    #[error("{link} exists and is not a symbolic link: remove it or choose another --pty path")]
    LinkOccupied {
        /// The requested link path.
        link: PathBuf,
    },
    /// The link could not be created.
    #[error(
        "cannot create the link {link} to {target}: {source}: check that its folder exists and is writable"
    )]
    Link {
        /// The requested link path.
        link: PathBuf,
        /// The slave's path.
        target: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// An open pseudo-terminal pair, with its optional link. Dropping it closes both sides (the
/// driver sees a hang-up, as when a cable is pulled) and removes the link.
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    /// Held so that the master never sees a hang-up while no driver has the port open.
    _slave: OwnedFd,
    slave_path: PathBuf,
    link: Option<PathBuf>,
}

impl Pty {
    /// Opens a pair with the slave raw at 9600 baud and the master non-blocking; when `link` is
    /// given, points a symbolic link there at the slave (replacing an older link atomically).
    pub fn open(link: Option<&Path>) -> Result<Self, PtyError> {
        let pair = nix::pty::openpty(None, None).map_err(|errno| PtyError::Open { errno })?;
        let setup = |operation: &'static str| move |errno| PtyError::Setup { operation, errno };
        for fd in [&pair.master, &pair.slave] {
            fcntl(fd, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).map_err(setup("set close-on-exec"))?;
        }
        fcntl(&pair.master, FcntlArg::F_SETFL(OFlag::O_NONBLOCK))
            .map_err(setup("make the master non-blocking"))?;
        let mut settings = termios::tcgetattr(&pair.slave).map_err(setup("read the termios"))?;
        termios::cfmakeraw(&mut settings);
        termios::cfsetspeed(&mut settings, termios::BaudRate::B9600)
            .map_err(setup("set the speed"))?;
        termios::tcsetattr(&pair.slave, SetArg::TCSANOW, &settings)
            .map_err(setup("set raw mode"))?;
        let slave_path =
            nix::unistd::ttyname(&pair.slave).map_err(setup("find the slave's name"))?;
        let pty = Self {
            master: pair.master,
            _slave: pair.slave,
            slave_path,
            link: None,
        };
        match link {
            Some(link) => pty.linked(link),
            None => Ok(pty),
        }
    }

    fn linked(mut self, link: &Path) -> Result<Self, PtyError> {
        if let Ok(metadata) = std::fs::symlink_metadata(link)
            && !metadata.file_type().is_symlink()
        {
            return Err(PtyError::LinkOccupied {
                link: link.to_path_buf(),
            });
        }
        let link_error = |source| PtyError::Link {
            link: link.to_path_buf(),
            target: self.slave_path.clone(),
            source,
        };
        let mut temporary = link.as_os_str().to_owned();
        temporary.push(format!(".{}.new", std::process::id()));
        let temporary = PathBuf::from(temporary);
        let _ = std::fs::remove_file(&temporary);
        std::os::unix::fs::symlink(&self.slave_path, &temporary).map_err(link_error)?;
        // A rename replaces the old link in one step: a driver reopening the path never finds
        // it missing or half made.
        if let Err(error) = std::fs::rename(&temporary, link) {
            let _ = std::fs::remove_file(&temporary);
            return Err(link_error(error));
        }
        self.link = Some(link.to_path_buf());
        Ok(self)
    }

    /// The master side, which the emulator reads and writes.
    pub fn master(&self) -> BorrowedFd<'_> {
        self.master.as_fd()
    }

    /// The slave's device path (`/dev/pts/N`).
    pub fn slave_path(&self) -> &Path {
        &self.slave_path
    }

    /// The path a driver should open: the link if there is one, else the slave.
    pub fn path(&self) -> &Path {
        self.link.as_deref().unwrap_or(&self.slave_path)
    }

    /// The baud rate the driver last set on the slave, in bits per second, or `None` when it
    /// cannot be read (or the speed is 0, the hang-up rate).
    pub fn host_baud_bps(&self) -> Option<u32> {
        host_baud_bps(self.master.as_raw_fd())
    }
}

impl Drop for Pty {
    fn drop(&mut self) {
        // Only our own link goes: another emulator may have re-pointed the path since.
        if let Some(link) = &self.link
            && std::fs::read_link(link).is_ok_and(|target| target == self.slave_path)
        {
            let _ = std::fs::remove_file(link);
        }
    }
}

#[cfg(target_os = "linux")]
fn host_baud_bps(fd: std::os::fd::RawFd) -> Option<u32> {
    use nix::libc;
    let mut settings = std::mem::MaybeUninit::<libc::termios2>::zeroed();
    // SAFETY: TCGETS2 writes one `termios2` through the pointer, which points to enough
    // writable memory; `fd` is open for the duration of the call (borrowed from `self`).
    let result = unsafe { libc::ioctl(fd, libc::TCGETS2, settings.as_mut_ptr()) };
    if result != 0 {
        return None;
    }
    // SAFETY: the ioctl succeeded, so the kernel filled the struct (and it was zeroed before).
    let settings = unsafe { settings.assume_init() };
    (settings.c_ospeed > 0).then_some(settings.c_ospeed)
}

#[cfg(not(target_os = "linux"))]
fn host_baud_bps(_fd: std::os::fd::RawFd) -> Option<u32> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_master_sees_the_speed_set_on_the_slave() {
        let pty = Pty::open(None).unwrap();
        assert_eq!(pty.host_baud_bps(), Some(9600));
        let port = serialport::new(pty.slave_path().to_string_lossy(), 500_000)
            .open_native()
            .unwrap();
        assert_eq!(pty.host_baud_bps(), Some(500_000));
        drop(port);
    }

    #[test]
    fn a_link_points_at_the_slave_and_goes_with_the_pty() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("ttyFAKE");
        let pty = Pty::open(Some(&link)).unwrap();
        assert_eq!(pty.path(), link);
        assert_eq!(std::fs::read_link(&link).unwrap(), pty.slave_path());
        drop(pty);
        assert!(std::fs::symlink_metadata(&link).is_err());
    }

    #[test]
    fn a_regular_file_at_the_link_path_is_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("precious");
        std::fs::write(&link, "data").unwrap();
        let error = Pty::open(Some(&link)).unwrap_err();
        assert!(matches!(error, PtyError::LinkOccupied { .. }), "{error}");
        assert_eq!(std::fs::read_to_string(&link).unwrap(), "data");
    }
}
