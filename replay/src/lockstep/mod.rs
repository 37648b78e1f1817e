//! The lockstep harness: the broker's decision core and any set of services, in one thread,
//! on a virtual clock, fed recorded publications in a total order.
//!
//! Services are the same code as live: the harness implements the runtime's
//! [`Backend`](lewis_service::Backend) (a virtual clock and an outbox) and drives
//! the [`Service`](lewis_service::Service) trait. Nothing in a service knows it is replayed.
//!
//! # Time and order
//!
//! The virtual time of a recorded message is its *replay time*: when it was made (its
//! header's publish time, which is the time of the handler that made it, see
//! [`lewis_runtime::live`]), or when the recorder got it for a message without one. The
//! reader hands messages over in the total order replay time, then topic, then sequence
//! number (the recorder's latency no longer reorders a sample and the tick that used it).
//! Before a message at time `t` is handled, every timer at or before `t` fires (ticks of
//! free-running services, heartbeats of re-simulated services at the broker's period, the
//! broker's deadlines, fault starts and ends, calls taken up later, call timeouts), in time
//! order, ties in the order they were set.
//!
//! Each event runs one handler of one service; what the handler did (publications, calls,
//! health, logs) is carried out after it returns, through one FIFO queue, so the order of
//! everything is fixed by the order of the events.
//!
//! # Following the recording
//!
//! An unchanged service must compute exactly what it computed live, so it must see the same
//! events in the same order at the same times. A re-simulated service whose outputs are in
//! the recording (and whose tick rate is unchanged) *follows* it ([`Plan::followed`]):
//!
//! - **Ticks when it ticked live.** Every handler run stamps its publications with its time,
//!   so the recorded outputs say when the service handled an event that published. A
//!   ticking service is ticked at the publish times of its recorded outputs, and only then
//!   (the shipped ticking services publish at every tick). A service that publishes from
//!   `on_input` needs nothing: its inputs come, it publishes.
//! - **Gets exactly the inputs it had.** Each recorded output names in its provenance the
//!   newest sample of every input it stood on. A sample that the service's next recorded
//!   event says it had not received yet is held back and handed over right after that
//!   event ([`script`]); every other sample is handed over at its own time.
//! - **Subscribes when it subscribed.** A data channel keeps its newest sample (history
//!   1). A client bound as it starts subscribed before its first heartbeat, where the
//!   replay starts it, so it gets the provider's newest sample at once; a running client
//!   moved to another provider gets that provider's history only with its next sample, as
//!   iceoryx2 connects a late subscriber when the publisher next sends; until it takes in
//!   the move, the old provider's samples its recorded events name still reach it.
//! - **Takes up calls when it took them up.** A call from another re-simulated service
//!   whose request bytes equal a recorded one (same caller, same sequence number, same
//!   virtual time, same arguments) reaches it at the time its recorded command log says;
//!   the reply goes back at once.
//!
//! When the run goes another way (a fault, a changed parameter), the recording still gives
//! the tick times, and provenance that no longer fits holds nothing back: samples of a
//! channel the recorded events do not name (the sonar after a failover) are handed over at
//! their own time, a sample is never held longer than [`script::MAX_HOLD_NS`], and a call
//! unlike any recorded one is taken up at once. A service with no recorded output (one that
//! never ran live, like the sonar started by a failover) runs free: it ticks at its
//! declared rate from its start.
//!
//! # The rest of the world
//!
//! - **Sources** (services not re-simulated) are fed from the log: their data goes to the
//!   re-simulated clients the broker core has bound to them; their recorded heartbeats go to
//!   the broker core. Re-simulated services get synthesised heartbeats.
//! - **Clients**: a re-simulated service asks the core for what it requires when it starts,
//!   as the live harness does; clients that are not re-simulated (other programs, fed
//!   services) are seen through the recorded `bind` decisions and asked for again.
//! - **Calls** to a fed service are answered from its recorded `CommandLog`
//!   ([`CommandBook`]) when it answered such a call live, else with an ok and a default
//!   reply (counted in [`HarnessStats::calls_defaulted`]). A call to a provider that is
//!   stalled, crashed or not running times out after its timeout.
//! - **Commands from outside** (an operator, a sequencer program) that a re-simulated
//!   service answered live are fed to it again at the time it took them up.
//! - **Faults** ([`Fault`]) act on a provider as they would live: a stall silences its data
//!   and heartbeats, a crash makes its process exit (and exit again at every restart while
//!   it lasts), garbage replaces its data with bytes that do not decode, out-of-service
//!   declares it out of service.
//!
//! The harness learns what lies ahead through [`Lockstep::preview`], which the reader calls
//! for every message as it reads it, a bounded time before it is fed: the recorded events
//! and calls of followed services, and the recorded answers of fed services. Nothing of the
//! recording is kept longer than that window, so memory does not grow with its length.

mod backend;
pub mod book;
mod calls;
mod engine;
mod faults;
mod health;
pub mod mission;
mod programs;
pub mod route;
pub mod script;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Broker as BrokerMessage, BrokerAction, CommandLog, HostLink, HostLinkEvent, ProcessCpu,
};
use lewis_robot::Robot;
use lewis_runtime::broker::{BrokerCore, Decision, Event};
use lewis_runtime::live::heartbeat_event;
use lewis_service::Health;
use lewis_service::{BuildError, ContextState, Level, ServiceConfig, ServiceRegistry};
use serde::Serialize;

use crate::fault::{Fault, FaultKind};
pub use book::{CommandBook, default_reply, header_provider};
use engine::{Sim, Timer, Work, backend_for};
use lewis_recording::RecordedMessage;
use mission::MissionRun;
pub use mission::{Answer, AnswerSource, MissionPlan, Program, Programs};
pub use programs::{AppPrograms, ReadAppArgs};
pub use route::{Route, route};
use script::Script;

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
    /// The mission's sequencer made a record ([`mission`]).
    Mission(&'a lewis_sequencer::Record),
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
    /// Samples held back because the recording says the service had not received them
    /// yet at its next event (handed over right after it).
    pub inputs_held: u64,
    /// Samples not handed over because the recording says their client had stopped by
    /// then (`lewis up` stops clients before their providers).
    pub inputs_after_stop: u64,
    /// Ticks run.
    pub ticks: u64,
    /// Of those, ticks at the recorded time of a followed service.
    pub ticks_followed: u64,
    /// Publications of re-simulated services.
    pub publications: u64,
    /// Calls served by another re-simulated service.
    pub calls_between_resimulated: u64,
    /// Of those, calls taken up at the time the server's recorded command log says.
    pub calls_at_recorded_time: u64,
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

/// What to run: which services are re-simulated, which of them follow the recording,
/// which faults are injected.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// The services run in the harness; every other service is fed from the log.
    pub resimulated: BTreeSet<String>,
    /// The re-simulated services that follow the recording (see the module
    /// documentation): those whose outputs are in it and whose tick rate did not change.
    pub followed: BTreeSet<String>,
    /// When the process of each followed service came up live (its first recorded
    /// heartbeat): the broker core may start it earlier, but it comes up no earlier in the
    /// replay, so that calls made to it before then fail as they failed live.
    pub ready_at: BTreeMap<String, i64>,
    /// The faults to inject.
    pub faults: Vec<Fault>,
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

/// The lockstep harness. See the module documentation.
pub struct Lockstep<'a> {
    robot: &'a Robot,
    registry: &'a ServiceRegistry,
    core: BrokerCore,
    sims: BTreeMap<String, Sim>,
    faults: Vec<Fault>,
    book: CommandBook,
    script: Script,
    ready_at: BTreeMap<String, i64>,
    bindings: BTreeMap<(String, String), String>,
    requested: BTreeSet<(String, String)>,
    routes: BTreeMap<Arc<str>, Route>,
    /// Crashes and stuck loops that struck a service while its restart was pending, oldest
    /// first: each strikes a later process at its start instead (a recorded death had a
    /// process to strike live; the replay's restart merely came later than live's).
    strikes: BTreeMap<String, VecDeque<FaultKind>>,
    timers: BTreeMap<(i64, u64), Timer>,
    timer_seq: u64,
    deadline_at: Option<i64>,
    work: VecDeque<Work>,
    now_ns: i64,
    expired_at_ns: i64,
    heartbeat_period_ns: i64,
    stats: HarnessStats,
    last_input: BTreeMap<(String, String), i64>,
    longest_gap: Option<Gap>,
    feeds: BTreeMap<(String, String, String), Feed>,
    mission: Option<MissionRun<'a>>,
    /// The data checks of each provider's channel of each interface ([`health`]).
    watches: BTreeMap<(String, String), health::Watch>,
    /// The last payload of each provider's channel before a `frozen` fault, by provider
    /// and interface: what the fault repeats.
    last_good: BTreeMap<(String, String), Vec<u8>>,
    /// The newest sample of each provider's channel of each interface, by provider and
    /// interface: the channel's history, which a client bound to it later gets.
    latest: BTreeMap<(String, String), engine::Latest>,
    /// Clients, by interface, whose binding changed and whose new subscriber has not had
    /// the channel's history yet (it comes with the provider's next sample).
    history_due: BTreeSet<(String, String)>,
    /// The provider each client was last moved away from and when, by client and
    /// interface: live, the client takes in a rebind when it next wakes, and the old
    /// provider's samples that came before then still reach it (the recording names them).
    left: BTreeMap<(String, String), (String, i64)>,
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

/// How often recorded answers and calls the replay did not use are forgotten.
const EXPIRE_EVERY_NS: i64 = book::MATCH_WINDOW_NS;

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
                    known: robot.service_names(),
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
                    held: VecDeque::new(),
                    subscribed: BTreeSet::new(),
                },
            );
        }
        let followed = plan
            .followed
            .iter()
            .filter(|s| plan.resimulated.contains(*s))
            .map(|s| {
                let deadline_ms = robot
                    .service(s)
                    .map_or(robot.broker.heartbeat_deadline_ms, |spec| {
                        spec.heartbeat_deadline_ms
                    });
                let deadline_ns = i64::try_from(deadline_ms.saturating_mul(1_000_000));
                (s.clone(), deadline_ns.unwrap_or(i64::MAX))
            });
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
            book: CommandBook::new(),
            script: Script::new(followed),
            ready_at: plan.ready_at,
            bindings: BTreeMap::new(),
            requested: BTreeSet::new(),
            routes: BTreeMap::new(),
            strikes: BTreeMap::new(),
            timers: BTreeMap::new(),
            timer_seq: 0,
            deadline_at: None,
            work: VecDeque::new(),
            now_ns: 0,
            expired_at_ns: i64::MIN,
            heartbeat_period_ns,
            stats: HarnessStats::default(),
            last_input: BTreeMap::new(),
            longest_gap: None,
            feeds: BTreeMap::new(),
            mission: None,
            watches: BTreeMap::new(),
            last_good: BTreeMap::new(),
            latest: BTreeMap::new(),
            history_due: BTreeSet::new(),
            left: BTreeMap::new(),
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
        // The core starts the other hosts lost, as live; `/lewis/hosts` joins them.
        self.work.push_back(Work::Broker(Event::BrokerStarted));
        self.pump(sink);
    }

    /// Takes note of a recorded message read ahead of the clock, whose replay time is
    /// `at_ns`: the events of followed services, the calls they took up from each other and
    /// the answers of fed services. Call it for every message, in reading order, before
    /// the message is fed.
    pub fn preview(&mut self, message: &RecordedMessage, at_ns: i64) {
        self.script.read_to(at_ns);
        match self.route_of(&message.topic) {
            Route::Data { service, .. } => {
                let input = lewis_service::Input {
                    interface: "",
                    provider: "",
                    channel: &message.topic,
                    bytes: &message.data,
                };
                if self.script.follows(&service)
                    && let Ok(header) = input.header()
                {
                    self.script.expect_event(&service, at_ns, &header.inputs);
                }
            }
            Route::Commands { service } => {
                let Ok(log) = cdr::from_bytes::<CommandLog>(&message.data) else {
                    return;
                };
                if !self.sims.contains_key(&service) {
                    self.book.add(&service, at_ns, &log);
                    return;
                }
                let caller = header_provider(&log.request);
                if self.sims.contains_key(&caller) {
                    // The time it was taken up, which is the log's time in recordings
                    // made by this version (the handler's time).
                    let taken = if (at_ns.saturating_sub(script::MAX_HOLD_NS)..=at_ns)
                        .contains(&log.received_ns)
                    {
                        log.received_ns
                    } else {
                        at_ns
                    };
                    self.script
                        .expect_call(&service, &caller, &log.request, taken);
                }
            }
            Route::Health { service } => self.script.expect_life(&service, at_ns),
            Route::Broker | Route::Cpu | Route::Hosts | Route::Other => {}
        }
    }

    /// Every message of the recording has been previewed: a followed service not heard of
    /// again had stopped.
    pub fn read_whole(&mut self) {
        self.script.read_whole();
    }

    /// Runs everything due up to `at_ns` (the message's replay time), then hands the message
    /// to whoever it is for.
    pub fn feed(&mut self, message: &RecordedMessage, at_ns: i64, sink: &mut dyn Sink) {
        self.advance_to(at_ns, sink);
        match self.route_of(&message.topic) {
            Route::Data { service, interface } => {
                if self.sims.contains_key(&service) {
                    self.recorded_event(&service, sink);
                    return;
                }
                let Some(bytes) =
                    self.through_faults(&service, &interface, message.seq, &message.data)
                else {
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
                let event = match self.fault_of(&service) {
                    Some(
                        FaultKind::Stall
                        | FaultKind::Crash
                        | FaultKind::Stuck
                        | FaultKind::HostLost,
                    ) => return,
                    Some(FaultKind::OutOfService) => Event::Heartbeat {
                        service,
                        health: faults::injected_out_of_service(),
                    },
                    // A heartbeat, or the service's word that its loop was stuck, as live.
                    _ => heartbeat_event(&service, &health),
                };
                self.work.push_back(Work::Broker(event));
            }
            Route::Commands { service } => {
                if !self.sims.contains_key(&service) {
                    return;
                }
                let Ok(log) = cdr::from_bytes::<CommandLog>(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                // A re-simulated caller makes its call again by itself, and so do the
                // programs of a mission run in the harness.
                let caller = header_provider(&log.request);
                if self.sims.contains_key(&caller) || self.is_mission_client(&caller) {
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
                let is_request = matches!(
                    BrokerAction::parse(&decision.action),
                    Some(BrokerAction::Bind | BrokerAction::Reject)
                );
                if is_request
                    && !decision.client.is_empty()
                    && !self.sims.contains_key(&decision.client)
                    && !self.is_mission_client(&decision.client)
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
            Route::Cpu => {
                let Ok(measured) = cdr::from_bytes::<ProcessCpu>(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                // The live broker's measurement, as it was fed: replay decides the same.
                self.work.push_back(Work::Broker(Event::CpuMeasured {
                    service: measured.service,
                    milli_cores: u32::try_from(measured.milli_cores).unwrap_or(0),
                }));
            }
            Route::Hosts => {
                let Ok(heard) = cdr::from_bytes::<HostLink>(&message.data) else {
                    self.stats.undecodable += 1;
                    return;
                };
                // The live broker's word on its hosts, as it was fed: replay loses and
                // joins them when it did.
                match HostLinkEvent::parse(&heard.event) {
                    Some(HostLinkEvent::Joined) => {
                        self.work
                            .push_back(Work::Broker(Event::HostJoined { host: heard.host }));
                    }
                    Some(HostLinkEvent::Lost) => {
                        self.work.push_back(Work::Broker(Event::HostLost {
                            host: heard.host,
                            why: heard.reason,
                        }));
                    }
                    Some(HostLinkEvent::Heard) | None => {}
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
        if self.now_ns.saturating_sub(self.expired_at_ns) >= EXPIRE_EVERY_NS {
            self.expired_at_ns = self.now_ns;
            self.book.expire(self.now_ns);
            self.script.expire_calls(self.now_ns);
        }
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

    fn route_of(&mut self, topic: &Arc<str>) -> Route {
        if let Some(route) = self.routes.get(topic) {
            return route.clone();
        }
        let found = route(topic, self.robot);
        self.routes.insert(topic.clone(), found.clone());
        found
    }

    /// A recorded output of the re-simulated `service` is due now: when it follows the
    /// recording and the output is the first of an event, the event happens now.
    fn recorded_event(&mut self, service: &str, sink: &mut dyn Sink) {
        self.script.drop_past(service, self.now_ns);
        if self.script.take_event(service, self.now_ns).is_none() {
            return;
        }
        let ticking = self
            .sims
            .get(service)
            .is_some_and(|s| s.instance.is_some() && !s.stalled && s.tick_period_ns.is_some());
        if ticking {
            self.stats.ticks += 1;
            self.stats.ticks_followed += 1;
            self.dispatch(service, Vec::new(), sink, |s, ctx| s.on_tick(ctx));
            self.pump(sink);
        }
        self.release_held(service, sink);
    }
}
