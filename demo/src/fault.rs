//! The demo's fault, struck live from a thread of its own: it listens on `/lewis/sequencer`
//! for the moment to strike and on `/lewis/broker` for what the broker does about it.
//!
//! A crash is the paper's demonstration: the provider's process is killed (SIGKILL) again
//! after every restart until the broker gives it up (`service-failed`) and moves its
//! clients to another provider. A stall, an out-of-service, a freeze or garbage is
//! injected once through the service's harness.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, BrokerStatus, Sequencer as SequencerMessage};
use lewis_replay::fault::{FaultKind, FaultSpec};
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::live::fault::{inject, kill};
use lewis_runtime::names;
use lewis_sequencer::{Decision, Entry, Record, from_message};

/// How long one question to the broker or one injection may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// How often the thread looks at its stop flag while nothing arrives.
const POLL: Duration = Duration::from_millis(100);

/// When the fault strikes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Strike {
    /// When the mission leaves its first state (the challenge's `door`), whichever way.
    AfterFirstState,
    /// This long after the mission started.
    At {
        /// Nanoseconds from the mission's first record.
        after_start_ns: i64,
    },
}

/// The fault to strike: which service, how, when.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveFault {
    /// The service.
    pub provider: String,
    /// Crash (the kill loop), stall, out-of-service, frozen or garbage.
    pub kind: FaultKind,
    /// When.
    pub strike: Strike,
}

impl LiveFault {
    /// The default: the laser crashes beyond its restart limit once the first state is over.
    #[must_use]
    pub fn laser_after_first_state() -> Self {
        Self {
            provider: "laser".to_owned(),
            kind: FaultKind::Crash,
            strike: Strike::AfterFirstState,
        }
    }

    /// The fault of `--fault SPEC` (the `--inject-fault` grammar; the time from the
    /// mission's start, none: after the first state).
    ///
    /// # Errors
    /// For `slow`, `stuck` and a host's loss (only a replay can thin a service's data,
    /// stick its loop or cut a host off) and for a time window (a live fault is not
    /// cleared).
    pub fn from_spec(spec: &FaultSpec) -> Result<Self, String> {
        if matches!(
            spec.kind,
            FaultKind::Slow
                | FaultKind::Stuck
                | FaultKind::HostLost
                | FaultKind::Nan
                | FaultKind::Degraded
        ) {
            return Err(format!(
                "--fault {}: `{}` can only be injected in a replay; use crash, stall, out-of-service, frozen or garbage",
                spec.text, spec.kind
            ));
        }
        if spec.until_ns.is_some() {
            return Err(format!(
                "--fault {}: a live fault is not cleared; give a start time only",
                spec.text
            ));
        }
        Ok(Self {
            provider: spec.provider.clone(),
            kind: spec.kind,
            strike: spec
                .at_ns
                .map_or(Strike::AfterFirstState, |after_start_ns| Strike::At {
                    after_start_ns,
                }),
        })
    }
}

/// What the fault thread did and saw.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FaultLog {
    /// When it struck (wall clock, ns since the Unix epoch), if it did.
    pub struck_ns: Option<i64>,
    /// The processes killed, in order.
    pub killed: Vec<i32>,
    /// When the broker gave the provider up (`service-failed`), if it did.
    pub failed_ns: Option<i64>,
    /// The broker's moves of clients away from the provider after the fault, as
    /// `client Interface: from -> to`.
    pub rebinds: Vec<String>,
    /// What went wrong, if the fault could not be struck.
    pub error: Option<String>,
}

/// The fault thread: started before the robot, so that it hears everything.
#[derive(Debug)]
pub struct FaultThread {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Option<FaultLog>>,
}

impl FaultThread {
    /// Subscribes in `namespace` and starts the thread.
    ///
    /// # Errors
    /// When the IPC node or the subscribers cannot be opened, or the thread cannot start.
    pub fn start(namespace: &Namespace, fault: LiveFault) -> Result<Self, std::io::Error> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let namespace = namespace.clone();
        let thread = spawn_listening(
            "lewis-demo-fault",
            move || Watch::open(&namespace, fault, flag),
            |mut watch| {
                watch.run();
                watch.log
            },
        )?;
        Ok(Self { stop, thread })
    }

    /// Stops the thread and returns what it did.
    #[must_use]
    pub fn finish(self) -> FaultLog {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .ok()
            .flatten()
            .unwrap_or_else(|| FaultLog {
                error: Some("the fault thread panicked".to_owned()),
                ..FaultLog::default()
            })
    }
}

struct Watch {
    ipc: Ipc,
    sequencer: Subscriber,
    broker: Subscriber,
    stop: Arc<AtomicBool>,
    fault: LiveFault,
    log: FaultLog,
    mission_start_ns: Option<i64>,
    first_state: Option<String>,
    first_state_over: bool,
    /// The mission is over: nothing more to strike.
    over: bool,
}

impl Watch {
    fn open(
        namespace: &Namespace,
        fault: LiveFault,
        stop: Arc<AtomicBool>,
    ) -> Result<Self, String> {
        let ipc = Ipc::open(
            namespace,
            &format!("lewis-demo-fault-{}", std::process::id()),
        )
        .map_err(|e| e.to_string())?;
        let sequencer = ipc
            .subscriber(names::SEQUENCER_CHANNEL, &names::sequencer_config())
            .map_err(|e| e.to_string())?;
        let broker = ipc
            .subscriber(names::BROKER_CHANNEL, &names::broker_config())
            .map_err(|e| e.to_string())?;
        Ok(Self {
            ipc,
            sequencer,
            broker,
            stop,
            fault,
            log: FaultLog::default(),
            mission_start_ns: None,
            first_state: None,
            first_state_over: false,
            over: false,
        })
    }

    fn run(&mut self) {
        // Until the moment comes.
        while !self.due() {
            if self.stopped() || self.over {
                return;
            }
            self.wait();
            self.drain_sequencer();
            self.drain_broker();
        }
        self.log.struck_ns = Some(now_ns());
        let provider = self.fault.provider.clone();
        match self.fault.kind {
            FaultKind::Crash => self.kill_until_failed(),
            FaultKind::Stall | FaultKind::OutOfService | FaultKind::Frozen | FaultKind::Garbage => {
                if let Err(e) = inject(&self.ipc, &provider, Some(self.fault.kind), CALL_TIMEOUT) {
                    self.log.error = Some(e.to_string());
                }
            }
            FaultKind::Slow
            | FaultKind::Stuck
            | FaultKind::HostLost
            | FaultKind::Nan
            | FaultKind::Degraded => {
                let kind = self.fault.kind;
                self.log.error = Some(format!("{kind} cannot be injected live"));
            }
        }
        // What the broker does next (the rebinds), until the run ends.
        while !self.stopped() {
            self.wait();
            self.drain_sequencer();
            self.drain_broker();
        }
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn due(&self) -> bool {
        match &self.fault.strike {
            Strike::AfterFirstState => self.first_state_over,
            Strike::At { after_start_ns } => self
                .mission_start_ns
                .is_some_and(|start| now_ns() >= start + after_start_ns),
        }
    }

    fn wait(&self) {
        let _ = WaitSet::new(WakeMode::Event).wait(
            &[&self.sequencer, &self.broker],
            Some(Instant::now() + POLL),
        );
    }

    /// The paper's demonstration: kill every process of the provider the broker starts
    /// until it gives the provider up.
    fn kill_until_failed(&mut self) {
        let provider = self.fault.provider.clone();
        let mut broker = match self
            .ipc
            .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        {
            Ok(client) => client,
            Err(e) => {
                self.log.error = Some(format!("cannot reach the broker: {e}"));
                return;
            }
        };
        while self.log.failed_ns.is_none() && !self.stopped() && !self.over {
            let pid = lewis_runtime::client::call_blocking(
                &mut broker,
                &BrokerStatus::default(),
                CALL_TIMEOUT,
            )
            .ok()
            .and_then(|status| lewis_runtime::broker::status::pid_of(&status, &provider));
            if let Some(pid) = pid
                && !self.log.killed.contains(&pid)
            {
                match kill(&self.ipc, &provider, CALL_TIMEOUT) {
                    Ok(pid) => {
                        tracing::info!("demo: killed {provider} (pid {pid})");
                        self.log.killed.push(pid);
                    }
                    // Gone between the status and the kill: the broker restarts it.
                    Err(e) => tracing::debug!("demo: {e}"),
                }
                continue;
            }
            // The broker announces each start, and the failure, on /lewis/broker.
            self.wait();
            self.drain_sequencer();
            self.drain_broker();
        }
    }

    fn drain_sequencer(&mut self) {
        while let Ok(Some(sample)) = self.sequencer.receive() {
            let Ok(message) = cdr::from_bytes::<SequencerMessage>(sample.bytes()) else {
                continue;
            };
            if let Ok(record) = from_message(&message) {
                self.seen(&record);
            }
        }
    }

    fn seen(&mut self, record: &Record) {
        match &record.entry {
            Entry::MissionStarted { .. } => self.mission_start_ns = Some(record.time_ns),
            Entry::Decided { decision } => match decision {
                Decision::Run { state, .. } if self.first_state.is_none() => {
                    self.first_state = Some(state.clone());
                }
                Decision::Transition { from, .. } | Decision::EnterRecovery { from, .. }
                    if self.first_state.as_ref() == Some(from) =>
                {
                    self.first_state_over = true;
                }
                Decision::Finished { .. } | Decision::Aborted { .. } => self.over = true,
                _ => {}
            },
            Entry::Observed { .. } | Entry::Refused { .. } | Entry::ProgramStarted { .. } => {}
        }
    }

    fn drain_broker(&mut self) {
        while let Ok(Some(sample)) = self.broker.receive() {
            let Ok(decision) = cdr::from_bytes::<Broker>(sample.bytes()) else {
                continue;
            };
            if self.log.struck_ns.is_none() {
                continue;
            }
            let provider = &self.fault.provider;
            if decision.action == "service-failed" && decision.service == *provider {
                self.log.failed_ns.get_or_insert_with(now_ns);
            }
            if decision.action == "rebind" && decision.from_service == *provider {
                self.log.rebinds.push(format!(
                    "{} {}: {} -> {}",
                    decision.client, decision.interface, decision.from_service, decision.to_service
                ));
            }
        }
    }
}

/// Starts thread `name`, which opens what it listens with (`open`: IPC ports stay on the
/// thread that opens them) and then runs `run`; returns once it listens, so that it hears
/// everything from then on. The thread's result is `None` when `open` failed (the error
/// is returned here).
///
/// # Errors
/// When `open` fails, or the thread cannot start.
pub(crate) fn spawn_listening<W, T: Send + 'static>(
    name: &str,
    open: impl FnOnce() -> Result<W, String> + Send + 'static,
    run: impl FnOnce(W) -> T + Send + 'static,
) -> Result<JoinHandle<Option<T>>, std::io::Error> {
    let (ready, listening) = std::sync::mpsc::channel();
    let thread = std::thread::Builder::new()
        .name(name.to_owned())
        .spawn(move || match open() {
            Ok(watch) => {
                let _ = ready.send(Ok(()));
                Some(run(watch))
            }
            Err(e) => {
                let _ = ready.send(Err(e));
                None
            }
        })?;
    match listening.recv() {
        Ok(Ok(())) => Ok(thread),
        Ok(Err(e)) => Err(std::io::Error::other(e)),
        Err(_) => Err(std::io::Error::other(format!("{name} ended at once"))),
    }
}

/// The wall clock, as the sequencer's records read it.
pub(crate) fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}
