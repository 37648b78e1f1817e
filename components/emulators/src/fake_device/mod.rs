//! Device emulators on pseudo-terminals: a pure device state machine ([`Emulated`]) driven by
//! a thread that waits in `poll` on the master side and on a wake-up pipe, with a timeout to
//! the device's next event (scan, report, watchdog): no busy waiting.
//!
//! What the line does is emulated in software, since a pseudo-terminal moves bytes at any
//! speed: bytes the host sends at another baud rate than the device's are garbage to the
//! device, and bytes the device sends while the host's port is at another rate reach the host
//! as garbage (about as many bytes as the host's rate allows in the same time). Output that
//! the host does not read is queued up to a bound and then dropped, as on a wire.
//!
//! # Which rate the host's bytes were sent at
//!
//! A pseudo-terminal keeps no rate per byte: the emulator can only read the host's termios,
//! and it reads it when it reads the bytes, which may be after the host has moved on to
//! another rate (a host that probes writes at one rate, waits for a reply, changes the rate
//! and writes again; an emulator thread held up for longer than that wait reads both writes
//! at once). So the emulator reads the termios at every read and gives the device both the
//! rate of its previous read and the rate now ([`HostRates`]): the bytes of one read were
//! sent at one of them, or at both, when the host changed its rate once in between. A device
//! hears a telegram when either rate is its own.
//!
//! The guarantee, whatever the scheduling of the emulator thread: **a telegram sent at the
//! device's rate is always heard** as long as the host changed its rate at most once between
//! writing it and the emulator reading it (a host that waits for a reply or a reply timeout
//! after every write, as every SICK and RFlex host does, changes it once per wait); **a
//! telegram sent at another rate is ignored**, except right after the host left the device's
//! rate (the first read after the change), when the device may hear it and answer: at its own
//! rate, which the host, now at another, receives as garbage, as it would from a real device
//! answering late. The replies are garbled by the host's rate when they are written, which
//! is when a real host would receive them.
//!
//! The handle ([`FakeDevice`]) shares the device with the thread: tests and tools inspect it
//! ([`FakeDevice::with_device`]), wait for a state ([`FakeDevice::wait_for`], woken at every
//! step of the thread), change faults, and unplug and replug the port.

mod rflex;
mod sick;

pub use rflex::{FakeRflex, RflexEmulation, RflexEmulatorOptions};
pub use sick::{FakeSick, SickEmulation};

use std::collections::VecDeque;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::poll::{PollFd, PollFlags, PollTimeout, poll};

use lewis_service::NoiseBytes;

use crate::clock::MonotonicClock;
use crate::fault_spec::Unplug;
use crate::pty::{Pty, PtyError};

/// Output queued for the host beyond this is dropped (the host is not reading).
const OUTPUT_LIMIT: usize = 64 * 1024;
/// The host bytes kept for inspection ([`FakeDevice::host_bytes`]): the most recent ones.
const HOST_LOG_LIMIT: usize = 64 * 1024;
/// How long unplugging or replugging may take before the handle gives up.
const PLUG_TIMEOUT: Duration = Duration::from_secs(5);

/// A device state machine as the emulator thread drives it. Time is the emulator's monotonic
/// clock in nanoseconds.
pub trait Emulated: Send + 'static {
    /// What [`FakeDevice::with_device`] exposes.
    type Device;

    /// The device, for inspection and control.
    fn device(&mut self) -> &mut Self::Device;

    /// The baud rate the device talks and listens at now.
    fn line_bps(&self) -> u32;

    /// Takes bytes from the host, sent at one of `host` (see the module documentation), and
    /// returns the reply bytes, which go out at the rate [`Emulated::line_bps`] gave before
    /// this call.
    fn receive(&mut self, host: HostRates, bytes: &[u8], now_ns: i64) -> Vec<u8>;

    /// Returns what is due by `now_ns` (scans, reports).
    fn tick(&mut self, now_ns: i64) -> Vec<u8>;

    /// When [`Emulated::tick`] next has something to do.
    fn next_event_ns(&self) -> Option<i64>;

    /// The port was plugged back in.
    fn replugged(&mut self, now_ns: i64);
}

/// The rates the host's port may have had when it wrote the bytes of one read: the rate the
/// emulator saw at its previous read and the rate now (`None`: unknown, or the hang-up rate 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HostRates {
    /// The host's rate at the emulator's previous read (or when the port was opened).
    pub before_bps: Option<u32>,
    /// The host's rate now.
    pub now_bps: Option<u32>,
}

impl HostRates {
    /// The host has stayed at `bps`.
    pub fn steady(bps: u32) -> Self {
        Self {
            before_bps: Some(bps),
            now_bps: Some(bps),
        }
    }

    /// Whether the bytes may have been sent at `bps`.
    pub fn includes(self, bps: u32) -> bool {
        self.before_bps == Some(bps) || self.now_bps == Some(bps)
    }
}

/// Why an emulator could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum FakeDeviceError {
    /// The pseudo-terminal could not be made or linked.
    #[error(transparent)]
    Pty(#[from] PtyError),
    /// A system call of the emulator failed.
    #[error("fake device: cannot {operation}: {errno}")]
    Io {
        /// What was being done.
        operation: &'static str,
        /// The error.
        errno: Errno,
    },
    /// The emulator thread ended on an error, given here.
    #[error("fake device stopped: {message}")]
    Stopped {
        /// The error that stopped it.
        message: String,
    },
    /// The emulator did not do what was asked in time.
    #[error("fake device did not {what} within {timeout:?}")]
    Timeout {
        /// What was asked.
        what: &'static str,
        /// How long the handle waited.
        timeout: Duration,
    },
    /// The emulator thread panicked (a bug).
    #[error("fake device thread panicked")]
    Panicked,
}

/// Counters of the emulator's line.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EmulatorStats {
    /// Bytes read from the host.
    pub bytes_from_host: u64,
    /// Bytes written towards the host (garbage included).
    pub bytes_to_host: u64,
    /// Device bytes that went out while the host's port was at another rate (sent as garbage).
    pub bytes_garbled: u64,
    /// Device bytes dropped: queue full (host not reading) or port unplugged.
    pub bytes_dropped: u64,
    /// The baud rate the host's port was last seen at.
    pub host_baud_bps: Option<u32>,
    /// Whether the port is plugged in.
    pub plugged: bool,
    /// Times the port was plugged back in.
    pub replugs: u64,
}

struct State<E> {
    emulation: E,
    stats: EmulatorStats,
    host_log: VecDeque<u8>,
    path: PathBuf,
    plug_request: Option<bool>,
    /// Plugging changes due at emulator times (ns), in time order.
    plug_schedule: VecDeque<(i64, bool)>,
    stop: bool,
    failure: Option<String>,
}

struct Shared<E> {
    state: Mutex<State<E>>,
    changed: Condvar,
}

impl<E> Shared<E> {
    fn lock(&self) -> MutexGuard<'_, State<E>> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A running emulator: a device behind a pseudo-terminal, served by its own thread until
/// [`FakeDevice::stop`] or drop.
pub struct FakeDevice<E: Emulated> {
    shared: Arc<Shared<E>>,
    wake: OwnedFd,
    thread: Option<JoinHandle<Result<(), FakeDeviceError>>>,
}

impl<E: Emulated> FakeDevice<E> {
    /// Opens a pseudo-terminal (linked at `link` if given) and starts serving `emulation` on
    /// it; `clock` is the clock the emulation's times come from.
    pub fn spawn(
        clock: MonotonicClock,
        emulation: E,
        link: Option<&Path>,
    ) -> Result<Self, FakeDeviceError> {
        let pty = Pty::open(link)?;
        // Read here, before any host can have opened the port: the thread may start late.
        let opened_bps = pty.host_baud_bps();
        let (wake_rx, wake_tx) =
            nix::unistd::pipe2(OFlag::O_CLOEXEC | OFlag::O_NONBLOCK).map_err(|errno| {
                FakeDeviceError::Io {
                    operation: "make the wake-up pipe",
                    errno,
                }
            })?;
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                emulation,
                stats: EmulatorStats {
                    plugged: true,
                    ..EmulatorStats::default()
                },
                host_log: VecDeque::new(),
                path: pty.path().to_path_buf(),
                plug_request: None,
                plug_schedule: VecDeque::new(),
                stop: false,
                failure: None,
            }),
            changed: Condvar::new(),
        });
        let runner = Runner {
            shared: Arc::clone(&shared),
            clock,
            link: link.map(Path::to_path_buf),
            wake: wake_rx,
            output: Output::default(),
        };
        let thread = std::thread::Builder::new()
            .name("fake-device".to_owned())
            .spawn(move || runner.run(pty, opened_bps))
            .map_err(|error| FakeDeviceError::Stopped {
                message: format!("cannot start the emulator thread: {error}"),
            })?;
        Ok(Self {
            shared,
            wake: wake_tx,
            thread: Some(thread),
        })
    }

    /// The path a driver opens: the link if one was asked for, else the slave
    /// (`/dev/pts/N`, which changes when the port is replugged).
    pub fn path(&self) -> PathBuf {
        self.shared.lock().path.clone()
    }

    /// Runs `f` on the device (the emulator thread waits meanwhile), then wakes the thread so
    /// that a change (faults, a bumper press) takes effect at once.
    pub fn with_device<R>(&self, f: impl FnOnce(&mut E::Device) -> R) -> R {
        let result = f(self.shared.lock().emulation.device());
        self.wake();
        result
    }

    /// Waits until `done` holds for the device, at most `timeout`; whether it held. The
    /// predicate is checked after every step of the emulator thread.
    pub fn wait_for(
        &self,
        timeout: Duration,
        mut done: impl FnMut(&mut E::Device) -> bool,
    ) -> bool {
        self.wait_state(timeout, |state| done(state.emulation.device()))
    }

    /// Waits until `done` holds for the line's counters (plugging included), at most
    /// `timeout`; whether it held. Checked after every step of the emulator thread.
    pub fn wait_stats(
        &self,
        timeout: Duration,
        mut done: impl FnMut(&EmulatorStats) -> bool,
    ) -> bool {
        self.wait_state(timeout, |state| done(&state.stats))
    }

    /// Waits until `done` holds for the shared state, at most `timeout` or until the
    /// emulator thread failed; whether it held. Checked after every step of the thread.
    fn wait_state(&self, timeout: Duration, mut done: impl FnMut(&mut State<E>) -> bool) -> bool {
        let deadline = Instant::now() + timeout;
        let mut state = self.shared.lock();
        loop {
            if done(&mut state) {
                return true;
            }
            let now = Instant::now();
            if now >= deadline || state.failure.is_some() {
                return false;
            }
            state = self
                .shared
                .changed
                .wait_timeout(state, deadline - now)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }

    /// The line's counters.
    pub fn stats(&self) -> EmulatorStats {
        self.shared.lock().stats.clone()
    }

    /// The most recent bytes received from the host (up to 64 KiB), oldest first.
    pub fn host_bytes(&self) -> Vec<u8> {
        self.shared.lock().host_log.iter().copied().collect()
    }

    /// Forgets the host bytes received so far.
    pub fn clear_host_bytes(&self) {
        self.shared.lock().host_log.clear();
    }

    /// The error that stopped the emulator thread, if it stopped on one.
    pub fn failure(&self) -> Option<String> {
        self.shared.lock().failure.clone()
    }

    /// Pulls the cable: closes the pseudo-terminal (the driver sees a hang-up) and removes the
    /// link; returns once done.
    pub fn unplug(&self) -> Result<(), FakeDeviceError> {
        self.request_plug(false, "unplug")
    }

    /// Plugs the cable back in: a new pseudo-terminal, at the same link path if there is one.
    pub fn replug(&self) -> Result<(), FakeDeviceError> {
        self.request_plug(true, "replug")
    }

    /// Pulls the cable at the start of each window and puts it back at its end (never, for a
    /// window without one), counted from the emulator's start; replaces an earlier schedule.
    pub fn schedule_unplugs(&self, unplugs: &[Unplug]) {
        let nanos = |time: Duration| i64::try_from(time.as_nanos()).unwrap_or(i64::MAX);
        let mut changes: Vec<(i64, bool)> = Vec::new();
        for unplug in unplugs {
            changes.push((nanos(unplug.at), false));
            if let Some(until) = unplug.until {
                changes.push((nanos(until), true));
            }
        }
        changes.sort_by_key(|&(at, _)| at);
        self.shared.lock().plug_schedule = changes.into();
        self.wake();
    }

    /// Stops the thread and closes the port; reports an error that had stopped the thread.
    pub fn stop(mut self) -> Result<(), FakeDeviceError> {
        self.shutdown()
    }

    /// Waits until the emulator thread ends on its own (an error), for a tool that runs the
    /// emulator until it is killed.
    pub fn join(mut self) -> Result<(), FakeDeviceError> {
        match self.thread.take() {
            Some(thread) => thread.join().unwrap_or(Err(FakeDeviceError::Panicked)),
            None => Ok(()),
        }
    }

    fn request_plug(&self, plugged: bool, what: &'static str) -> Result<(), FakeDeviceError> {
        self.shared.lock().plug_request = Some(plugged);
        self.wake();
        let deadline = Instant::now() + PLUG_TIMEOUT;
        let mut state = self.shared.lock();
        loop {
            if let Some(message) = &state.failure {
                return Err(FakeDeviceError::Stopped {
                    message: message.clone(),
                });
            }
            if state.plug_request.is_none() && state.stats.plugged == plugged {
                return Ok(());
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(FakeDeviceError::Timeout {
                    what,
                    timeout: PLUG_TIMEOUT,
                });
            }
            state = self
                .shared
                .changed
                .wait_timeout(state, deadline - now)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }

    fn wake(&self) {
        // A full pipe already holds a wake-up: the error is harmless.
        let _ = nix::unistd::write(&self.wake, &[1]);
    }

    fn shutdown(&mut self) -> Result<(), FakeDeviceError> {
        self.shared.lock().stop = true;
        self.wake();
        match self.thread.take() {
            Some(thread) => thread.join().unwrap_or(Err(FakeDeviceError::Panicked)),
            None => Ok(()),
        }
    }
}

impl<E: Emulated> Drop for FakeDevice<E> {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

impl<E: Emulated> std::fmt::Debug for FakeDevice<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FakeDevice")
            .field("path", &self.path())
            .field("stats", &self.stats())
            .finish_non_exhaustive()
    }
}

/// The emulator thread's side.
struct Runner<E> {
    shared: Arc<Shared<E>>,
    clock: MonotonicClock,
    link: Option<PathBuf>,
    wake: OwnedFd,
    output: Output,
}

impl<E: Emulated> Runner<E> {
    fn run(mut self, pty: Pty, opened_bps: Option<u32>) -> Result<(), FakeDeviceError> {
        let result = self.serve(Some(pty), opened_bps);
        if let Err(error) = &result {
            self.shared.lock().failure = Some(error.to_string());
        }
        self.shared.changed.notify_all();
        result
    }

    /// Serves the device; `opened_bps` is the rate the port had when it was made.
    fn serve(
        &mut self,
        mut pty: Option<Pty>,
        opened_bps: Option<u32>,
    ) -> Result<(), FakeDeviceError> {
        let mut received = Vec::new();
        // The host's rate at the previous read: what bytes read next may have been sent at.
        let mut read_bps = opened_bps;
        loop {
            let now_ns = self.clock.now_ns();
            let next_ns = {
                let mut state = self.shared.lock();
                if state.stop {
                    return Ok(());
                }
                if state.plug_request.is_none()
                    && let Some(&(at_ns, plugged)) = state.plug_schedule.front()
                    && at_ns <= now_ns
                {
                    state.plug_schedule.pop_front();
                    state.plug_request = Some(plugged);
                }
                if let Some(plugged) = state.plug_request.take() {
                    if plugged && pty.is_none() {
                        let fresh = Pty::open(self.link.as_deref())?;
                        state.path = fresh.path().to_path_buf();
                        state.emulation.replugged(now_ns);
                        state.stats.replugs += 1;
                        read_bps = fresh.host_baud_bps();
                        pty = Some(fresh);
                    } else if !plugged {
                        pty = None;
                        state.stats.bytes_dropped += self.output.clear();
                    }
                    state.stats.plugged = pty.is_some();
                }
                let (written, garbled) = self.output.take_counts();
                state.stats.bytes_to_host += written;
                state.stats.bytes_garbled += garbled;
                let next_ns = match &pty {
                    Some(pty) => {
                        let host_bps = pty.host_baud_bps();
                        state.stats.host_baud_bps = host_bps;
                        let line_bps = state.emulation.line_bps();
                        let bytes = state.emulation.tick(now_ns);
                        self.output.push(&mut state.stats, &bytes, line_bps);
                        state.emulation.next_event_ns()
                    }
                    // Nothing moves while unplugged: wait for the handle or the schedule.
                    None => None,
                };
                let next_plug_ns = state.plug_schedule.front().map(|&(at_ns, _)| at_ns);
                self.shared.changed.notify_all();
                next_ns.into_iter().chain(next_plug_ns).min()
            };
            if let Some(pty) = &pty {
                self.output.write(pty.master(), pty.host_baud_bps())?;
            }
            let master_events = self.wait(pty.as_ref(), poll_timeout(next_ns, now_ns))?;
            drain(self.wake.as_fd());
            let (Some(pty), Some(events)) = (&pty, master_events) else {
                continue;
            };
            if events.intersects(PollFlags::POLLERR | PollFlags::POLLHUP | PollFlags::POLLNVAL) {
                // The emulator holds a slave descriptor, so this is not a host hanging up.
                return Err(FakeDeviceError::Io {
                    operation: "poll the pseudo-terminal",
                    errno: Errno::EIO,
                });
            }
            if events.contains(PollFlags::POLLIN) {
                read_available(pty.master(), &mut received)?;
                if !received.is_empty() {
                    let now_ns = self.clock.now_ns();
                    let mut state = self.shared.lock();
                    let host_bps = pty.host_baud_bps();
                    state.stats.host_baud_bps = host_bps;
                    state.stats.bytes_from_host += received.len() as u64;
                    state.host_log.extend(received.iter().copied());
                    let excess = state.host_log.len().saturating_sub(HOST_LOG_LIMIT);
                    state.host_log.drain(..excess);
                    let line_bps = state.emulation.line_bps();
                    let host = HostRates {
                        before_bps: read_bps,
                        now_bps: host_bps,
                    };
                    read_bps = host_bps;
                    let reply = state.emulation.receive(host, &received, now_ns);
                    self.output.push(&mut state.stats, &reply, line_bps);
                }
            }
        }
    }

    /// Waits for the wake-up pipe, the master (readable, or writable while output is queued)
    /// or the timeout; returns the master's events.
    fn wait(
        &self,
        pty: Option<&Pty>,
        timeout: PollTimeout,
    ) -> Result<Option<PollFlags>, FakeDeviceError> {
        let mut fds = vec![PollFd::new(self.wake.as_fd(), PollFlags::POLLIN)];
        if let Some(pty) = pty {
            let mut events = PollFlags::POLLIN;
            if !self.output.is_empty() {
                events |= PollFlags::POLLOUT;
            }
            fds.push(PollFd::new(pty.master(), events));
        }
        match poll(&mut fds, timeout) {
            Ok(_) | Err(Errno::EINTR) => {}
            Err(errno) => {
                return Err(FakeDeviceError::Io {
                    operation: "poll",
                    errno,
                });
            }
        }
        Ok(fds.get(1).and_then(PollFd::revents))
    }
}

/// The poll timeout until `next_ns`, rounded up to a millisecond (rounding down would wake
/// early and spin until the event is due); none when nothing is scheduled.
fn poll_timeout(next_ns: Option<i64>, now_ns: i64) -> PollTimeout {
    let Some(next_ns) = next_ns else {
        return PollTimeout::NONE;
    };
    // The device state machines fire strictly after a deadline: one more nanosecond.
    let wait_ns = next_ns.saturating_sub(now_ns).saturating_add(1).max(0);
    let wait_ms = wait_ns.saturating_add(999_999) / 1_000_000;
    PollTimeout::try_from(u32::try_from(wait_ms).unwrap_or(u32::MAX)).unwrap_or(PollTimeout::MAX)
}

/// Reads everything the master has now into `received` (cleared first).
fn read_available(master: BorrowedFd<'_>, received: &mut Vec<u8>) -> Result<(), FakeDeviceError> {
    received.clear();
    let mut buf = [0; 4096];
    loop {
        match nix::unistd::read(master, &mut buf) {
            Ok(0) | Err(Errno::EAGAIN) => return Ok(()),
            Ok(count) => received.extend_from_slice(&buf[..count]),
            Err(Errno::EINTR) => {}
            Err(errno) => {
                return Err(FakeDeviceError::Io {
                    operation: "read the pseudo-terminal",
                    errno,
                });
            }
        }
    }
}

/// Empties the wake-up pipe.
fn drain(wake: BorrowedFd<'_>) {
    let mut buf = [0; 64];
    while matches!(nix::unistd::read(wake, &mut buf), Ok(count) if count > 0) {}
}

/// The bytes queued for the host, and the line's garbling of bytes sent at a wrong rate.
///
/// Whether the host hears bytes as sent or as garbage is decided when they go out to the
/// pseudo-terminal (the host receives them then), not when the device made them: a reply
/// made while the host was at the device's rate, and written after it moved to another,
/// reaches it as garbage.
#[derive(Debug)]
struct Output {
    /// Device bytes not handed to the pseudo-terminal yet, with the rate they are sent at.
    pending: VecDeque<(Vec<u8>, u32)>,
    pending_len: usize,
    /// Bytes as the host will receive them, being written.
    queue: VecDeque<u8>,
    written: u64,
    garbled: u64,
    noise: NoiseBytes,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            pending: VecDeque::new(),
            pending_len: 0,
            queue: VecDeque::new(),
            written: 0,
            garbled: 0,
            // The seed, and where in each number the byte is taken, of the line's noise.
            noise: NoiseBytes::new(0x2545_F491_4F6C_DD1D, 24),
        }
    }
}

impl Output {
    fn is_empty(&self) -> bool {
        self.queue.is_empty() && self.pending.is_empty()
    }

    /// Queues `bytes` sent at `line_bps`; beyond the bound they are dropped and counted.
    fn push(&mut self, stats: &mut EmulatorStats, bytes: &[u8], line_bps: u32) {
        if bytes.is_empty() {
            return;
        }
        if self.queue.len() + self.pending_len + bytes.len() > OUTPUT_LIMIT {
            stats.bytes_dropped += bytes.len() as u64;
            return;
        }
        self.pending_len += bytes.len();
        self.pending.push_back((bytes.to_vec(), line_bps));
    }

    /// Turns what is pending into what a host at `host_bps` receives: the bytes as sent when
    /// the rates agree, else as many garbage characters as the host's rate fits in the time
    /// the device took.
    fn commit(&mut self, host_bps: Option<u32>) {
        while let Some((bytes, line_bps)) = self.pending.pop_front() {
            self.pending_len -= bytes.len();
            if host_bps == Some(line_bps) {
                self.queue.extend(bytes);
                continue;
            }
            self.garbled += bytes.len() as u64;
            let host_bps = u64::from(host_bps.unwrap_or(0));
            let count = bytes.len() as u64 * host_bps / u64::from(line_bps.max(1));
            for _ in 0..count {
                let byte = self.noise.next_byte();
                self.queue.push_back(byte);
            }
        }
    }

    /// Hands what is pending to a host at `host_bps` and writes what the master takes
    /// without blocking.
    fn write(
        &mut self,
        master: BorrowedFd<'_>,
        host_bps: Option<u32>,
    ) -> Result<(), FakeDeviceError> {
        self.commit(host_bps);
        while !self.queue.is_empty() {
            let (front, _) = self.queue.as_slices();
            match nix::unistd::write(master, front) {
                Ok(count) => {
                    self.queue.drain(..count);
                    self.written += count as u64;
                }
                Err(Errno::EAGAIN) => return Ok(()),
                Err(Errno::EINTR) => {}
                Err(errno) => {
                    return Err(FakeDeviceError::Io {
                        operation: "write the pseudo-terminal",
                        errno,
                    });
                }
            }
        }
        Ok(())
    }

    /// Bytes written, and device bytes garbled, since the last call.
    fn take_counts(&mut self) -> (u64, u64) {
        (
            std::mem::take(&mut self.written),
            std::mem::take(&mut self.garbled),
        )
    }

    /// Drops the queue; the bytes dropped.
    fn clear(&mut self) -> u64 {
        let count = (self.queue.len() + self.pending_len) as u64;
        self.queue.clear();
        self.pending.clear();
        self.pending_len = 0;
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poll_timeouts_round_up_and_never_go_negative() {
        let check = |next: Option<i64>, now: i64, expected: PollTimeout| {
            assert_eq!(poll_timeout(next, now), expected, "{next:?} {now}");
        };
        check(None, 0, PollTimeout::NONE);
        check(Some(5), 10, PollTimeout::from(0u8));
        check(Some(10), 10, PollTimeout::from(1u8));
        check(Some(2_500_000), 0, PollTimeout::from(3u8));
    }

    #[test]
    fn bytes_at_the_wrong_rate_reach_the_host_as_fewer_garbage_bytes() {
        let mut output = Output::default();
        let mut stats = EmulatorStats::default();
        output.push(&mut stats, &[0x02; 400], 38_400);
        output.commit(Some(9_600));
        assert_eq!(output.queue.len(), 100);
        assert_eq!(output.take_counts(), (0, 400));
        output.push(&mut stats, &[7, 8], 9_600);
        output.commit(Some(9_600));
        assert_eq!(
            output
                .queue
                .iter()
                .rev()
                .take(2)
                .copied()
                .collect::<Vec<_>>(),
            vec![8, 7]
        );
    }

    #[test]
    fn the_host_rate_when_the_bytes_go_out_decides_whether_they_are_garbled() {
        let mut output = Output::default();
        let mut stats = EmulatorStats::default();
        // Made while the host listened at 38400, written after it moved to 9600.
        output.push(&mut stats, &[0x06; 40], 38_400);
        output.commit(Some(9_600));
        assert_eq!(output.queue.len(), 10);
        // The bytes the line's own xorshift gave before it was made the one.
        assert_eq!(
            output.queue.iter().copied().collect::<Vec<_>>(),
            [0xea, 0x1c, 0x58, 0xd8, 0x97, 0xbe, 0x9d, 0x50, 0x12, 0xc9]
        );
    }

    #[test]
    fn output_beyond_the_limit_is_dropped_and_counted() {
        let mut output = Output::default();
        let mut stats = EmulatorStats::default();
        let chunk = vec![0; OUTPUT_LIMIT - 10];
        output.push(&mut stats, &chunk, 9_600);
        output.push(&mut stats, &[1; 20], 9_600);
        output.commit(Some(9_600));
        assert_eq!(output.queue.len(), OUTPUT_LIMIT - 10);
        assert_eq!(stats.bytes_dropped, 20);
    }
}
