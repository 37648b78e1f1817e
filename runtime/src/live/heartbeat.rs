//! A service's heartbeats, sent from a thread of their own that watches the event loop.
//!
//! A heartbeat means "this service is responsive". Sent from the event loop between
//! handlers, as they were first, it meant "the loop came round within the deadline", and on
//! a loaded machine that is a statement about the scheduler, not the service: beside
//! `stress-ng --cpu 2` a 100 ms deadline failed every service of the simulated robot within
//! seconds (a 20 ms tick took 160 ms of wall time, most of it waiting for a core).
//!
//! So the time is measured where it means something. The loop marks each step it takes
//! (woken, a handler begun, back to waiting) with the wall clock and its own thread's CPU
//! clock; this thread beats at the broker's period unless the loop is stuck, which is:
//! - a step that has used more CPU than the deadline (a handler in an endless loop), or
//! - a step older than the deadline whose thread sleeps in it and has not run since the
//!   last look (a handler blocked on a lock or a device without timeout).
//!
//! Finding the loop stuck, it says so once, a Health message `stalled` with what it saw,
//! and goes silent. The broker fails the service on that message at once: one deadline
//! after the step began, plus at most a period between looks. Silence alone would have it
//! judged twice, by this thread and then by the broker's own deadline (210-220 ms at a
//! 100 ms deadline). Silence stays the backstop for a process dead or frozen whole.
//!
//! Work inside iceoryx2 is not a handler's, and is judged against the startup deadline:
//! iceoryx2 takes 70-80 ms of CPU to open a command client (measured on the simulated
//! robot), which the harness does at a client's first call to a provider, inside the
//! handler that makes it, 5-15 ms for a subscriber at each rebinding, and 250-350 ms at a
//! port's next use after a peer died (debug build), to drop that peer's connections: every
//! service the demo's killed laser had a channel with paid it at once.
//!
//! A step that waits for a core is neither: it is runnable, and its CPU clock does not
//! advance while it waits. An injected stall stops the beats at once, as a hung process
//! would. The thread runs under `SCHED_FIFO` where the machine allows it
//! ([`crate::supervise::set_thread_realtime`]): it wakes 20 times a second for a few
//! microseconds, and with it a busy machine cannot delay a beat by more than that. It
//! never waits for the loop's thread, which runs at normal priority: the loop shows its
//! steps in atomics and the thread parks, so a loop preempted at any point cannot hold the
//! heartbeats up (a mutex between them did, beside `stress-ng`: a priority inversion).

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::{JoinHandle, Thread};
use std::time::{Duration, Instant};

use lewis_interfaces::msg::{Health as HealthMessage, HealthState};

use super::fault::{FaultState, OUT_OF_SERVICE_REASON};
use super::health_fields;
use crate::clock::LiveClock;
use crate::ipc::{Ipc, IpcError, Namespace, Publisher};
use crate::names;
use lewis_service::Health;

/// The step word's flag: the loop waits for something to do.
const WAITING: u64 = 1;
/// The step word's flag: the loop is in iceoryx2 (opening an endpoint, or a port's
/// upkeep), judged against the startup deadline.
const IPC: u64 = 2;

/// What the loop shows the heartbeat thread; the thread never blocks on any of it.
#[derive(Debug)]
struct Shared {
    /// The loop's step: its number shifted left by two, with [`WAITING`] and [`IPC`].
    step: AtomicU64,
    fault: AtomicU8,
    /// Taken by the thread only with `try_lock`: the loop holds it for a clone.
    declared: Mutex<Health>,
    /// Beat now: the declared health or the fault changed.
    beat_now: AtomicBool,
    stop: AtomicBool,
}

const fn fault_code(fault: FaultState) -> u8 {
    match fault {
        FaultState::Normal => 0,
        FaultState::OutOfService => 1,
        FaultState::Stalled => 2,
        FaultState::Frozen => 3,
        FaultState::Garbage => 4,
    }
}

const fn fault_of(code: u8) -> FaultState {
    match code {
        0 => FaultState::Normal,
        1 => FaultState::OutOfService,
        3 => FaultState::Frozen,
        4 => FaultState::Garbage,
        _ => FaultState::Stalled,
    }
}

/// The loop thread as the heartbeat thread sees it: its CPU clock and its state.
#[derive(Debug, Clone, Copy)]
struct LoopThread {
    cpu_clock: nix::time::ClockId,
    tid: i32,
}

impl LoopThread {
    /// The calling thread.
    fn current() -> Self {
        let mut clock: nix::libc::clockid_t = 0;
        // SAFETY: pthread_self is the calling thread, and `clock` is a valid place for
        // the result.
        let found =
            unsafe { nix::libc::pthread_getcpuclockid(nix::libc::pthread_self(), &raw mut clock) };
        let cpu_clock = if found == 0 {
            nix::time::ClockId::from_raw(clock)
        } else {
            // Not on Linux's threads: the process's clock still measures a busy loop.
            nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID
        };
        Self {
            cpu_clock,
            tid: nix::unistd::gettid().as_raw(),
        }
    }

    fn cpu_ns(self) -> i64 {
        nix::time::clock_gettime(self.cpu_clock).map_or(0, |t| {
            t.tv_sec()
                .saturating_mul(1_000_000_000)
                .saturating_add(t.tv_nsec())
        })
    }

    /// Whether the thread sleeps (`S`) or waits for a device (`D`), from
    /// `/proc/self/task/TID/stat`; runnable or unknown is not asleep.
    fn asleep(self) -> bool {
        std::fs::read_to_string(format!("/proc/self/task/{}/stat", self.tid))
            .ok()
            .and_then(|stat| thread_state(&stat))
            .is_some_and(|state| matches!(state, 'S' | 'D'))
    }
}

/// The state letter of a `/proc/.../stat` line: the field after the command, which is in
/// parentheses and may itself hold spaces and parentheses.
fn thread_state(stat: &str) -> Option<char> {
    stat.rsplit_once(')')?.1.trim_start().chars().next()
}

/// What one step may take, in CPU time and asleep.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Deadlines {
    /// The heartbeat deadline: every step of the loop but IPC work.
    step: Duration,
    /// The startup deadline: opening an endpoint.
    setup: Duration,
}

/// One step of the loop as the heartbeat thread has seen it, from its first look.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Seen {
    /// The step word.
    word: u64,
    /// When it was first seen.
    since: Instant,
    /// The loop thread's CPU clock then.
    cpu_ns: i64,
    /// The loop thread's CPU clock at the last look.
    last_cpu_ns: i64,
}

/// Why the loop, in step `seen` (looked at now, its CPU clock at `cpu_now_ns`), counts as
/// stuck; `None` while it is responsive. A step is timed from its first look, so a stall
/// is seen up to one heartbeat period later than it began.
fn stuck(
    seen: &Seen,
    now: Instant,
    cpu_now_ns: i64,
    asleep: impl FnOnce() -> bool,
    deadlines: Deadlines,
) -> Option<&'static str> {
    let deadline = if seen.word & IPC != 0 {
        deadlines.setup
    } else {
        deadlines.step
    };
    let deadline_ns = i64::try_from(deadline.as_nanos()).unwrap_or(i64::MAX);
    if cpu_now_ns.saturating_sub(seen.cpu_ns) > deadline_ns {
        return Some("busy in one step for more CPU time than its deadline");
    }
    let idle = seen.last_cpu_ns == cpu_now_ns;
    (now.saturating_duration_since(seen.since) > deadline && idle && asleep())
        .then_some("blocked in one step for longer than its deadline")
}

/// The event loop's steps, as its heartbeat thread sees them (a program, which the broker
/// does not supervise, has no heartbeat thread: its steps are measured all the same, for
/// its overrun warnings). Used from the loop's thread only.
#[derive(Debug)]
pub(super) struct LoopWatch {
    shared: Arc<Shared>,
    loop_thread: LoopThread,
    steps: Cell<u64>,
    /// The loop thread's CPU clock when the step began, moved on by the IPC work within it.
    step_cpu_ns: Cell<i64>,
    heartbeats: Option<(JoinHandle<()>, Thread)>,
}

/// What the heartbeat thread needs to start.
pub(super) struct HeartbeatPlan<'a> {
    pub namespace: &'a Namespace,
    pub service: &'a str,
    pub period: Duration,
    pub deadline: Duration,
    /// What one call into iceoryx2 may take: the startup deadline.
    pub setup_deadline: Duration,
    /// The `SCHED_FIFO` priority to ask for; 0 for the normal scheduler.
    pub realtime_priority: u8,
}

impl LoopWatch {
    /// Watches the calling thread's loop.
    pub(super) fn new() -> Self {
        Self {
            shared: Arc::new(Shared {
                step: AtomicU64::new(WAITING),
                fault: AtomicU8::new(fault_code(FaultState::Normal)),
                declared: Mutex::new(Health::Ok),
                beat_now: AtomicBool::new(false),
                stop: AtomicBool::new(false),
            }),
            loop_thread: LoopThread::current(),
            steps: Cell::new(0),
            step_cpu_ns: Cell::new(0),
            heartbeats: None,
        }
    }

    /// Opens the health channel on a thread of its own (an iceoryx2 node belongs to the
    /// thread that made it) and starts beating. Called once the service is ready: the
    /// first heartbeat says so.
    ///
    /// # Errors
    /// When the thread cannot start or the channel cannot be opened.
    pub(super) fn start_heartbeats(&mut self, plan: &HeartbeatPlan<'_>) -> Result<(), IpcError> {
        let (opened_tx, opened) = std::sync::mpsc::channel::<Result<(), IpcError>>();
        let thread_error = |reason: String| IpcError::Node {
            node: plan.service.to_owned(),
            namespace: plan.namespace.to_string(),
            reason,
        };
        let beater = Beater {
            shared: Arc::clone(&self.shared),
            loop_thread: self.loop_thread,
            service: plan.service.to_owned(),
            period: plan.period.max(Duration::from_millis(1)),
            deadlines: Deadlines {
                step: plan.deadline,
                setup: plan.setup_deadline,
            },
            seq: 0,
            clock: LiveClock::new(),
            declared: Health::Ok,
            seen: None,
            withheld_for: None,
        };
        let (namespace, priority) = (plan.namespace.clone(), plan.realtime_priority);
        let thread = std::thread::Builder::new()
            .name("lewis-heartbeat".to_owned())
            .spawn(move || {
                // Named apart from the service's own node, which tools find by its name.
                let node = format!("{}-heartbeat", beater.service);
                let opened = Ipc::open(&namespace, &node).and_then(|ipc| {
                    let publisher = ipc.publisher(
                        &names::health_channel(&beater.service),
                        &names::health_config(),
                    )?;
                    Ok((ipc, publisher))
                });
                match opened {
                    Ok((ipc, publisher)) => {
                        // After opening (tens of milliseconds of CPU at start), not before.
                        // Where it is not allowed, `lewis up` has said so for the robot.
                        if priority > 0 {
                            let _ = crate::supervise::set_thread_realtime(priority);
                        }
                        let _ = opened_tx.send(Ok(()));
                        beater.run(publisher);
                        drop(ipc);
                    }
                    Err(e) => {
                        let _ = opened_tx.send(Err(e));
                    }
                }
            })
            .map_err(|e| thread_error(format!("cannot start the heartbeat thread: {e}")))?;
        let handle = thread.thread().clone();
        self.heartbeats = Some((thread, handle));
        match opened.recv() {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(e),
            Err(_) => Err(thread_error(
                "the heartbeat thread ended before opening its channel".to_owned(),
            )),
        }
    }

    fn show(&self, flags: u64) {
        let number = self.steps.get() + 1;
        self.steps.set(number);
        self.shared
            .step
            .store(number << 2 | flags, Ordering::Release);
    }

    /// The loop begins a step (it woke, or a handler is about to run): the step's CPU time
    /// and age count from now.
    pub(super) fn step(&self) {
        self.show(0);
        self.step_cpu_ns.set(self.loop_thread.cpu_ns());
    }

    /// Runs `work`, a call into iceoryx2, judged against the startup deadline; the step it
    /// interrupts goes on afterwards without the CPU `work` took.
    ///
    /// Opening an endpoint took 70-80 ms of CPU, and a port whose peer died drops that
    /// peer's connections at its next use: 250-350 ms of CPU for one killed laser, in every
    /// service it had a channel with. Counted as the handler's, that failed every service
    /// of the robot at once when the demo killed the laser.
    pub(super) fn ipc<T>(&self, work: impl FnOnce() -> T) -> T {
        self.show(IPC);
        let before = self.loop_thread.cpu_ns();
        let done = work();
        let used = self.loop_thread.cpu_ns().saturating_sub(before);
        self.show(0);
        self.step_cpu_ns
            .set(self.step_cpu_ns.get().saturating_add(used));
        done
    }

    /// The loop waits for something to do: nothing of it can be stuck.
    pub(super) fn waiting(&self) {
        self.show(WAITING);
    }

    /// The CPU time the loop's thread has used in the step it is in, IPC work left out.
    pub(super) fn step_cpu(&self) -> Duration {
        let used = self
            .loop_thread
            .cpu_ns()
            .saturating_sub(self.step_cpu_ns.get());
        Duration::from_nanos(u64::try_from(used).unwrap_or(0))
    }

    /// The service declares its health: the broker hears it at once.
    pub(super) fn declare(&self, health: &Health) {
        *self
            .shared
            .declared
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = health.clone();
        self.beat_now();
    }

    /// A fault was injected: stalled stops the beats, out of service says so in them.
    pub(super) fn fault(&self, fault: FaultState) {
        self.shared
            .fault
            .store(fault_code(fault), Ordering::Release);
        self.beat_now();
    }

    fn beat_now(&self) {
        self.shared.beat_now.store(true, Ordering::Release);
        if let Some((_, thread)) = &self.heartbeats {
            thread.unpark();
        }
    }
}

impl Drop for LoopWatch {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        if let Some((join, thread)) = self.heartbeats.take() {
            thread.unpark();
            let _ = join.join();
        }
    }
}

/// The heartbeat thread's side.
struct Beater {
    shared: Arc<Shared>,
    loop_thread: LoopThread,
    service: String,
    period: Duration,
    deadlines: Deadlines,
    seq: u64,
    /// The machine's clock: heartbeats keep it, whatever clock the service reads.
    clock: LiveClock,
    /// The declared health as last read.
    declared: Health,
    /// The loop's step at the last look.
    seen: Option<Seen>,
    /// The step the last withheld heartbeat was for.
    withheld_for: Option<u64>,
}

impl Beater {
    fn run(mut self, mut publisher: Publisher) {
        // The first heartbeat says "ready": the loop has run `on_start` and made every
        // endpoint before it starts this thread.
        let mut next = Instant::now();
        while !self.shared.stop.load(Ordering::Acquire) {
            let now = Instant::now();
            let asked = self.shared.beat_now.swap(false, Ordering::AcqRel);
            if asked || now >= next {
                if now >= next {
                    next = super::advance(next, self.period, now);
                }
                self.beat(&mut publisher);
                continue;
            }
            std::thread::park_timeout(next.saturating_duration_since(now));
        }
    }

    /// How the loop looks now.
    fn look(&mut self) -> Look {
        let word = self.shared.step.load(Ordering::Acquire);
        if word & WAITING != 0 {
            self.seen = None;
            return Look::Responsive;
        }
        let now = Instant::now();
        let cpu_ns = self.loop_thread.cpu_ns();
        let seen = match self.seen {
            Some(seen) if seen.word == word => seen,
            _ => {
                self.seen = Some(Seen {
                    word,
                    since: now,
                    cpu_ns,
                    last_cpu_ns: cpu_ns,
                });
                return Look::Responsive;
            }
        };
        let why = stuck(
            &seen,
            now,
            cpu_ns,
            || self.loop_thread.asleep(),
            self.deadlines,
        );
        self.seen = Some(Seen {
            last_cpu_ns: cpu_ns,
            ..seen
        });
        match why {
            None => Look::Responsive,
            Some(_) if self.withheld_for == Some(word) => Look::StillStuck,
            Some(why) => {
                self.withheld_for = Some(word);
                Look::Stuck(why)
            }
        }
    }

    fn beat(&mut self, publisher: &mut Publisher) {
        let (state, reason) = match self.look() {
            Look::Responsive => {
                // The loop holds the lock only to store a clone. If it holds it now
                // (preempted there, perhaps), the value read last time stands and the
                // change goes with the next beat: retrying at once would spin, ahead of the
                // loop that must let go.
                if let Ok(declared) = self.shared.declared.try_lock() {
                    self.declared.clone_from(&declared);
                }
                match fault_of(self.shared.fault.load(Ordering::Acquire)) {
                    FaultState::Stalled => return,
                    FaultState::OutOfService => {
                        (HealthState::OutOfService, OUT_OF_SERVICE_REASON.to_owned())
                    }
                    // Bad data under good heartbeats: what the data checks are for.
                    FaultState::Normal | FaultState::Frozen | FaultState::Garbage => {
                        let (state, reason) = health_fields(&self.declared);
                        (state, reason.to_owned())
                    }
                }
            }
            // Said once, then silence: the broker fails it on this message, and silence
            // stays the backstop should the message be lost.
            Look::Stuck(why) => {
                let reason = format!(
                    "its event loop is {why} ({} ms)",
                    self.deadlines.step.as_millis()
                );
                tracing::warn!(service = self.service, "stalled: {reason}");
                (HealthState::Stalled, reason)
            }
            Look::StillStuck => return,
        };
        self.seq += 1;
        let mut message = HealthMessage {
            state: state.into(),
            reason,
            ..HealthMessage::default()
        };
        let now_ns = self.clock.now_ns();
        if let Err(e) = publisher.publish_stamped(&mut message, &self.service, self.seq, now_ns) {
            tracing::warn!(service = self.service, "cannot publish heartbeat: {e}");
        }
    }
}

/// What the heartbeat thread makes of the loop at one look.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Look {
    /// Waiting, or in a step within its deadlines: beat.
    Responsive,
    /// Stuck in a step, seen now for the first time: say so, once.
    Stuck(&'static str),
    /// Stuck in a step already reported: stay silent.
    StillStuck,
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);
    const MS_NS: i64 = 1_000_000;
    const DEADLINES: Deadlines = Deadlines {
        step: Duration::from_millis(100),
        setup: Duration::from_millis(5000),
    };

    fn seen(since: Instant, cpu_ns: i64, last_cpu_ns: i64) -> Seen {
        Seen {
            word: 7 << 2,
            since,
            cpu_ns,
            last_cpu_ns,
        }
    }

    #[test]
    fn a_step_that_waits_for_a_core_is_not_stuck_however_old() {
        let start = Instant::now();
        // 900 ms of wall time, 40 ms of it on a core, runnable.
        let step = seen(start, 0, 30 * MS_NS);
        assert_eq!(
            stuck(&step, start + 900 * MS, 40 * MS_NS, || false, DEADLINES),
            None
        );
        // Not running since the last look, but runnable: waiting for a core.
        assert_eq!(
            stuck(&step, start + 900 * MS, 30 * MS_NS, || false, DEADLINES),
            None
        );
    }

    #[test]
    fn a_step_busy_for_more_cpu_than_its_deadline_is_stuck() {
        let start = Instant::now();
        assert_eq!(
            stuck(
                &seen(start, 0, 90 * MS_NS),
                start + 150 * MS,
                101 * MS_NS,
                || false,
                DEADLINES
            ),
            Some("busy in one step for more CPU time than its deadline")
        );
    }

    #[test]
    fn a_step_asleep_past_its_deadline_without_running_is_stuck() {
        let start = Instant::now();
        let cpu = 5 * MS_NS;
        let step = seen(start, 0, cpu);
        assert_eq!(
            stuck(&step, start + 120 * MS, cpu, || true, DEADLINES),
            Some("blocked in one step for longer than its deadline")
        );
        // It ran since the last look: not blocked.
        assert_eq!(
            stuck(&step, start + 120 * MS, cpu + 1, || true, DEADLINES),
            None
        );
        // Young enough: a short sleep in a handler is allowed.
        assert_eq!(stuck(&step, start + 90 * MS, cpu, || true, DEADLINES), None);
    }

    #[test]
    fn ipc_work_is_judged_against_the_startup_deadline() {
        let start = Instant::now();
        let setup = Seen {
            word: 7 << 2 | IPC,
            ..seen(start, 0, 0)
        };
        let now = start + 200 * MS;
        assert_eq!(stuck(&setup, now, 150 * MS_NS, || false, DEADLINES), None);
        assert!(stuck(&setup, now, 5001 * MS_NS, || false, DEADLINES).is_some());
    }

    #[test]
    fn a_handler_goes_on_after_ipc_work_without_its_cpu() {
        let watch = LoopWatch::new();
        watch.step();
        let word = watch.shared.step.load(Ordering::Acquire);
        watch.ipc(|| {
            assert_eq!(watch.shared.step.load(Ordering::Acquire) & IPC, IPC);
            let before = watch.loop_thread.cpu_ns();
            while watch.loop_thread.cpu_ns() - before < 20 * MS_NS {
                std::hint::black_box(0);
            }
        });
        let after = watch.shared.step.load(Ordering::Acquire);
        assert_eq!(after & (IPC | WAITING), 0);
        assert_ne!(after, word, "a new step for the heartbeat thread");
        // The handler's own CPU: what it used before and after, not the 20 ms of IPC work.
        assert!(watch.step_cpu() < 20 * MS, "{:?}", watch.step_cpu());
        watch.waiting();
        assert_eq!(watch.shared.step.load(Ordering::Acquire) & WAITING, WAITING);
    }

    #[test]
    fn faults_keep_their_meaning_through_their_codes() {
        for fault in [
            FaultState::Normal,
            FaultState::OutOfService,
            FaultState::Stalled,
            FaultState::Frozen,
            FaultState::Garbage,
        ] {
            assert_eq!(fault_of(fault_code(fault)), fault);
        }
    }

    #[test]
    fn the_state_letter_is_found_after_the_command_name() {
        assert_eq!(thread_state("42 (laser) S 1 42 42 0"), Some('S'));
        assert_eq!(thread_state("42 (a) b) (c) R 1"), Some('R'));
        assert_eq!(thread_state("42 (laser"), None);
    }

    #[test]
    fn this_threads_cpu_clock_advances_while_it_computes() {
        let me = LoopThread::current();
        let before = me.cpu_ns();
        // However busy the machine, 10 ms of CPU come; a clock that does not advance
        // never ends the loop, and the test's own timeout says so.
        let mut x = 0_u64;
        while me.cpu_ns() - before < 10 * MS_NS {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        assert!(x > 0);
        assert!(!me.asleep(), "a computing thread is runnable");
    }
}
