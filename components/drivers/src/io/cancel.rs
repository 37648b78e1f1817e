//! A stop request that interrupts a driver's blocking waits: the read end of a pipe that becomes
//! readable (and stays so) once [`CancelHandle::cancel`] is called, so that a device reader
//! thread blocked in a read or a retry wait ends at once when its owner goes away.

use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::Arc;
use std::time::Duration;

use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

/// What the waiting side holds: cheap to clone, checked or waited on.
#[derive(Debug, Clone)]
pub(crate) struct Cancel(Arc<OwnedFd>);

/// What the owner holds: cancels once, for good.
#[derive(Debug)]
pub(crate) struct CancelHandle(OwnedFd);

/// A new stop request, not cancelled yet.
pub(crate) fn cancel_pair() -> Result<(Cancel, CancelHandle), Errno> {
    let (read, write) = nix::unistd::pipe2(OFlag::O_CLOEXEC | OFlag::O_NONBLOCK)?;
    Ok((Cancel(Arc::new(read)), CancelHandle(write)))
}

impl Cancel {
    /// Whether the stop was asked for.
    pub(crate) fn is_set(&self) -> bool {
        self.wait(Duration::ZERO)
    }

    /// Waits at most `timeout` for the stop; whether it was asked for.
    pub(crate) fn wait(&self, timeout: Duration) -> bool {
        let mut fds = [PollFd::new(self.0.as_fd(), PollFlags::POLLIN)];
        poll_fds(&mut fds, timeout);
        fds[0]
            .revents()
            .is_some_and(|events| events.intersects(PollFlags::POLLIN | PollFlags::POLLHUP))
    }

    /// The descriptor, readable once cancelled, for a caller's own poll.
    pub(crate) fn fd(&self) -> BorrowedFd<'_> {
        self.0.as_fd()
    }
}

impl CancelHandle {
    /// Asks for the stop; every wait on the [`Cancel`] ends from now on.
    pub(crate) fn cancel(&self) {
        // A full pipe is readable already: the error is harmless.
        let _ = nix::unistd::write(&self.0, &[1]);
    }
}

/// Polls `fds` for at most `timeout` (rounded up to a millisecond, so that a wait never ends
/// early and spins); an interrupted poll counts as a wake-up.
pub(crate) fn poll_fds(fds: &mut [PollFd<'_>], timeout: Duration) {
    let millis = timeout.as_nanos().div_ceil(1_000_000);
    let timeout = PollTimeout::try_from(u32::try_from(millis).unwrap_or(u32::MAX))
        .unwrap_or(PollTimeout::MAX);
    // EINTR and the like: the caller looks at the clock and the revents and goes on.
    let _ = poll(fds, timeout);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cancel_ends_every_wait_from_then_on() {
        let (cancel, handle) = cancel_pair().unwrap();
        assert!(!cancel.is_set());
        assert!(!cancel.wait(Duration::from_millis(1)));
        let other = cancel.clone();
        handle.cancel();
        assert!(cancel.is_set() && other.is_set());
        assert!(
            cancel.wait(Duration::from_secs(3600)),
            "at once, not in an hour"
        );
    }

    #[test]
    fn dropping_the_handle_cancels_too() {
        let (cancel, handle) = cancel_pair().unwrap();
        drop(handle);
        assert!(cancel.is_set(), "a closed pipe reads as hung up");
    }
}
