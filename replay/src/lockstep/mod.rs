//! The lockstep harness: the broker's decision core and any set of services, in one thread,
//! on a virtual clock, fed recorded publications in a total order.
//!
//! Services are the same code as live: the harness implements the runtime's
//! [`Backend`](lewis_runtime::service::Backend) (a virtual clock and an outbox) and drives
//! the [`Service`] trait. Nothing in a service knows it is replayed.
//!
//! - **Time** is the recording's log time. Before a recorded message at time `t` is handled,
//!   every timer at or before `t` fires (ticks at each service's declared rate, heartbeats
//!   of re-simulated services at the broker's period, the broker's deadlines, fault starts
//!   and ends, call timeouts), in time order, ties in the order they were set.
//! - **Run to completion**: each event runs one handler of one service; what the handler did
//!   (publications, calls, health, logs) is carried out after it returns, through one FIFO
//!   queue, so the order of everything is fixed by the order of the events.
//! - **Sources** (services not re-simulated) are fed from the log: their data goes to the
//!   re-simulated clients the broker core has bound to them; their recorded heartbeats go to
//!   the broker core. Re-simulated services get synthesised heartbeats.
//! - **Clients**: a re-simulated service asks the core for what it requires when it starts,
//!   as the live harness does; clients that are not re-simulated (other programs, fed
//!   services) are seen through the recorded `bind` decisions and asked for again.
//! - **Calls** between re-simulated services are served in virtual time (same instant, after
//!   the caller's handler). A call to a fed service is answered from its recorded
//!   `CommandLog` ([`CommandBook`]) when it answered such a call live, else with an ok and a
//!   default reply (counted in [`HarnessStats::calls_defaulted`]). A call to a provider
//!   that is stalled, crashed or not running times out after its timeout.
//! - **Commands from outside** (an operator, a sequencer program) that a re-simulated
//!   service answered live are fed to it again at their recorded time.
//! - **Faults** ([`Fault`]) act on a provider as they would live: a stall silences its data
//!   and heartbeats, a crash makes its process exit (and exit again at every restart while
//!   it lasts), garbage replaces its data with bytes that do not decode, out-of-service
//!   declares it out of service.

mod backend;
pub mod book;
pub mod route;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use lewis_interfaces::cdr::{self, ENCAPSULATION_LE};
use lewis_interfaces::msg::{Broker as BrokerMessage, CommandLog, Header, InputRef};
use lewis_runtime::broker::{Action, BrokerCore, Decision, Event, ExitStatus, Health};
use lewis_runtime::live::health_from_message;
use lewis_runtime::robot::Robot;
use lewis_runtime::service::{
    BuildError, CallFailure, CallId, ContextState, IncomingCommand, Input, Level, ReplyEvent, Rng,
    Service, ServiceConfig, ServiceRegistry, decode_header_seq,
};
use lewis_runtime::{names, wire};
use serde::Serialize;

use crate::fault::{Fault, FaultKind};
use crate::recording::RecordedMessage;
use backend::{Effect, StepBackend};
pub use book::{CommandBook, default_reply, header_provider};
pub use route::{Route, route};

/// SIGABRT: how an injected crash ends a process.
const SIGABRT: i32 = 6;
/// SIGKILL: how a stalled process is stopped.
const SIGKILL: i32 = 9;
/// SIGTERM: how the broker stops a process.
const SIGTERM: i32 = 15;

/// What the harness produces, handed to a [`Sink`] as it happens.
#[derive(Debug, Clone, Copy)]
pub enum Emitted<'a> {
    /// A re-simulated service published.
    Publication {
        /// The service.
        service: &'a str,
        /// The interface.
        interface: &'a str,
        /// The virtual time.
        time_ns: i64,
        /// The header's sequence number.
        seq: u64,
        /// The CDR bytes.
        bytes: &'a [u8],
    },
    /// The broker core decided.
    Decision(&'a Decision),
    /// A re-simulated service declared a new health.
    Health {
        /// The service.
        service: &'a str,
        /// The virtual time.
        time_ns: i64,
        /// What it declared.
        health: &'a Health,
    },
    /// A re-simulated service answered a command.
    Command {
        /// The service.
        service: &'a str,
        /// The virtual time.
        time_ns: i64,
        /// The command and its answer.
        log: &'a CommandLog,
    },
    /// A re-simulated service wrote a log line.
    Log {
        /// The service.
        service: &'a str,
        /// The virtual time.
        time_ns: i64,
        /// Its level.
        level: Level,
        /// The text.
        text: &'a str,
    },
    /// A fault started or ended.
    Fault {
        /// The fault.
        fault: &'a Fault,
        /// The virtual time.
        time_ns: i64,
        /// Whether it starts (else it ends).
        starts: bool,
    },
}

/// Where the harness puts what it produces.
pub trait Sink {
    /// Takes one thing the harness produced.
    fn emit(&mut self, event: Emitted<'_>);
}

/// Counts of what the harness did.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct HarnessStats {
    /// Samples handed to re-simulated services.
    pub inputs_delivered: u64,
    /// Ticks run.
    pub ticks: u64,
    /// Publications of re-simulated services.
    pub publications: u64,
    /// Calls served by another re-simulated service.
    pub calls_between_resimulated: u64,
    /// Calls to a fed service answered from its recorded command log.
    pub calls_answered_from_log: u64,
    /// Calls to a fed service that the log did not answer: answered ok with a default reply.
    pub calls_defaulted: u64,
    /// Calls that failed (timeout, no provider).
    pub calls_failed: u64,
    /// Recorded commands from outside fed again to a re-simulated service.
    pub external_commands_fed: u64,
    /// Recorded messages on harness topics that did not decode (and were skipped).
    pub undecodable: u64,
    /// Publications dropped or garbled by an injected fault.
    pub faulted_publications: u64,
}

/// The longest time a client went without data of an interface it had received.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Gap {
    /// The client.
    pub client: String,
    /// The interface.
    pub interface: String,
    /// The virtual time of the last sample before the gap.
    pub from_ns: i64,
    /// The virtual time of the first sample after it (or the end of the replay).
    pub to_ns: i64,
    /// Its length.
    pub gap_ns: i64,
}

/// What one re-simulated client received of one interface from one provider: the
/// evidence of which sensor a service worked from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Feed {
    /// The client.
    pub client: String,
    /// The interface.
    pub interface: String,
    /// The provider.
    pub provider: String,
    /// Samples delivered.
    pub samples: u64,
    /// The virtual time of the first.
    pub first_ns: i64,
    /// The virtual time of the last.
    pub last_ns: i64,
}

/// What to run: which services are re-simulated, which faults are injected, and the
/// recorded answers of the fed services.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// The services run in the harness; every other service is fed from the log.
    pub resimulated: BTreeSet<String>,
    /// The faults to inject.
    pub faults: Vec<Fault>,
    /// Recorded answers of fed services.
    pub book: CommandBook,
}

/// Why the harness cannot be set up.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LockstepError {
    /// A service to re-simulate is not in the robot.
    #[error("the robot has no service `{service}` to re-simulate; it has: {known}")]
    UnknownService {
        /// The name.
        service: String,
        /// The services it has.
        known: String,
    },
    /// A service to re-simulate cannot be built.
    #[error("cannot re-simulate: {0}")]
    Build(#[from] BuildError),
}

struct Sim {
    instance: Option<Box<dyn Service>>,
    state: ContextState,
    backend: StepBackend,
    generation: u64,
    stalled: bool,
    tick_period_ns: Option<i64>,
    commands_answered: u64,
}

#[derive(Debug)]
enum Timer {
    Tick { service: String, generation: u64 },
    Heartbeat { service: String, generation: u64 },
    BrokerDeadline,
    FaultStarts(usize),
    FaultEnds(usize),
    Reply(Box<Work>),
}

#[derive(Debug)]
enum Work {
    Broker(Event),
    Start {
        service: String,
        generation: u64,
    },
    Input {
        client: String,
        interface: String,
        provider: String,
        channel: Arc<str>,
        seq: u64,
        bytes: Arc<[u8]>,
    },
    Command {
        target: String,
        interface: String,
        command: String,
        request: Vec<u8>,
        reply_to: Option<(String, u64, CallId, i64)>,
    },
    Reply {
        caller: String,
        generation: u64,
        call: CallId,
        interface: String,
        command: String,
        result: Result<Vec<u8>, CallFailure>,
    },
}

/// The lockstep harness. See the module documentation.
pub struct Lockstep<'a> {
    robot: &'a Robot,
    registry: &'a ServiceRegistry,
    core: BrokerCore,
    sims: BTreeMap<String, Sim>,
    faults: Vec<Fault>,
    book: CommandBook,
    bindings: BTreeMap<(String, String), String>,
    requested: BTreeSet<(String, String)>,
    routes: BTreeMap<Arc<str>, Route>,
    timers: BTreeMap<(i64, u64), Timer>,
    timer_seq: u64,
    deadline_at: Option<i64>,
    work: VecDeque<Work>,
    now_ns: i64,
    heartbeat_period_ns: i64,
    stats: HarnessStats,
    last_input: BTreeMap<(String, String), i64>,
    longest_gap: Option<Gap>,
    feeds: BTreeMap<(String, String, String), Feed>,
}

impl std::fmt::Debug for Lockstep<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Lockstep")
            .field("robot", &self.robot.name)
            .field("resimulated", &self.sims.keys().collect::<Vec<_>>())
            .field("now_ns", &self.now_ns)
            .finish_non_exhaustive()
    }
}

impl<'a> Lockstep<'a> {
    /// A harness for `robot` that re-simulates the services `plan` names (each built once
    /// here, to fail early on a kind or parameter this binary cannot run).
    ///
    /// # Errors
    /// When a service to re-simulate is unknown or cannot be built.
    pub fn new(
        robot: &'a Robot,
        registry: &'a ServiceRegistry,
        plan: Plan,
    ) -> Result<Self, LockstepError> {
        let mut sims = BTreeMap::new();
        for name in &plan.resimulated {
            let spec = robot
                .service(name)
                .ok_or_else(|| LockstepError::UnknownService {
                    service: name.clone(),
                    known: robot
                        .services
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })?;
            let config = ServiceConfig {
                spec,
                heartbeat_period_ms: robot.broker.heartbeat_period_ms,
            };
            drop(registry.build(&config)?);
            sims.insert(
                name.clone(),
                Sim {
                    instance: None,
                    state: ContextState::new(name, config.seed()),
                    backend: backend_for(spec),
                    generation: 0,
                    stalled: false,
                    tick_period_ns: None,
                    commands_answered: 0,
                },
            );
        }
        let heartbeat_period_ns = i64::try_from(
            robot
                .broker
                .heartbeat_period_ms
                .max(1)
                .saturating_mul(1_000_000),
        )
        .unwrap_or(i64::MAX);
        let mut harness = Self {
            robot,
            registry,
            core: BrokerCore::new(robot),
            sims,
            faults: plan.faults,
            book: plan.book,
            bindings: BTreeMap::new(),
            requested: BTreeSet::new(),
            routes: BTreeMap::new(),
            timers: BTreeMap::new(),
            timer_seq: 0,
            deadline_at: None,
            work: VecDeque::new(),
            now_ns: 0,
            heartbeat_period_ns,
            stats: HarnessStats::default(),
            last_input: BTreeMap::new(),
            longest_gap: None,
            feeds: BTreeMap::new(),
        };
        for i in 0..harness.faults.len() {
            let (at, until) = (harness.faults[i].at_ns, harness.faults[i].until_ns);
            harness.schedule(at, Timer::FaultStarts(i));
            if let Some(until) = until {
                harness.schedule(until, Timer::FaultEnds(i));
            }
        }
        Ok(harness)
    }

    /// The broker comes up at `at_ns` (the start of the recording): the core starts its
    /// standby and always services.
    pub fn start(&mut self, at_ns: i64, sink: &mut dyn Sink) {
        self.now_ns = at_ns;
        self.work.push_back(Work::Broker(Event::BrokerStarted));
        self.pump(sink);
    }

    /// Runs everything due up to `message`'s log time, then hands it to whoever it is for.
    pub fn feed(&mut self, message: &RecordedMessage, sink: &mut dyn Sink) {
        self.advance_to(message.log_time_ns, sink);
        let route = match self.routes.get(&message.topic) {
            Some(route) => route.clone(),
            None => {
                let route = route(&message.topic, self.robot);
                self.routes.insert(message.topic.clone(), route.clone());
                route
            }
        };
        match route {
            Route::Data { service, interface } => {
                if self.sims.contains_key(&service) {
                    return;
                }
                let Some(bytes) = self.through_faults(&service, message.seq, &message.data) else {
                    return;
                };
                self.deliver(&service, &interface, &message.topic, message.seq, &bytes);
            }
            Route::Health { service } => {
                if self.sims.contains_key(&service) {
                    return;
                }
                let Ok(health) = cdr::from_bytes(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                let health = match self.fault_of(&service) {
                    Some(FaultKind::Stall | FaultKind::Crash) => return,
                    Some(FaultKind::OutOfService) => injected_out_of_service(),
                    _ => health_from_message(&health),
                };
                self.work
                    .push_back(Work::Broker(Event::Heartbeat { service, health }));
            }
            Route::Commands { service } => {
                if !self.sims.contains_key(&service) {
                    return;
                }
                let Ok(log) = cdr::from_bytes::<CommandLog>(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                // A re-simulated caller makes its call again by itself.
                if self.sims.contains_key(&header_provider(&log.request)) {
                    return;
                }
                self.stats.external_commands_fed += 1;
                self.work.push_back(Work::Command {
                    target: service,
                    interface: log.interface,
                    command: log.command,
                    request: log.request,
                    reply_to: None,
                });
            }
            Route::Broker => {
                let Ok(decision) = cdr::from_bytes::<BrokerMessage>(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                let is_request = matches!(decision.action.as_str(), "bind" | "reject");
                if is_request
                    && !decision.client.is_empty()
                    && !self.sims.contains_key(&decision.client)
                    && self
                        .requested
                        .insert((decision.client.clone(), decision.interface.clone()))
                {
                    self.work.push_back(Work::Broker(Event::ClientRequest {
                        client: decision.client,
                        interface: decision.interface,
                    }));
                }
            }
            Route::Other => {}
        }
        self.pump(sink);
    }

    /// Runs everything due up to `end_ns`, then stops every running service (`on_stop`).
    pub fn finish(&mut self, end_ns: i64, sink: &mut dyn Sink) {
        self.advance_to(end_ns, sink);
        let running: Vec<String> = self
            .sims
            .iter()
            .filter(|(_, s)| s.instance.is_some() && !s.stalled)
            .map(|(n, _)| n.clone())
            .collect();
        for name in running {
            self.dispatch(&name, Vec::new(), sink, |service, ctx| service.on_stop(ctx));
            self.pump(sink);
        }
        let open: Vec<((String, String), i64)> = self
            .last_input
            .iter()
            .map(|(k, t)| (k.clone(), *t))
            .collect();
        for ((client, interface), last) in open {
            self.note_gap(&client, &interface, last, self.now_ns);
        }
    }

    /// Runs every timer due at or before `t`, then sets the clock to `t`.
    pub fn advance_to(&mut self, t: i64, sink: &mut dyn Sink) {
        while let Some(entry) = self.timers.first_entry() {
            if entry.key().0 > t {
                break;
            }
            let ((time, _), timer) = entry.remove_entry();
            self.now_ns = time;
            self.fire(timer, sink);
            self.pump(sink);
        }
        self.now_ns = self.now_ns.max(t);
    }

    /// The virtual time.
    #[must_use]
    pub fn now_ns(&self) -> i64 {
        self.now_ns
    }

    /// What the harness did so far.
    #[must_use]
    pub fn stats(&self) -> &HarnessStats {
        &self.stats
    }

    /// The longest time a client went without data so far.
    #[must_use]
    pub fn longest_gap(&self) -> Option<&Gap> {
        self.longest_gap.as_ref()
    }

    /// What each re-simulated client received from each provider so far, ordered by client,
    /// interface and provider.
    pub fn feeds(&self) -> impl Iterator<Item = &Feed> {
        self.feeds.values()
    }

    /// The provider of each client's interface now.
    #[must_use]
    pub fn bindings(&self) -> &BTreeMap<(String, String), String> {
        &self.bindings
    }

    fn schedule(&mut self, at_ns: i64, timer: Timer) {
        self.timer_seq += 1;
        self.timers
            .insert((at_ns.max(self.now_ns), self.timer_seq), timer);
    }

    fn fault_of(&self, provider: &str) -> Option<FaultKind> {
        self.faults
            .iter()
            .find(|f| f.provider == provider && f.active_at(self.now_ns))
            .map(|f| f.kind)
    }

    /// The bytes a provider's publication has after the faults: `None` when it is lost.
    fn through_faults(&mut self, provider: &str, seq: u64, bytes: &[u8]) -> Option<Vec<u8>> {
        match self.fault_of(provider) {
            None => Some(bytes.to_vec()),
            Some(FaultKind::Garbage) => {
                self.stats.faulted_publications += 1;
                Some(garble(provider, seq, bytes.len()))
            }
            Some(_) => {
                self.stats.faulted_publications += 1;
                None
            }
        }
    }

    /// Hands a provider's sample to every re-simulated client bound to it.
    fn deliver(
        &mut self,
        provider: &str,
        interface: &str,
        channel: &Arc<str>,
        seq: u64,
        bytes: &[u8],
    ) {
        let clients: Vec<String> = self
            .bindings
            .iter()
            .filter(|((client, i), p)| {
                i == interface && *p == provider && self.sims.contains_key(client)
            })
            .map(|((client, _), _)| client.clone())
            .collect();
        if clients.is_empty() {
            return;
        }
        let bytes: Arc<[u8]> = Arc::from(bytes);
        for client in clients {
            self.work.push_back(Work::Input {
                client,
                interface: interface.to_owned(),
                provider: provider.to_owned(),
                channel: channel.clone(),
                seq,
                bytes: bytes.clone(),
            });
        }
    }

    fn note_gap(&mut self, client: &str, interface: &str, from_ns: i64, to_ns: i64) {
        let gap_ns = to_ns - from_ns;
        if self.longest_gap.as_ref().is_none_or(|g| gap_ns > g.gap_ns) {
            self.longest_gap = Some(Gap {
                client: client.to_owned(),
                interface: interface.to_owned(),
                from_ns,
                to_ns,
                gap_ns,
            });
        }
    }

    fn fire(&mut self, timer: Timer, sink: &mut dyn Sink) {
        match timer {
            Timer::Tick {
                service,
                generation,
            } => {
                let Some(sim) = self.sims.get(&service) else {
                    return;
                };
                if sim.generation != generation || sim.instance.is_none() {
                    return;
                }
                let period = sim.tick_period_ns.unwrap_or(i64::MAX);
                if !sim.stalled {
                    self.stats.ticks += 1;
                    self.dispatch(&service, Vec::new(), sink, |s, ctx| s.on_tick(ctx));
                }
                let at = self.now_ns.saturating_add(period);
                self.schedule(
                    at,
                    Timer::Tick {
                        service,
                        generation,
                    },
                );
            }
            Timer::Heartbeat {
                service,
                generation,
            } => {
                let Some(sim) = self.sims.get(&service) else {
                    return;
                };
                if sim.generation != generation || sim.instance.is_none() {
                    return;
                }
                if !sim.stalled {
                    let health = match self.fault_of(&service) {
                        Some(FaultKind::OutOfService) => injected_out_of_service(),
                        _ => sim.state.health().clone(),
                    };
                    self.work.push_back(Work::Broker(Event::Heartbeat {
                        service: service.clone(),
                        health,
                    }));
                }
                let at = self.now_ns.saturating_add(self.heartbeat_period_ns);
                self.schedule(
                    at,
                    Timer::Heartbeat {
                        service,
                        generation,
                    },
                );
            }
            Timer::BrokerDeadline => {
                if self.deadline_at.is_some_and(|d| d <= self.now_ns) {
                    self.deadline_at = None;
                }
                if self.core.next_deadline().is_some_and(|d| d <= self.now_ns) {
                    self.work.push_back(Work::Broker(Event::TimePassed));
                }
            }
            Timer::FaultStarts(i) => self.fault_starts(i, sink),
            Timer::FaultEnds(i) => self.fault_ends(i, sink),
            Timer::Reply(work) => self.work.push_back(*work),
        }
    }

    fn fault_starts(&mut self, i: usize, sink: &mut dyn Sink) {
        let fault = self.faults[i].clone();
        sink.emit(Emitted::Fault {
            fault: &fault,
            time_ns: self.now_ns,
            starts: true,
        });
        let provider = fault.provider.clone();
        match fault.kind {
            FaultKind::Crash => {
                if let Some(sim) = self.sims.get_mut(&provider) {
                    if sim.instance.take().is_none() {
                        return;
                    }
                    sim.generation += 1;
                }
                self.work.push_back(Work::Broker(Event::ProcessExited {
                    service: provider,
                    status: ExitStatus::Signal(SIGABRT),
                }));
            }
            FaultKind::Stall => {
                if let Some(sim) = self.sims.get_mut(&provider) {
                    sim.stalled = true;
                }
            }
            FaultKind::OutOfService => {
                self.work.push_back(Work::Broker(Event::Heartbeat {
                    service: provider,
                    health: injected_out_of_service(),
                }));
            }
            FaultKind::Garbage => {}
        }
    }

    fn fault_ends(&mut self, i: usize, sink: &mut dyn Sink) {
        let fault = self.faults[i].clone();
        sink.emit(Emitted::Fault {
            fault: &fault,
            time_ns: self.now_ns,
            starts: false,
        });
        match fault.kind {
            FaultKind::Stall => {
                if let Some(sim) = self.sims.get_mut(&fault.provider) {
                    sim.stalled = false;
                }
            }
            FaultKind::OutOfService => {
                let health = self
                    .sims
                    .get(&fault.provider)
                    .map_or(Health::Ok, |s| s.state.health().clone());
                self.work.push_back(Work::Broker(Event::Heartbeat {
                    service: fault.provider,
                    health,
                }));
            }
            FaultKind::Crash | FaultKind::Garbage => {}
        }
    }

    /// Carries out queued work until none is left, then sets the broker's next deadline.
    fn pump(&mut self, sink: &mut dyn Sink) {
        while let Some(work) = self.work.pop_front() {
            self.run(work, sink);
        }
        if let Some(deadline) = self.core.next_deadline()
            && self.deadline_at != Some(deadline)
        {
            self.deadline_at = Some(deadline);
            self.schedule(deadline, Timer::BrokerDeadline);
        }
    }

    fn run(&mut self, work: Work, sink: &mut dyn Sink) {
        match work {
            Work::Broker(event) => {
                for decision in self.core.handle(self.now_ns, &event) {
                    sink.emit(Emitted::Decision(&decision));
                    self.carry_out(&decision.action, sink);
                }
            }
            Work::Start {
                service,
                generation,
            } => self.run_start(&service, generation, sink),
            Work::Input {
                client,
                interface,
                provider,
                channel,
                seq,
                bytes,
            } => {
                if let Some(last) = self
                    .last_input
                    .insert((client.clone(), interface.clone()), self.now_ns)
                {
                    self.note_gap(&client, &interface, last, self.now_ns);
                }
                self.stats.inputs_delivered += 1;
                let now_ns = self.now_ns;
                self.feeds
                    .entry((client.clone(), interface.clone(), provider.clone()))
                    .and_modify(|f| {
                        f.samples += 1;
                        f.last_ns = now_ns;
                    })
                    .or_insert_with(|| Feed {
                        client: client.clone(),
                        interface: interface.clone(),
                        provider: provider.clone(),
                        samples: 1,
                        first_ns: now_ns,
                        last_ns: now_ns,
                    });
                let provenance = vec![InputRef {
                    channel: channel.to_string(),
                    seq,
                }];
                self.dispatch(&client, provenance, sink, |s, ctx| {
                    s.on_input(
                        ctx,
                        &Input {
                            interface: &interface,
                            provider: &provider,
                            channel: &channel,
                            bytes: &bytes,
                        },
                    );
                });
            }
            Work::Command {
                target,
                interface,
                command,
                request,
                reply_to,
            } => self.run_command(&target, &interface, &command, request, reply_to, sink),
            Work::Reply {
                caller,
                generation,
                call,
                interface,
                command,
                result,
            } => {
                if self
                    .sims
                    .get(&caller)
                    .is_none_or(|s| s.generation != generation)
                {
                    return;
                }
                let event = ReplyEvent {
                    call,
                    interface: &interface,
                    command: &command,
                    result: result.as_deref().map_err(Clone::clone),
                };
                self.dispatch(&caller, Vec::new(), sink, |s, ctx| s.on_reply(ctx, &event));
            }
        }
    }

    fn carry_out(&mut self, action: &Action, sink: &mut dyn Sink) {
        match action {
            Action::Start { service } => self.start_service(service),
            Action::Stop { service } => self.stop_service(service, sink),
            Action::Bind {
                client,
                interface,
                service,
            } => {
                self.bindings
                    .insert((client.clone(), interface.clone()), service.clone());
            }
            Action::Rebind {
                client,
                interface,
                to,
                ..
            } => {
                self.bindings
                    .insert((client.clone(), interface.clone()), to.clone());
            }
            Action::Unbind {
                client, interface, ..
            } => {
                self.bindings.remove(&(client.clone(), interface.clone()));
            }
            Action::Reject { .. }
            | Action::AskForHelp { .. }
            | Action::RestartScheduled { .. }
            | Action::ServiceFailed { .. } => {}
        }
    }

    fn start_service(&mut self, service: &str) {
        let crashing = self.fault_of(service) == Some(FaultKind::Crash);
        let stalling = self.fault_of(service) == Some(FaultKind::Stall);
        self.work.push_back(Work::Broker(Event::ProviderStarted {
            service: service.to_owned(),
        }));
        if crashing {
            self.work.push_back(Work::Broker(Event::ProcessExited {
                service: service.to_owned(),
                status: ExitStatus::Signal(SIGABRT),
            }));
            return;
        }
        let Some(spec) = self.robot.service(service) else {
            return;
        };
        let Some(sim) = self.sims.get_mut(service) else {
            return;
        };
        let config = ServiceConfig {
            spec,
            heartbeat_period_ms: self.robot.broker.heartbeat_period_ms,
        };
        sim.generation += 1;
        sim.state = ContextState::new(service, config.seed());
        sim.backend = backend_for(spec);
        sim.stalled = stalling;
        sim.commands_answered = 0;
        let generation = sim.generation;
        match self.registry.build(&config) {
            Ok(instance) => {
                sim.tick_period_ns = instance.tick_period_ns().filter(|p| *p > 0);
                sim.instance = Some(instance);
            }
            Err(e) => {
                // Checked when the harness was made; a constructor that fails later is a
                // process that exits at once.
                sim.instance = None;
                let _ = e;
                self.work.push_back(Work::Broker(Event::ProcessExited {
                    service: service.to_owned(),
                    status: ExitStatus::Code(1),
                }));
                return;
            }
        }
        // As the live harness: ask for what it requires, say it is ready, then start it.
        for interface in &spec.requires {
            self.work.push_back(Work::Broker(Event::ClientRequest {
                client: service.to_owned(),
                interface: interface.clone(),
            }));
        }
        if !stalling {
            self.work.push_back(Work::Broker(Event::Heartbeat {
                service: service.to_owned(),
                health: Health::Ok,
            }));
        }
        self.work.push_back(Work::Start {
            service: service.to_owned(),
            generation,
        });
    }

    fn run_start(&mut self, service: &str, generation: u64, sink: &mut dyn Sink) {
        if self
            .sims
            .get(service)
            .is_none_or(|s| s.generation != generation || s.instance.is_none())
        {
            return;
        }
        let mut outcome = Ok(());
        self.dispatch(service, Vec::new(), sink, |s, ctx| {
            outcome = s.on_start(ctx);
        });
        let Some(sim) = self.sims.get_mut(service) else {
            return;
        };
        if let Err(reason) = outcome {
            sim.instance = None;
            sim.generation += 1;
            let text = format!("{service} could not start: {reason}");
            sink.emit(Emitted::Log {
                service,
                time_ns: self.now_ns,
                level: Level::Error,
                text: &text,
            });
            self.work.push_back(Work::Broker(Event::ProcessExited {
                service: service.to_owned(),
                status: ExitStatus::Code(1),
            }));
            return;
        }
        let tick = sim.tick_period_ns;
        let (now, period) = (self.now_ns, self.heartbeat_period_ns);
        if let Some(tick) = tick {
            self.schedule(
                now.saturating_add(tick),
                Timer::Tick {
                    service: service.to_owned(),
                    generation,
                },
            );
        }
        self.schedule(
            now.saturating_add(period),
            Timer::Heartbeat {
                service: service.to_owned(),
                generation,
            },
        );
    }

    fn stop_service(&mut self, service: &str, sink: &mut dyn Sink) {
        let stalled = self.fault_of(service) == Some(FaultKind::Stall);
        let status = match self.sims.get(service) {
            Some(sim) if sim.instance.is_some() && !sim.stalled => {
                self.dispatch(service, Vec::new(), sink, |s, ctx| s.on_stop(ctx));
                ExitStatus::Code(0)
            }
            Some(_) => ExitStatus::Signal(SIGKILL),
            None if stalled => ExitStatus::Signal(SIGKILL),
            None => ExitStatus::Signal(SIGTERM),
        };
        if let Some(sim) = self.sims.get_mut(service) {
            sim.instance = None;
            sim.stalled = false;
            sim.generation += 1;
        }
        self.work.push_back(Work::Broker(Event::ProcessExited {
            service: service.to_owned(),
            status,
        }));
    }

    fn run_command(
        &mut self,
        target: &str,
        interface: &str,
        command: &str,
        request: Vec<u8>,
        reply_to: Option<(String, u64, CallId, i64)>,
        sink: &mut dyn Sink,
    ) {
        let mut outcome = None;
        self.dispatch(target, Vec::new(), sink, |s, ctx| {
            let incoming = IncomingCommand {
                interface,
                command,
                bytes: &request,
            };
            outcome = Some(
                s.on_command(ctx, &incoming)
                    .map(|reply| reply.bytes().to_vec())
                    .map_err(|e| e.0),
            );
        });
        let Some(result) = outcome else {
            // The target did not run (stalled, stopped): the caller times out.
            if let Some((caller, generation, call, timeout_ns)) = reply_to {
                self.stats.calls_failed += 1;
                let at = self.now_ns.saturating_add(timeout_ns);
                self.schedule(
                    at,
                    Timer::Reply(Box::new(Work::Reply {
                        caller,
                        generation,
                        call,
                        interface: interface.to_owned(),
                        command: command.to_owned(),
                        result: Err(CallFailure::Timeout { timeout_ns }),
                    })),
                );
            }
            return;
        };
        let seq = self.sims.get_mut(target).map_or(0, |s| {
            s.commands_answered += 1;
            s.commands_answered
        });
        let mut log = CommandLog {
            header: Header {
                provider: target.to_owned(),
                seq,
                publish_time_ns: self.now_ns,
                inputs: Vec::new(),
            },
            interface: interface.to_owned(),
            command: command.to_owned(),
            request,
            received_ns: self.now_ns,
            ..CommandLog::default()
        };
        match &result {
            Ok(reply) => {
                "ok".clone_into(&mut log.status);
                log.reply.clone_from(reply);
            }
            Err(error) => {
                "refused".clone_into(&mut log.status);
                log.error.clone_from(error);
            }
        }
        sink.emit(Emitted::Command {
            service: target,
            time_ns: self.now_ns,
            log: &log,
        });
        if let Some((caller, generation, call, _)) = reply_to {
            self.work.push_back(Work::Reply {
                caller,
                generation,
                call,
                interface: interface.to_owned(),
                command: command.to_owned(),
                result: result.map_err(CallFailure::Refused),
            });
        }
    }

    /// Runs one handler of a running service, then carries out what it did.
    fn dispatch(
        &mut self,
        name: &str,
        inputs: Vec<InputRef>,
        sink: &mut dyn Sink,
        handler: impl FnOnce(&mut dyn Service, &mut lewis_runtime::service::Context<'_>),
    ) {
        let bound: BTreeMap<String, String> = self
            .bindings
            .range((name.to_owned(), String::new())..)
            .take_while(|((client, _), _)| client == name)
            .map(|((_, interface), provider)| (interface.clone(), provider.clone()))
            .collect();
        let Some(sim) = self.sims.get_mut(name) else {
            return;
        };
        if sim.stalled {
            return;
        }
        let Some(instance) = sim.instance.as_mut() else {
            return;
        };
        sim.backend.now_ns = self.now_ns;
        sim.backend.bound = bound;
        sim.state.set_inputs(inputs);
        handler(instance.as_mut(), &mut sim.state.context(&mut sim.backend));
        sim.state.set_inputs(Vec::new());
        let effects = std::mem::take(&mut sim.backend.effects);
        let generation = sim.generation;
        for effect in effects {
            self.carry_effect(name, generation, effect, sink);
        }
    }

    fn carry_effect(&mut self, name: &str, generation: u64, effect: Effect, sink: &mut dyn Sink) {
        match effect {
            Effect::Publish { interface, bytes } => {
                let seq = decode_header_seq(&bytes);
                let Some(bytes) = self.through_faults(name, seq, &bytes) else {
                    return;
                };
                self.stats.publications += 1;
                sink.emit(Emitted::Publication {
                    service: name,
                    interface: &interface,
                    time_ns: self.now_ns,
                    seq,
                    bytes: &bytes,
                });
                let channel: Arc<str> = Arc::from(names::data_channel(name, &interface));
                self.deliver(name, &interface, &channel, seq, &bytes);
            }
            Effect::Call {
                call,
                interface,
                command,
                frame,
                timeout_ns,
            } => self.call(
                name, generation, call, &interface, command, &frame, timeout_ns,
            ),
            Effect::Health(health) => {
                sink.emit(Emitted::Health {
                    service: name,
                    time_ns: self.now_ns,
                    health: &health,
                });
                let health = match self.fault_of(name) {
                    Some(FaultKind::OutOfService) => injected_out_of_service(),
                    _ => health,
                };
                self.work.push_back(Work::Broker(Event::Heartbeat {
                    service: name.to_owned(),
                    health,
                }));
            }
            Effect::Log { level, text } => sink.emit(Emitted::Log {
                service: name,
                time_ns: self.now_ns,
                level,
                text: &text,
            }),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn call(
        &mut self,
        caller: &str,
        generation: u64,
        call: CallId,
        interface: &str,
        command: &'static str,
        frame: &[u8],
        timeout_ns: i64,
    ) {
        let reply = |result| Work::Reply {
            caller: caller.to_owned(),
            generation,
            call,
            interface: interface.to_owned(),
            command: command.to_owned(),
            result,
        };
        let request = match wire::read_request(frame) {
            Ok((_, message)) => message.to_vec(),
            Err(e) => {
                self.stats.calls_failed += 1;
                self.work
                    .push_back(reply(Err(CallFailure::Transport(e.to_string()))));
                return;
            }
        };
        let Some(provider) = self
            .bindings
            .get(&(caller.to_owned(), interface.to_owned()))
            .cloned()
        else {
            self.stats.calls_failed += 1;
            self.work.push_back(reply(Err(CallFailure::NoProvider {
                interface: interface.to_owned(),
            })));
            return;
        };
        if self.sims.contains_key(&provider) {
            self.stats.calls_between_resimulated += 1;
            self.work.push_back(Work::Command {
                target: provider,
                interface: interface.to_owned(),
                command: command.to_owned(),
                request,
                reply_to: Some((caller.to_owned(), generation, call, timeout_ns)),
            });
            return;
        }
        if matches!(
            self.fault_of(&provider),
            Some(FaultKind::Stall | FaultKind::Crash)
        ) {
            self.stats.calls_failed += 1;
            let at = self.now_ns.saturating_add(timeout_ns);
            self.schedule(
                at,
                Timer::Reply(Box::new(reply(Err(CallFailure::Timeout { timeout_ns })))),
            );
            return;
        }
        let result = match self
            .book
            .take(&provider, interface, command, caller, self.now_ns)
        {
            Some(recorded) => {
                self.stats.calls_answered_from_log += 1;
                recorded.map_err(CallFailure::Refused)
            }
            None => {
                self.stats.calls_defaulted += 1;
                default_reply(interface, command).ok_or_else(|| {
                    CallFailure::Transport(format!(
                        "no recorded answer of {provider} to {interface}.{command}, and no such command to make a default reply for"
                    ))
                })
            }
        };
        self.work.push_back(reply(result));
    }
}

fn backend_for(spec: &lewis_runtime::robot::ServiceSpec) -> StepBackend {
    StepBackend::new(
        &spec.name,
        spec.provides.iter().map(|p| p.interface.clone()),
        spec.requires.iter().cloned(),
    )
}

fn injected_out_of_service() -> Health {
    Health::OutOfService("injected fault: out-of-service".to_owned())
}

/// Bytes that do not decode, of the given length, the same for the same provider and
/// sequence number.
fn garble(provider: &str, seq: u64, len: usize) -> Vec<u8> {
    let mut rng = Rng::new(Rng::seed_from_name(provider) ^ seq);
    let mut out = ENCAPSULATION_LE.to_vec();
    while out.len() < len.max(ENCAPSULATION_LE.len() + 4) {
        out.extend_from_slice(&rng.next_u64().to_le_bytes());
    }
    // A provider string longer than the message: no decoder accepts it.
    out[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    out.truncate(len.max(ENCAPSULATION_LE.len() + 4));
    out
}
