//! Waiting on many IPC endpoints and file descriptors at once, with a deadline.
//!
//! Readiness is level-triggered: a source is reported while it has unread data (a
//! subscriber with samples, a server with requests, a client with a reply or a call past its
//! deadline, a readable file descriptor). Blocking uses `ppoll(2)` on the sockets of the
//! iceoryx2 listeners paired with each endpoint, so endpoints are borrowed only for the
//! duration of one wait and can be added or dropped freely between waits.

use std::os::fd::BorrowedFd;
use std::time::{Duration, Instant};

use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::{FileDescriptorBased, ipc};
use nix::errno::Errno;
use nix::poll::{PollFd, PollFlags, ppoll};
use nix::sys::time::TimeSpec;

use super::predict::ArrivalPredictor;

/// The most sources one wait accepts.
pub const MAX_WAIT_SOURCES: usize = 128;

/// How a [`WaitSet`] waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WakeMode {
    /// Block in the kernel until a notification arrives: no CPU while idle, a wake-up
    /// latency of tens of microseconds. What services use by default.
    Event,
    /// Spin on the shared-memory state for up to `spin`, then block like
    /// [`WakeMode::Event`]: data arriving within the spin is seen in well under a
    /// microsecond, at the price of a busy core during the spin.
    Adaptive {
        /// How long to spin before blocking.
        spin: Duration,
    },
    /// Never block: spin until data or the deadline. Lowest latency, one core fully busy.
    /// For hard real-time consumers only.
    BusyPoll,
    /// For one periodic stream (a scan every 27 ms): learn its period from the arrivals,
    /// block until `margin` before the next one is due, spin until it comes (at most
    /// `margin` past its predicted time), then block like [`WakeMode::Event`]. Once the
    /// period is learnt, samples that come on the beat are seen at busy-polling latency for
    /// about `2 * margin / period` of a core. The kernel's timer slack (50 µs by default)
    /// and its scheduling delay make a timed wake-up late, so `margin` must be larger than
    /// both. Until the period is learnt, and for samples off the beat, it behaves like
    /// [`WakeMode::Event`].
    Predictive {
        /// How long before (and after) the predicted arrival to spin.
        margin: Duration,
    },
}

/// Something a [`WaitSet`] can wait on: [`Subscriber`](super::Subscriber),
/// [`CommandServer`](super::CommandServer), [`CommandClient`](super::CommandClient),
/// [`FdSource`].
pub trait Waitable: sealed::Source {}

pub(crate) mod sealed {
    use std::os::fd::BorrowedFd;
    use std::time::Instant;

    /// What the wait loop needs from a source; sealed so that only this crate's endpoints
    /// (whose readiness and wake-up socket agree) can be waited on.
    pub trait Source {
        /// Whether the source has something to take now, without a system call.
        fn is_ready(&self) -> bool;
        /// The descriptor that becomes readable when the source may have become ready.
        fn wake_fd(&self) -> Option<BorrowedFd<'_>>;
        /// Consumes the pending wake-up so that the descriptor blocks again.
        fn drain_wake(&self);
        /// Whether readiness is known only from the descriptor (no shared-memory state).
        fn fd_only(&self) -> bool {
            false
        }
        /// When the source becomes ready by itself (a call's timeout).
        fn deadline(&self) -> Option<Instant> {
            None
        }
    }
}

/// A plain file descriptor to wait on (a device, a signalfd, a pipe): reported when it is
/// readable, hung up or in error. Reading it is the caller's business.
#[derive(Debug, Clone, Copy)]
pub struct FdSource<'fd> {
    fd: BorrowedFd<'fd>,
}

impl<'fd> FdSource<'fd> {
    /// Waits on `fd` for readability.
    pub fn new(fd: BorrowedFd<'fd>) -> Self {
        Self { fd }
    }
}

impl sealed::Source for FdSource<'_> {
    fn is_ready(&self) -> bool {
        false
    }

    fn wake_fd(&self) -> Option<BorrowedFd<'_>> {
        Some(self.fd)
    }

    fn drain_wake(&self) {}

    fn fd_only(&self) -> bool {
        true
    }
}

impl Waitable for FdSource<'_> {}

/// The indices (into the slice given to [`WaitSet::wait`]) of the sources that are ready.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Fired {
    bits: u128,
}

impl Fired {
    /// Whether source `index` is ready.
    pub fn contains(self, index: usize) -> bool {
        index < MAX_WAIT_SOURCES && self.bits & (1 << index) != 0
    }

    /// The ready indices, in increasing order.
    pub fn iter(self) -> impl Iterator<Item = usize> {
        (0..MAX_WAIT_SOURCES).filter(move |i| self.contains(*i))
    }

    /// Whether no source is ready.
    pub fn is_empty(self) -> bool {
        self.bits == 0
    }

    fn insert(&mut self, index: usize) {
        self.bits |= 1 << index;
    }
}

/// Why a wait returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Woken {
    /// These sources are ready.
    Ready(Fired),
    /// The deadline passed with no source ready.
    DeadlineReached,
    /// A signal handler ran (`EINTR`); the caller checks its signal flags and waits again.
    Interrupted,
}

/// Why a wait failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WaitError {
    /// More sources than [`MAX_WAIT_SOURCES`].
    #[error("cannot wait on {count} sources at once: at most {MAX_WAIT_SOURCES}")]
    TooManySources {
        /// How many were given.
        count: usize,
    },
    /// Nothing to wait on and no deadline: the wait would never end.
    #[error("wait on no source without a deadline would never return: give a deadline or a source")]
    NothingToWaitOn,
    /// `ppoll(2)` failed.
    #[error("ppoll failed: {0}")]
    Poll(Errno),
}

/// Waits on many sources at once (see the module documentation). Holds the mode (and, in
/// [`WakeMode::Predictive`], what it learnt of the arrivals): the sources are lent to each
/// call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WaitSet {
    mode: WakeMode,
    arrivals: ArrivalPredictor,
}

/// Spins between two reads of the clock in the spinning modes (the wait set's, and a
/// busy-polling client's own loop).
pub(crate) const SPINS_PER_CLOCK_READ: u32 = 32;
/// Spins between two non-blocking polls of file-descriptor-only sources in busy-poll mode.
const SPINS_PER_FD_POLL: u32 = 1024;

impl WaitSet {
    /// A wait set that waits in `mode`.
    pub fn new(mode: WakeMode) -> Self {
        Self {
            mode,
            arrivals: ArrivalPredictor::default(),
        }
    }

    /// The mode it waits in.
    pub fn mode(&self) -> WakeMode {
        self.mode
    }

    /// Waits until at least one of `sources` is ready or `deadline` passes (`None`: no
    /// deadline of its own; a pending call's timeout still ends the wait). Returns at once
    /// when a source is already ready.
    pub fn wait(
        &self,
        sources: &[&dyn Waitable],
        deadline: Option<Instant>,
    ) -> Result<Woken, WaitError> {
        if sources.len() > MAX_WAIT_SOURCES {
            return Err(WaitError::TooManySources {
                count: sources.len(),
            });
        }
        let deadline = sources
            .iter()
            .filter_map(|s| s.deadline())
            .chain(deadline)
            .min();
        if sources.is_empty() && deadline.is_none() {
            return Err(WaitError::NothingToWaitOn);
        }
        let fired = ready_now(sources);
        if !fired.is_empty() {
            return Ok(Woken::Ready(fired));
        }
        match self.mode {
            WakeMode::Event => block(sources, deadline),
            WakeMode::BusyPoll => spin(sources, deadline, None),
            WakeMode::Adaptive { spin: budget } => {
                let spin_end = Instant::now() + budget;
                match spin(sources, deadline, Some(spin_end))? {
                    Woken::DeadlineReached if deadline.is_none_or(|d| d > spin_end) => {
                        block(sources, deadline)
                    }
                    woken => Ok(woken),
                }
            }
            WakeMode::Predictive { margin } => {
                let woken = self.predictive(sources, deadline, margin)?;
                if matches!(woken, Woken::Ready(_)) {
                    self.arrivals.arrived(Instant::now());
                }
                Ok(woken)
            }
        }
    }

    /// [`WakeMode::Predictive`]: block until the spin window, spin across it, block again.
    fn predictive(
        &self,
        sources: &[&dyn Waitable],
        deadline: Option<Instant>,
        margin: Duration,
    ) -> Result<Woken, WaitError> {
        let Some((spin_from, spin_until)) = self.arrivals.window(margin) else {
            return block(sources, deadline);
        };
        let now = Instant::now();
        if spin_until <= now {
            // Past the window: the sample is late or missed; the next event tells.
            return block(sources, deadline);
        }
        if spin_from > now {
            let until = deadline.map_or(spin_from, |d| d.min(spin_from));
            match block(sources, Some(until))? {
                Woken::DeadlineReached if deadline.is_none_or(|d| d > spin_from) => {}
                woken => return Ok(woken),
            }
        }
        match spin(sources, deadline, Some(spin_until))? {
            Woken::DeadlineReached if deadline.is_none_or(|d| d > spin_until) => {
                block(sources, deadline)
            }
            woken => Ok(woken),
        }
    }
}

/// The sources ready now, from shared memory and deadlines only.
fn ready_now(sources: &[&dyn Waitable]) -> Fired {
    let mut fired = Fired::default();
    for (i, source) in sources.iter().enumerate() {
        if source.is_ready() {
            fired.insert(i);
        }
    }
    fired
}

/// Spins until a source is ready or `until` (the spin budget) or `deadline` passes; both
/// give [`Woken::DeadlineReached`].
fn spin(
    sources: &[&dyn Waitable],
    deadline: Option<Instant>,
    until: Option<Instant>,
) -> Result<Woken, WaitError> {
    let end = match (deadline, until) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let has_fd_only = sources.iter().any(|s| s.fd_only());
    let mut spins: u32 = 0;
    loop {
        let fired = ready_now(sources);
        if !fired.is_empty() {
            return Ok(Woken::Ready(fired));
        }
        spins = spins.wrapping_add(1);
        if has_fd_only
            && spins.is_multiple_of(SPINS_PER_FD_POLL)
            && let Woken::Ready(fired) = poll_once(sources, Some(Duration::ZERO))?
        {
            return Ok(Woken::Ready(fired));
        }
        if spins.is_multiple_of(SPINS_PER_CLOCK_READ) && end.is_some_and(|e| Instant::now() >= e) {
            return Ok(Woken::DeadlineReached);
        }
        std::hint::spin_loop();
    }
}

/// Blocks in `ppoll` until a source is ready or the deadline passes. Wake-ups that leave no
/// source ready (a notification for a sample already taken) are absorbed here.
fn block(sources: &[&dyn Waitable], deadline: Option<Instant>) -> Result<Woken, WaitError> {
    loop {
        let timeout = match deadline {
            None => None,
            Some(d) => match d.checked_duration_since(Instant::now()) {
                Some(left) if !left.is_zero() => Some(left),
                _ => return Ok(Woken::DeadlineReached),
            },
        };
        match poll_once(sources, timeout)? {
            Woken::DeadlineReached => {
                if deadline.is_some_and(|d| Instant::now() >= d) {
                    return Ok(Woken::DeadlineReached);
                }
            }
            woken => return Ok(woken),
        }
    }
}

/// One `ppoll` over the sources' descriptors, then the readiness check.
/// `DeadlineReached` here means only "nothing ready after this poll".
fn poll_once(sources: &[&dyn Waitable], timeout: Option<Duration>) -> Result<Woken, WaitError> {
    let mut index_of = Vec::with_capacity(sources.len());
    let mut fds = Vec::with_capacity(sources.len());
    for (i, source) in sources.iter().enumerate() {
        if let Some(fd) = source.wake_fd() {
            index_of.push(i);
            fds.push(PollFd::new(fd, PollFlags::POLLIN));
        }
    }
    let timeout = timeout.map(TimeSpec::from_duration);
    match ppoll(&mut fds, timeout, None) {
        Ok(_) => {}
        Err(Errno::EINTR) => return Ok(Woken::Interrupted),
        Err(e) => return Err(WaitError::Poll(e)),
    }
    let mut fired = Fired::default();
    for (pollfd, &i) in fds.iter().zip(&index_of) {
        let signalled = pollfd.revents().is_some_and(|r| !r.is_empty());
        if signalled {
            sources[i].drain_wake();
            if sources[i].fd_only() {
                fired.insert(i);
            }
        }
    }
    // Checked for every source, not only the signalled ones: data may have arrived after
    // the poll returned, and a call may have passed its deadline.
    let mut fired_now = ready_now(sources);
    fired_now.bits |= fired.bits;
    if fired_now.is_empty() {
        Ok(Woken::DeadlineReached)
    } else {
        Ok(Woken::Ready(fired_now))
    }
}

/// The socket an iceoryx2 listener is woken through.
pub(crate) fn listener_fd(listener: &Listener<ipc::Service>) -> BorrowedFd<'_> {
    // SAFETY: the descriptor is owned by the listener, stays open and unchanged for the
    // listener's whole life (iceoryx2 documents this), and the returned borrow cannot
    // outlive `listener`.
    unsafe { BorrowedFd::borrow_raw(listener.file_descriptor().native_handle()) }
}

/// Takes all pending notifications of a listener without blocking. A failure (an interrupt)
/// leaves the socket readable, so the next wait simply wakes again.
pub(crate) fn drain_listener(listener: &Listener<ipc::Service>) {
    let _ = listener.try_wait(|_| {});
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fired_reports_exactly_the_inserted_indices() {
        let mut fired = Fired::default();
        for i in [0, 5, 127] {
            fired.insert(i);
        }
        assert_eq!(fired.iter().collect::<Vec<_>>(), vec![0, 5, 127]);
        assert!(!fired.contains(128));
        assert!(!fired.is_empty());
    }

    #[test]
    fn waiting_on_nothing_without_deadline_is_an_error() {
        assert_eq!(
            WaitSet::new(WakeMode::Event).wait(&[], None),
            Err(WaitError::NothingToWaitOn)
        );
    }

    #[test]
    fn waiting_on_nothing_with_a_past_deadline_returns_deadline_reached_in_every_mode() {
        for mode in [
            WakeMode::Event,
            WakeMode::BusyPoll,
            WakeMode::Adaptive {
                spin: Duration::from_micros(10),
            },
            WakeMode::Predictive {
                margin: Duration::from_micros(10),
            },
        ] {
            assert_eq!(
                WaitSet::new(mode).wait(&[], Some(Instant::now())),
                Ok(Woken::DeadlineReached),
                "{mode:?}"
            );
        }
    }

    #[test]
    fn a_readable_pipe_fires_and_an_empty_one_reaches_the_deadline() {
        let (read, write) = nix::unistd::pipe().unwrap();
        let source = FdSource::new(std::os::fd::AsFd::as_fd(&read));
        for mode in [WakeMode::Event, WakeMode::BusyPoll] {
            let ws = WaitSet::new(mode);
            let soon = Instant::now() + Duration::from_millis(1);
            assert_eq!(ws.wait(&[&source], Some(soon)), Ok(Woken::DeadlineReached));
        }
        nix::unistd::write(&write, b"x").unwrap();
        for mode in [WakeMode::Event, WakeMode::BusyPoll] {
            match WaitSet::new(mode).wait(&[&source], None) {
                Ok(Woken::Ready(fired)) => assert!(fired.contains(0)),
                other => panic!("{mode:?}: {other:?}"),
            }
        }
    }
}
