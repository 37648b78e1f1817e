//! The supervisor: named children, their exits as events, automatic restarts, ordered stops.
//!
//! It is a plain value driven by its owner's thread: nothing happens between calls except
//! in the kernel (exits are noted on pidfds, backoffs run on a timerfd) and in the output
//! threads. The owner learns that something is ready either by blocking in
//! [`Supervisor::wait_event`] or by polling the file descriptor of [`Supervisor::as_fd`]
//! (an epoll set holding every child's pidfd and the restart timer) in its own event loop,
//! for example an iceoryx2 `WaitSet`, and then calling [`Supervisor::try_event`].

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::SyncSender;
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use rustix::event::epoll;
use rustix::time::{
    Itimerspec, TimerfdClockId, TimerfdFlags, TimerfdTimerFlags, Timespec, timerfd_create,
    timerfd_settime,
};

use super::error::{StartError, StopError, SuperviseError};
use super::event::{ExitStatus, LogLine, Stream, SupervisorEvent};
use super::guard::Guard;
use super::output::Forward;
use super::policy::{RestartDecision, RestartTracker};
use super::process::{Process, Spawner, Stopped, timespec};
use super::spec::{ChildSpec, Restart};

/// The epoll token of the restart timer; children get tokens from 1 up.
const TIMER_TOKEN: u64 = 0;

/// Events taken from the kernel per `epoll_wait`.
const EPOLL_BATCH: usize = 16;

/// Supervises named child processes; see the module documentation of
/// [`supervise`](crate::supervise).
pub struct Supervisor {
    children: BTreeMap<String, Slot>,
    /// Names in the order they were last started by the caller: [`Supervisor::stop_all`]
    /// goes backwards. Automatic restarts keep a child's place.
    start_order: Vec<String>,
    /// Epoll token of each running child's pidfd.
    tokens: BTreeMap<u64, String>,
    next_token: u64,
    /// Events found but not yet handed out. Bounded: new exits are looked for only when it is
    /// empty, and one look yields at most three events per child.
    pending: VecDeque<SupervisorEvent>,
    epoll: OwnedFd,
    timer: OwnedFd,
    /// The origin of the nanosecond clock given to the restart trackers.
    origin: Instant,
    log_sink: Option<SyncSender<LogLine>>,
    /// Kills the children's process groups if this process dies (see `guard`).
    guard: Arc<Guard>,
    // Dropped last (fields drop in order): children are killed in `drop` before the spawner
    // thread ends, and its end would kill any survivor through PDEATHSIG anyway.
    spawner: Spawner,
}

struct Slot {
    spec: ChildSpec,
    state: State,
    tracker: Option<RestartTracker>,
    dropped_log_lines: Arc<AtomicU64>,
}

enum State {
    Running { process: Process, token: u64 },
    RestartAt { at_ns: i64, attempt: u32 },
    Down,
}

impl Supervisor {
    /// A supervisor whose children's output goes to `tracing` only.
    pub fn new() -> Result<Self, SuperviseError> {
        Self::build(None)
    }

    /// A supervisor whose children's output goes to `tracing` and, line by line, to
    /// `log_sink`. Lines are sent with `try_send`: when the channel is full a line is dropped
    /// and counted ([`Self::dropped_log_lines`]), so size the channel for bursts.
    pub fn with_log_sink(log_sink: SyncSender<LogLine>) -> Result<Self, SuperviseError> {
        Self::build(Some(log_sink))
    }

    fn build(log_sink: Option<SyncSender<LogLine>>) -> Result<Self, SuperviseError> {
        let setup = |e: rustix::io::Errno| SuperviseError::Setup(e.into());
        let epoll = epoll::create(epoll::CreateFlags::CLOEXEC).map_err(setup)?;
        let timer = timerfd_create(
            TimerfdClockId::Monotonic,
            TimerfdFlags::CLOEXEC | TimerfdFlags::NONBLOCK,
        )
        .map_err(setup)?;
        epoll::add(
            &epoll,
            &timer,
            epoll::EventData::new_u64(TIMER_TOKEN),
            epoll::EventFlags::IN,
        )
        .map_err(setup)?;
        Ok(Self {
            children: BTreeMap::new(),
            start_order: Vec::new(),
            tokens: BTreeMap::new(),
            next_token: TIMER_TOKEN + 1,
            pending: VecDeque::new(),
            epoll,
            timer,
            origin: Instant::now(),
            log_sink,
            guard: Arc::new(Guard::spawn().map_err(SuperviseError::Setup)?),
            spawner: Spawner::new().map_err(SuperviseError::Setup)?,
        })
    }

    /// Starts a child and returns its pid. A child of the same name that is not running
    /// (exited, stopped, given up, waiting for a restart) is replaced, and its restart
    /// history forgotten.
    pub fn start(&mut self, spec: ChildSpec) -> Result<u32, StartError> {
        if let Some(pid) = self.pid(&spec.name) {
            return Err(StartError::AlreadyRunning {
                name: spec.name,
                pid,
            });
        }
        let name = spec.name.clone();
        let tracker = match spec.restart {
            Restart::Never => None,
            Restart::OnFailure(policy) | Restart::Always(policy) => {
                Some(RestartTracker::new(policy))
            }
        };
        let dropped_log_lines = Arc::new(AtomicU64::new(0));
        let (process, token) = self.launch(&spec, &dropped_log_lines)?;
        let pid = process.pid();
        self.children.insert(
            name.clone(),
            Slot {
                spec,
                state: State::Running { process, token },
                tracker,
                dropped_log_lines,
            },
        );
        self.start_order.retain(|n| *n != name);
        self.start_order.push(name);
        self.rearm_timer();
        Ok(pid)
    }

    /// Stops a child: SIGTERM to its process group, SIGKILL after its spec's grace period,
    /// then SIGKILL to whatever is left of the group. Returns how it ended, or `None` if it
    /// was not running (a pending automatic restart is cancelled). No event is reported for
    /// a stop.
    pub fn stop(&mut self, name: &str) -> Result<Option<ExitStatus>, StopError> {
        let slot = self
            .children
            .get_mut(name)
            .ok_or_else(|| StopError::UnknownChild {
                name: name.to_owned(),
            })?;
        let grace = slot.spec.stop_grace;
        match std::mem::replace(&mut slot.state, State::Down) {
            State::Running { process, token } => {
                let os = |source| StopError::Os {
                    name: name.to_owned(),
                    source,
                };
                let _ = epoll::delete(&self.epoll, process.pidfd());
                self.tokens.remove(&token);
                match process.terminate(grace).map_err(os)? {
                    Stopped::Exited(status) => Ok(Some(status)),
                    Stopped::StillAlive(process) => {
                        let pid = process.pid();
                        self.watch(name, process);
                        Err(StopError::StillAlive {
                            name: name.to_owned(),
                            pid,
                        })
                    }
                }
            }
            State::RestartAt { .. } | State::Down => {
                self.rearm_timer();
                Ok(None)
            }
        }
    }

    /// Stops every child, one after the other, in the reverse of the order they were started
    /// by [`Self::start`]. Returns each child's name with what [`Self::stop`] said.
    pub fn stop_all(&mut self) -> Vec<(String, Result<Option<ExitStatus>, StopError>)> {
        let order: Vec<String> = self.start_order.iter().rev().cloned().collect();
        order
            .into_iter()
            .map(|name| {
                let result = self.stop(&name);
                (name, result)
            })
            .collect()
    }

    /// Sends `signal` to a running child's process (not its group), through its pidfd so it
    /// can never reach a recycled pid. Its exit, if it dies, is reported as an event.
    pub fn signal(&self, name: &str, signal: Signal) -> Result<(), StopError> {
        match self.children.get(name).map(|slot| &slot.state) {
            Some(State::Running { process, .. }) => {
                process.signal(signal).map_err(|source| StopError::Os {
                    name: name.to_owned(),
                    source,
                })
            }
            Some(_) => Err(StopError::NotRunning {
                name: name.to_owned(),
            }),
            None => Err(StopError::UnknownChild {
                name: name.to_owned(),
            }),
        }
    }

    /// The pid of a running child.
    #[must_use]
    pub fn pid(&self, name: &str) -> Option<u32> {
        match self.children.get(name).map(|slot| &slot.state) {
            Some(State::Running { process, .. }) => Some(process.pid()),
            _ => None,
        }
    }

    /// Waits, at most `timeout`, for the exits of the running children that are dying
    /// (killed, their threads on the way out, not yet gone): their exits are then events.
    /// A child that was killed stops its heartbeats at once but is seen gone only when its
    /// last thread has exited; a deadline judged in between would call its death a stall.
    pub fn await_dying(&self, timeout: Duration) {
        for slot in self.children.values() {
            if let State::Running { process, .. } = &slot.state
                && dying(process.pid())
            {
                let _ = process.wait_exit(timeout);
            }
        }
    }

    /// The names of the running children, in start order.
    #[must_use]
    pub fn running(&self) -> Vec<&str> {
        self.start_order
            .iter()
            .filter(|name| self.pid(name).is_some())
            .map(String::as_str)
            .collect()
    }

    /// How many of a child's log lines were dropped because the log sink was full (since it
    /// was last started by [`Self::start`]).
    #[must_use]
    pub fn dropped_log_lines(&self, name: &str) -> u64 {
        self.children
            .get(name)
            .map_or(0, |slot| slot.dropped_log_lines.load(Ordering::Relaxed))
    }

    /// The next event if one is ready, without blocking.
    pub fn try_event(&mut self) -> Result<Option<SupervisorEvent>, SuperviseError> {
        if self.pending.is_empty() {
            self.collect(Some(Duration::ZERO))?;
        }
        Ok(self.pending.pop_front())
    }

    /// The next event, waiting at most `timeout` for it (forever if `None`). Backoffs run
    /// while waiting: a restart is made, and reported, from inside this call.
    pub fn wait_event(
        &mut self,
        timeout: Option<Duration>,
    ) -> Result<Option<SupervisorEvent>, SuperviseError> {
        let deadline = timeout.map(|t| Instant::now() + t);
        loop {
            if let Some(event) = self.pending.pop_front() {
                return Ok(Some(event));
            }
            let remaining = deadline.map(|d| d.saturating_duration_since(Instant::now()));
            self.collect(remaining)?;
            if self.pending.is_empty() && remaining == Some(Duration::ZERO) {
                return Ok(None);
            }
        }
    }

    /// Waits for the kernel to report exits or an expired backoff (at most `timeout`), and
    /// turns what it reports into pending events.
    fn collect(&mut self, timeout: Option<Duration>) -> Result<(), SuperviseError> {
        let wait_for = timeout.map(timespec);
        let mut ready = [epoll::Event {
            flags: epoll::EventFlags::empty(),
            data: epoll::EventData::new_u64(TIMER_TOKEN),
        }; EPOLL_BATCH];
        let count = match epoll::wait(&self.epoll, &mut ready, wait_for.as_ref()) {
            Ok(count) => count,
            Err(rustix::io::Errno::INTR) => 0,
            Err(e) => return Err(SuperviseError::Wait(e.into())),
        };
        for event in ready.iter().take(count) {
            let token = event.data.u64();
            if token != TIMER_TOKEN
                && let Some(name) = self.tokens.get(&token).cloned()
            {
                self.on_exit(&name);
            }
        }
        self.restart_due();
        Ok(())
    }

    /// Reaps an exited child, reports it and applies its restart policy.
    fn on_exit(&mut self, name: &str) {
        let now_ns = self.now_ns();
        let Some(slot) = self.children.get_mut(name) else {
            return;
        };
        let State::Running { process, token } = std::mem::replace(&mut slot.state, State::Down)
        else {
            return;
        };
        let _ = epoll::delete(&self.epoll, process.pidfd());
        self.tokens.remove(&token);
        let pid = process.pid();
        let status = match process.reap() {
            Ok(status) => status,
            Err(e) => {
                tracing::error!(service = name, pid, "cannot reap the exited service: {e}");
                return;
            }
        };
        tracing::trace!(service = name, "{status} (pid {pid})");
        self.pending.push_back(SupervisorEvent::Exited {
            name: name.to_owned(),
            pid,
            status,
        });
        let restart_wanted = match slot.spec.restart {
            Restart::Never => false,
            Restart::OnFailure(_) => !status.success(),
            Restart::Always(_) => true,
        };
        let Some(tracker) = slot.tracker.as_mut().filter(|_| restart_wanted) else {
            return;
        };
        match tracker.on_failure(now_ns) {
            RestartDecision::RestartAt { at_ns, attempt } => {
                slot.state = State::RestartAt { at_ns, attempt };
                let delay_ms = u64::try_from(at_ns.saturating_sub(now_ns) / 1_000_000).unwrap_or(0);
                self.pending.push_back(SupervisorEvent::RestartScheduled {
                    name: name.to_owned(),
                    attempt,
                    delay_ms,
                });
            }
            RestartDecision::GiveUp { failures } => {
                tracing::warn!(
                    service = name,
                    failures,
                    "service failed too often: giving up"
                );
                self.pending.push_back(SupervisorEvent::GaveUp {
                    name: name.to_owned(),
                    failures,
                });
            }
        }
    }

    /// Restarts every child whose backoff has expired, then sets the timer for the next.
    fn restart_due(&mut self) {
        let now_ns = self.now_ns();
        let due: Vec<(String, u32)> = self
            .children
            .iter()
            .filter_map(|(name, slot)| match slot.state {
                State::RestartAt { at_ns, attempt } if at_ns <= now_ns => {
                    Some((name.clone(), attempt))
                }
                _ => None,
            })
            .collect();
        for (name, attempt) in due {
            let Some(slot) = self.children.get(&name) else {
                continue;
            };
            let (spec, dropped) = (slot.spec.clone(), Arc::clone(&slot.dropped_log_lines));
            let (state, event) = match self.launch(&spec, &dropped) {
                Ok((process, token)) => {
                    let pid = process.pid();
                    (
                        State::Running { process, token },
                        SupervisorEvent::Restarted {
                            name: name.clone(),
                            pid,
                            attempt,
                        },
                    )
                }
                Err(error) => (
                    State::Down,
                    SupervisorEvent::RestartFailed {
                        name: name.clone(),
                        error,
                    },
                ),
            };
            if let Some(slot) = self.children.get_mut(&name) {
                slot.state = state;
            }
            self.pending.push_back(event);
        }
        self.rearm_timer();
    }

    /// Starts a process for `spec`, forwards its output and watches its pidfd.
    fn launch(
        &mut self,
        spec: &ChildSpec,
        dropped: &Arc<AtomicU64>,
    ) -> Result<(Process, u64), StartError> {
        let mut process = Process::start(&self.spawner, &self.guard, spec)?;
        let pid = process.pid();
        let name: Arc<str> = Arc::from(spec.name.as_str());
        let (stdout, stderr) = process.take_output();
        let forward = |stream| Forward {
            name: Arc::clone(&name),
            pid,
            stream,
            sink: self.log_sink.clone(),
            dropped: Arc::clone(dropped),
        };
        let started = stdout
            .map_or(Ok(()), |out| forward(Stream::Stdout).spawn(out))
            .and_then(|()| stderr.map_or(Ok(()), |err| forward(Stream::Stderr).spawn(err)));
        let token = self.next_token;
        let watched = started.and_then(|()| {
            epoll::add(
                &self.epoll,
                process.pidfd(),
                epoll::EventData::new_u64(token),
                epoll::EventFlags::IN,
            )
            .map_err(io::Error::from)
        });
        if let Err(e) = watched {
            // Without its output threads or its pidfd watched it would be unsupervised.
            let _ = process.kill();
            return Err(StartError::Supervisor {
                name: spec.name.clone(),
                source: Arc::new(e),
            });
        }
        self.next_token += 1;
        self.tokens.insert(token, spec.name.clone());
        tracing::trace!(service = %spec.name, "started {} (pid {pid})", spec.program.display());
        Ok((process, token))
    }

    /// Puts a process back under watch (after a stop that could not kill it).
    fn watch(&mut self, name: &str, process: Process) {
        let token = self.next_token;
        self.next_token += 1;
        if let Err(e) = epoll::add(
            &self.epoll,
            process.pidfd(),
            epoll::EventData::new_u64(token),
            epoll::EventFlags::IN,
        ) {
            tracing::error!(service = name, "cannot watch the service any more: {e}");
        }
        self.tokens.insert(token, name.to_owned());
        if let Some(slot) = self.children.get_mut(name) {
            slot.state = State::Running { process, token };
        }
    }

    /// Arms the timer for the earliest pending restart, or disarms it.
    fn rearm_timer(&self) {
        let earliest = self
            .children
            .values()
            .filter_map(|slot| match slot.state {
                State::RestartAt { at_ns, .. } => Some(at_ns),
                _ => None,
            })
            .min();
        let zero = Timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        let value = match earliest {
            // A zero value disarms the timer: an overdue restart fires after 1 ns instead.
            Some(at_ns) => {
                let delay_ns = at_ns.saturating_sub(self.now_ns()).max(1);
                Timespec {
                    tv_sec: delay_ns / 1_000_000_000,
                    tv_nsec: delay_ns % 1_000_000_000,
                }
            }
            None => zero,
        };
        let spec = Itimerspec {
            it_interval: zero,
            it_value: value,
        };
        // Reading the timer is never needed: a restart happens on any wake-up once due, and
        // setting the timer clears its expiry count.
        if let Err(e) = timerfd_settime(&self.timer, TimerfdTimerFlags::empty(), &spec) {
            tracing::error!("cannot set the restart timer: {e}");
        }
    }

    fn now_ns(&self) -> i64 {
        i64::try_from(self.origin.elapsed().as_nanos()).unwrap_or(i64::MAX)
    }
}

impl AsFd for Supervisor {
    /// An epoll file descriptor that is readable when [`Supervisor::try_event`] has something
    /// to do: a child exited or a restart backoff expired. It is level-triggered: after it
    /// polls readable, call `try_event` until it returns `None`.
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.epoll.as_fd()
    }
}

impl Drop for Supervisor {
    /// Kills every child's process group at once (no grace: call [`Supervisor::stop_all`]
    /// first for a clean shutdown) and reaps them.
    fn drop(&mut self) {
        for name in self.start_order.iter().rev() {
            let Some(slot) = self.children.get_mut(name) else {
                continue;
            };
            if let State::Running { process, .. } = std::mem::replace(&mut slot.state, State::Down)
            {
                let pid = process.pid();
                if let Err(e) = process.kill() {
                    tracing::error!(service = %name, pid, "cannot kill the service: {e}");
                }
            }
        }
    }
}

/// Whether process `pid` is on its way out: a zombie, its main thread exiting
/// (`PF_EXITING` among the flags of `/proc/PID/stat`), or killed and not yet scheduled to
/// act on it (SIGKILL pending in `/proc/PID/status`). On a machine whose cores are busy a
/// killed process's threads may wait tens of milliseconds for a core before they begin to
/// exit, and a deadline judged meanwhile would call the death a stall.
fn dying(pid: u32) -> bool {
    const PF_EXITING: u64 = 0x4;
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    let Some((_, after_name)) = stat.rsplit_once(')') else {
        return false;
    };
    // After the name: state, ppid, pgrp, session, tty_nr, tpgid, flags.
    let mut fields = after_name.split_whitespace();
    let state = fields.next();
    let flags = fields.nth(5).and_then(|f| f.parse::<u64>().ok());
    matches!(state, Some("Z" | "X"))
        || flags.is_some_and(|f| f & PF_EXITING != 0)
        || std::fs::read_to_string(format!("/proc/{pid}/status"))
            .is_ok_and(|status| sigkill_pending(&status))
}

/// Whether a `/proc/PID/status` text shows SIGKILL pending, for its thread (`SigPnd`) or
/// its whole process (`ShdPnd`): a fatal signal is queued on every thread at once.
fn sigkill_pending(status: &str) -> bool {
    const SIGKILL_BIT: u64 = 1 << (9 - 1);
    status.lines().any(|line| {
        line.strip_prefix("SigPnd:")
            .or_else(|| line.strip_prefix("ShdPnd:"))
            .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
            .is_some_and(|mask| mask & SIGKILL_BIT != 0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_zombie_is_dying_and_a_running_process_is_not() {
        assert!(!dying(std::process::id()));
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = rustix::process::Pid::from_child(&child);
        let pidfd = rustix::process::pidfd_open(pid, rustix::process::PidfdFlags::empty()).unwrap();
        // Readable once it has exited; not reaped yet, so a zombie.
        let mut fds = [rustix::event::PollFd::new(
            &pidfd,
            rustix::event::PollFlags::IN,
        )];
        rustix::event::poll(&mut fds, None).unwrap();
        assert!(dying(child.id()));
        child.wait().unwrap();
        assert!(!dying(u32::MAX), "no such process: not dying");
    }

    #[test]
    fn a_pending_sigkill_is_read_from_either_mask() {
        let status =
            |sig: &str, shd: &str| format!("Name:\tlaser\nSigPnd:\t{sig}\nShdPnd:\t{shd}\n");
        assert!(sigkill_pending(&status(
            "0000000000000100",
            "0000000000000000"
        )));
        assert!(sigkill_pending(&status(
            "0000000000000000",
            "0000000000000100"
        )));
        assert!(!sigkill_pending(&status(
            "0000000000000000",
            "0000000000004000"
        )));
        assert!(!sigkill_pending("SigPnd:\tnot hex\n"));
    }
}
