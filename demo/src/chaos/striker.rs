//! The chaos of one mission, struck live from a thread of its own: it hears the mission's
//! start on `/lewis/sequencer`, strikes each fault of the schedule at its time (a kill, or
//! a fault put in the service's harness and cleared when it has lasted), and counts what
//! the broker does about them on `/lewis/broker`.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, BrokerAction, Sequencer as SequencerMessage};
use lewis_replay::fault::FaultKind;
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::live::fault::{inject, kill};
use lewis_runtime::names;
use lewis_sequencer::{Entry, from_message};
use serde::Serialize;

use super::schedule::ChaosFault;
use crate::fault::{now_ns, spawn_listening};

/// How long one injection or kill may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// How often the thread looks at its clock and its stop flag while nothing arrives.
const POLL: Duration = Duration::from_millis(20);

/// One fault of the schedule as it went.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Struck {
    /// The fault planned.
    pub fault: ChaosFault,
    /// When it struck (wall clock, ns since the Unix epoch), if it did.
    pub struck_ns: Option<i64>,
    /// When it was cleared, for a lasting fault.
    pub cleared_ns: Option<i64>,
    /// Why it could not be struck or cleared (the service did not run then, say).
    pub missed: Option<String>,
}

/// What the broker did during the mission.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct BrokerCounts {
    /// Restarts scheduled (a process died).
    pub restarts: u32,
    /// Clients moved from one provider to another.
    pub failovers: u32,
    /// Failed services started again after their cool-down.
    pub retries: u32,
    /// Services given up.
    pub failed: u32,
    /// What the broker asked for help for: an interface none of whose providers was left,
    /// or a service it could not run (in order, each once).
    pub help_for: Vec<String>,
    /// Time clients spent with an interface they need bound to nobody, summed over
    /// clients and interfaces, in ns (from the broker's unbind to its next bind).
    pub blind_ns: i64,
}

/// What the thread did and saw.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct ChaosLog {
    /// When the mission started (wall clock, ns since the Unix epoch), if it did.
    pub mission_start_ns: Option<i64>,
    /// Each fault of the schedule.
    pub faults: Vec<Struck>,
    /// The broker's decisions, counted.
    pub broker: BrokerCounts,
    /// What went wrong with the thread itself, if anything.
    pub error: Option<String>,
}

/// The thread: started before the robot, so that it hears everything.
#[derive(Debug)]
pub struct Striker {
    stop: Arc<AtomicBool>,
    thread: JoinHandle<Option<ChaosLog>>,
}

impl Striker {
    /// Subscribes in `namespace` and starts the thread, which strikes `faults`.
    ///
    /// # Errors
    /// When the IPC node or the subscribers cannot be opened, or the thread cannot start.
    pub fn start(namespace: &Namespace, faults: Vec<ChaosFault>) -> Result<Self, std::io::Error> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let namespace = namespace.clone();
        let thread = spawn_listening(
            "lewis-chaos",
            move || Watch::open(&namespace, faults, flag),
            |mut watch| {
                watch.run();
                watch.finish()
            },
        )?;
        Ok(Self { stop, thread })
    }

    /// Stops the thread (its IPC node closes with it) and returns what it did.
    #[must_use]
    pub fn finish(self) -> ChaosLog {
        self.stop.store(true, Ordering::Relaxed);
        self.thread
            .join()
            .ok()
            .flatten()
            .unwrap_or_else(|| ChaosLog {
                error: Some("the chaos thread panicked".to_owned()),
                ..ChaosLog::default()
            })
    }
}

/// A lasting fault in effect, to clear at `until`.
struct Lasting {
    index: usize,
    until: Instant,
}

struct Watch {
    ipc: Ipc,
    sequencer: Subscriber,
    broker: Subscriber,
    stop: Arc<AtomicBool>,
    log: ChaosLog,
    /// The mission's start on this machine's monotonic clock, for the schedule.
    started: Option<Instant>,
    next: usize,
    lasting: Vec<Lasting>,
    /// Clients left without a provider, since when (the broker's time).
    blind_since: BTreeMap<(String, String), i64>,
    /// The broker's latest decision time: where open blind spells end.
    latest_ns: i64,
    over: bool,
}

impl Watch {
    fn open(
        namespace: &Namespace,
        faults: Vec<ChaosFault>,
        stop: Arc<AtomicBool>,
    ) -> Result<Self, String> {
        let ipc = Ipc::open(namespace, &format!("lewis-chaos-{}", std::process::id()))
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
            log: ChaosLog {
                faults: faults
                    .into_iter()
                    .map(|fault| Struck {
                        fault,
                        struck_ns: None,
                        cleared_ns: None,
                        missed: None,
                    })
                    .collect(),
                ..ChaosLog::default()
            },
            started: None,
            next: 0,
            lasting: Vec::new(),
            blind_since: BTreeMap::new(),
            latest_ns: 0,
            over: false,
        })
    }

    fn run(&mut self) {
        while !self.stop.load(Ordering::Relaxed) {
            let _ = WaitSet::new(WakeMode::Event).wait(
                &[&self.sequencer, &self.broker],
                Some(Instant::now() + POLL),
            );
            self.drain_sequencer();
            self.drain_broker();
            if !self.over {
                self.strike_due();
            }
        }
    }

    fn finish(mut self) -> ChaosLog {
        for (_, since) in std::mem::take(&mut self.blind_since) {
            self.log.broker.blind_ns += (self.latest_ns - since).max(0);
        }
        self.log
    }

    fn strike_due(&mut self) {
        let Some(started) = self.started else { return };
        let now = Instant::now();
        // Clear what has lasted long enough, first: a fault struck again on the same
        // service after it is cleared, not before.
        let mut i = 0;
        while i < self.lasting.len() {
            if self.lasting[i].until <= now {
                let Lasting { index, .. } = self.lasting.swap_remove(i);
                self.clear(index);
            } else {
                i += 1;
            }
        }
        while let Some(struck) = self.log.faults.get(self.next) {
            let due = started + Duration::from_millis(struck.fault.at_ms);
            if due > now {
                break;
            }
            let index = self.next;
            self.next += 1;
            self.strike(index);
        }
    }

    fn strike(&mut self, index: usize) {
        let fault = self.log.faults[index].fault.clone();
        let outcome = match fault.kind {
            FaultKind::Crash => kill(&self.ipc, &fault.provider, CALL_TIMEOUT)
                .map(|pid| tracing::info!("chaos: killed {} (pid {pid})", fault.provider))
                .map_err(|e| e.to_string()),
            kind => inject(&self.ipc, &fault.provider, Some(kind), CALL_TIMEOUT)
                .map(|()| tracing::info!("chaos: {} {kind}", fault.provider))
                .map_err(|e| e.to_string()),
        };
        let struck = &mut self.log.faults[index];
        match outcome {
            Ok(()) => {
                struck.struck_ns = Some(now_ns());
                if let Some(for_ms) = fault.for_ms {
                    self.lasting.push(Lasting {
                        index,
                        until: Instant::now() + Duration::from_millis(for_ms),
                    });
                }
            }
            Err(e) => struck.missed = Some(e),
        }
    }

    fn clear(&mut self, index: usize) {
        let provider = self.log.faults[index].fault.provider.clone();
        let struck = &mut self.log.faults[index];
        match inject(&self.ipc, &provider, None, CALL_TIMEOUT) {
            Ok(()) => struck.cleared_ns = Some(now_ns()),
            // Killed and restarted meanwhile (by chaos or by the broker): the new process
            // has no fault to clear.
            Err(e) => {
                struck.cleared_ns = Some(now_ns());
                tracing::debug!("chaos: clearing {provider}: {e}");
            }
        }
    }

    fn drain_sequencer(&mut self) {
        while let Ok(Some(sample)) = self.sequencer.receive() {
            let Ok(message) = cdr::from_bytes::<SequencerMessage>(sample.bytes()) else {
                continue;
            };
            let Ok(record) = from_message(&message) else {
                continue;
            };
            match &record.entry {
                Entry::MissionStarted { .. } if self.started.is_none() => {
                    self.started = Some(Instant::now());
                    self.log.mission_start_ns = Some(record.time_ns);
                }
                Entry::Decided {
                    decision:
                        lewis_sequencer::Decision::Finished { .. }
                        | lewis_sequencer::Decision::Aborted { .. },
                } => self.over = true,
                _ => {}
            }
        }
    }

    fn drain_broker(&mut self) {
        while let Ok(Some(sample)) = self.broker.receive() {
            let Ok(decision) = cdr::from_bytes::<Broker>(sample.bytes()) else {
                continue;
            };
            if self.started.is_none() {
                continue;
            }
            self.counted(&decision);
        }
    }

    fn counted(&mut self, d: &Broker) {
        self.latest_ns = self.latest_ns.max(d.at_ns);
        let counts = &mut self.log.broker;
        let key = (d.client.clone(), d.interface.clone());
        match BrokerAction::parse(&d.action) {
            Some(BrokerAction::RestartScheduled) => counts.restarts += 1,
            Some(BrokerAction::Rebind) => {
                counts.failovers += 1;
                self.close_blind(&key, d.at_ns);
            }
            Some(BrokerAction::Start) if d.reason.starts_with("retry ") => counts.retries += 1,
            Some(BrokerAction::ServiceFailed) => counts.failed += 1,
            Some(BrokerAction::AskForHelp) => {
                let need = if d.interface.is_empty() {
                    &d.service
                } else {
                    &d.interface
                };
                if !counts.help_for.contains(need) {
                    counts.help_for.push(need.clone());
                }
            }
            // Not when the client itself is gone ("client X is gone").
            Some(BrokerAction::Unbind) if d.reason.starts_with("no provider") => {
                self.blind_since.entry(key).or_insert(d.at_ns);
            }
            Some(BrokerAction::Bind) => self.close_blind(&key, d.at_ns),
            _ => {}
        }
    }

    fn close_blind(&mut self, key: &(String, String), at_ns: i64) {
        if let Some(since) = self.blind_since.remove(key) {
            self.log.broker.blind_ns += (at_ns - since).max(0);
        }
    }
}
