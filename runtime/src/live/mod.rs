//! The live harness: one service in its own process (`lewis service NAME --robot FILE`).
//!
//! It builds the service from a [`ServiceRegistry`], opens IPC in the namespace (the node is
//! named after the service), publishes every interface the service provides on
//! `/<service>/<Interface>` and serves its commands on `/<service>/<Interface>/cmd`, asks the
//! broker for every interface it requires (through [`RawClient`]s that follow rebinding),
//! ticks at the service's rate, publishes a heartbeat ([`Health`](lewis_interfaces::msg::Health))
//! at the broker's period and at once when the declared health changes, and waits on one
//! [`WaitSet`] for all of it (event wake-ups, no polling), the service's device and the stop
//! signals. SIGTERM or SIGINT end it cleanly: `on_stop` runs, the process exits with 0.
//!
//! A heartbeat means "this service is responsive". A thread of its own sends them
//! (`heartbeat.rs`), watching the steps of this loop: when a step has used more CPU than
//! the heartbeat deadline or has slept in a handler past it, it says `stalled` once and
//! stops, and that is how the broker sees a service stuck in a handler, while one that only
//! waits for a core on a busy machine keeps beating. The first heartbeat (the service
//! is ready) goes once `on_start` has returned: `on_start` may block (open a device, probe
//! its baud rate) for up to the startup deadline. After that every handler must use well
//! under the heartbeat deadline; one that uses more than half of it is reported once
//! (`overrun.rs`). Work that blocks (a device that may go silent for seconds) belongs in a
//! device reader that the loop waits on (see [`Service::device`]).
//!
//! The service's clock ([`Context::now`]) reads the time its current event was taken up, for
//! the whole handler, as in the lockstep replay harness: every publication of one handler
//! carries that time, so a recording says exactly when each handler ran and replay can run
//! it again at that time (the answered-command log carries it too, as `received_ns`). That
//! clock is the machine's, or the time of a recording played live ([`ClockSource`],
//! [`service_clock`]); heartbeats always keep the machine's time, since the broker is live.

pub mod fault;
mod heartbeat;
mod overrun;
pub mod service_clock;
mod signals;

pub use service_clock::{CLOCK_ENV, ClockSource, UnknownClock};
pub use signals::{StopHandle, StopSignals};

use std::collections::BTreeMap;
use std::os::fd::AsFd;
use std::rc::Rc;
use std::time::{Duration, Instant};

use lewis_interfaces::msg::{
    CommandLog, CommandLogStatus, Health as HealthMessage, HealthState, InputRef,
};

use crate::client::{ClientError, RawClient};
use crate::ipc::{
    CallError, CallId as IpcCallId, CommandServer, FdSource, Ipc, IpcError, Namespace, Publisher,
    WaitError, WaitSet, Waitable, WakeMode, Woken,
};
use crate::names;
use lewis_robot::Robot;
use lewis_service::Health;
use lewis_service::wire;
use lewis_service::{
    Backend, BuildError, CallFailure, CallId, Context, ContextError, ContextState, IncomingCommand,
    Level, ReplyEvent, Service, ServiceConfig, ServiceRegistry,
};
use service_clock::ServiceClock;

/// Why a service could not run.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The robot has no service of that name.
    #[error("robot `{robot}` has no service `{service}`; it has: {known}")]
    UnknownService {
        /// The robot.
        robot: String,
        /// The name asked for.
        service: String,
        /// The services it has.
        known: String,
    },
    /// The service could not be built.
    #[error(transparent)]
    Build(#[from] BuildError),
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A required interface could not be asked for.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// The stop signals could not be caught.
    #[error("cannot catch SIGTERM and SIGINT: {0}")]
    Signals(std::io::Error),
    /// The service's `on_start` refused to start.
    #[error("service `{service}` could not start: {reason}")]
    Start {
        /// The service.
        service: String,
        /// What it said.
        reason: String,
    },
}

/// Runs service `service` of `robot` until SIGTERM or SIGINT.
///
/// # Errors
/// When the service is unknown, cannot be built or started, or IPC fails.
pub fn run_service(
    robot: &Robot,
    service: &str,
    registry: &ServiceRegistry,
    namespace: &Namespace,
    clock_source: ClockSource,
) -> Result<(), LiveError> {
    let spec = robot
        .service(service)
        .ok_or_else(|| LiveError::UnknownService {
            robot: robot.name.clone(),
            service: service.to_owned(),
            known: robot.service_names(),
        })?;
    let config = ServiceConfig {
        spec,
        heartbeat_period_ms: robot.broker.heartbeat_period_ms,
    };
    let mut instance = registry.build(&config)?;
    let run = Run {
        name: &spec.name,
        provides: &spec.provides,
        requires: &spec.requires,
        startup_deadline_ms: spec.startup_deadline_ms,
        handler_deadline_ms: spec.heartbeat_deadline_ms,
        seed: config.seed(),
        heartbeat_period_ms: Some(robot.broker.heartbeat_period_ms),
        heartbeat_priority: robot.broker.heartbeat_priority,
    };
    run_one(&run, instance.as_mut(), namespace, clock_source)?;
    Ok(())
}

/// What a sub-task program is to the live harness: its node's name, the interfaces it asks
/// the broker for, and the seed of its random source.
#[derive(Debug, Clone)]
pub struct ProgramSpec {
    /// The node's name, and the client's name in the broker's bindings.
    pub name: String,
    /// The interfaces it asks the broker for.
    pub requires: Vec<String>,
    /// The seed of [`Context::rng`].
    pub seed: u64,
}

/// The exit code of a program stopped by SIGTERM or SIGINT before it finished: a shell's
/// 128 + SIGTERM, so the sequencer never takes a stopped program for one that succeeded.
pub const STOPPED_EXIT_CODE: i32 = 143;

/// Runs a sub-task program (the sequencer's child, not a service of the robot file) until
/// it finishes ([`Service::exit_code`]) or SIGTERM or SIGINT stop it, and returns the code
/// its process should exit with ([`STOPPED_EXIT_CODE`] when stopped).
///
/// It is the service harness without what only a provider needs: no publications, no
/// command servers, no heartbeats (the broker does not supervise it: the sequencer does).
/// Its clients follow the broker's rebinding like any service's.
///
/// # Errors
/// When `on_start` refuses or IPC fails.
pub fn run_program(
    program: &ProgramSpec,
    instance: &mut dyn Service,
    namespace: &Namespace,
    clock_source: ClockSource,
) -> Result<i32, LiveError> {
    let run = Run {
        name: &program.name,
        provides: &[],
        requires: &program.requires,
        startup_deadline_ms: PROGRAM_HANDLER_DEADLINE_MS,
        handler_deadline_ms: PROGRAM_HANDLER_DEADLINE_MS,
        seed: program.seed,
        heartbeat_period_ms: None,
        heartbeat_priority: 0,
    };
    Ok(run_one(&run, instance, namespace, clock_source)?.unwrap_or(STOPPED_EXIT_CODE))
}

/// A program has no heartbeat deadline; a handler slower than this is still worth a
/// warning, as a service's would be.
const PROGRAM_HANDLER_DEADLINE_MS: u64 = 1000;

/// One service or program to run.
struct Run<'a> {
    name: &'a str,
    provides: &'a [lewis_robot::Provision],
    requires: &'a [String],
    startup_deadline_ms: u64,
    /// The heartbeat deadline: what a handler may take.
    handler_deadline_ms: u64,
    seed: u64,
    /// `None` for a program: no heartbeats.
    heartbeat_period_ms: Option<u64>,
    /// The heartbeat thread's real-time priority (0: none).
    heartbeat_priority: u8,
}

/// Runs `instance` until a stop signal (`None`) or until it finishes (its exit code).
fn run_one(
    run: &Run<'_>,
    instance: &mut dyn Service,
    namespace: &Namespace,
    clock_source: ClockSource,
) -> Result<Option<i32>, LiveError> {
    let signals = StopSignals::install().map_err(LiveError::Signals)?;
    let ipc = Rc::new(Ipc::open(namespace, run.name)?);
    let time = ServiceClock::open(clock_source, &ipc)?;

    let mut publishers = BTreeMap::new();
    let mut servers = Vec::new();
    for provision in run.provides {
        let interface = &provision.interface;
        publishers.insert(
            interface.clone(),
            ipc.publisher(
                &names::data_channel(run.name, interface),
                &names::data_config(interface),
            )?,
        );
        servers.push((
            interface.clone(),
            ipc.command_server(
                &names::command_channel(run.name, interface),
                &names::command_config(),
            )?,
        ));
    }
    let mut clients = BTreeMap::new();
    for interface in run.requires {
        clients.insert(
            interface.clone(),
            RawClient::new(&ipc, run.name, interface)?,
        );
    }
    // A provider's answered commands; a program answers none.
    let command_log = match run.heartbeat_period_ms {
        Some(_) => Some(ipc.publisher(
            &names::command_log_channel(run.name),
            &names::command_log_config(),
        )?),
        None => None,
    };
    let mut backend = LiveBackend {
        service: run.name.to_owned(),
        time,
        publishers,
        clients,
        calls: BTreeMap::new(),
        watch: heartbeat::LoopWatch::new(),
        fault: fault::FaultState::Normal,
        frozen: BTreeMap::new(),
        garbled: 0,
        command_log,
        command_log_seq: 0,
        event_ns: 0,
    };
    let mut state = ContextState::new(run.name, run.seed);

    let mut overruns = overrun::OverrunWatch::new(
        run.name,
        Duration::from_millis(run.startup_deadline_ms),
        Duration::from_millis(run.handler_deadline_ms),
    );
    // Made before the first heartbeat, like every other endpoint: from that heartbeat on,
    // the heartbeat deadline applies, and opening an iceoryx2 service can take tens of
    // milliseconds on a loaded machine.
    let faults = ipc.command_server(&fault::fault_channel(run.name), &fault::fault_config())?;
    let started = Instant::now();
    instance
        .on_start(&mut event_context(&mut state, &mut backend))
        .map_err(|reason| LiveError::Start {
            service: run.name.to_owned(),
            reason,
        })?;
    overruns.ran("on_start", started.elapsed());
    // The first heartbeat says "ready": after on_start, which the startup deadline covers.
    if let Some(period_ms) = run.heartbeat_period_ms {
        backend.watch.start_heartbeats(&heartbeat::HeartbeatPlan {
            namespace,
            service: run.name,
            period: Duration::from_millis(period_ms),
            deadline: Duration::from_millis(run.handler_deadline_ms),
            setup_deadline: Duration::from_millis(run.startup_deadline_ms),
            realtime_priority: run.heartbeat_priority,
        })?;
    }
    let mut harness = Harness {
        service: instance,
        state,
        backend,
        servers,
        faults,
        waits: WaitSet::new(WakeMode::Event),
        tick_period_ns: None,
        overruns,
    };
    harness.tick_period_ns = harness.service.tick_period_ns().filter(|ns| *ns > 0);
    let finished = harness.run(&signals)?;
    if finished.is_some() {
        // A program that finished leaves while the broker runs on: it says goodbye and
        // waits to be heard, so that its bindings end as released, not as a death.
        for client in harness.backend.clients.values_mut() {
            client.release_and_wait(PROGRAM_RELEASE_TIMEOUT);
        }
    }
    Ok(finished)
}

/// How long a finished program waits for the broker to hear each release.
const PROGRAM_RELEASE_TIMEOUT: Duration = Duration::from_millis(500);

struct Harness<'s> {
    service: &'s mut dyn Service,
    state: ContextState,
    backend: LiveBackend,
    servers: Vec<(String, CommandServer)>,
    /// Injected faults ([`fault`]).
    faults: CommandServer,
    waits: WaitSet,
    /// On the service's clock.
    tick_period_ns: Option<i64>,
    overruns: overrun::OverrunWatch,
}

impl Harness<'_> {
    /// Runs until a stop signal (`None`) or until the service finishes (its exit code).
    fn run(&mut self, signals: &StopSignals) -> Result<Option<i32>, LiveError> {
        // On the service's clock: a played clock's ticks follow the recording's time.
        let mut next_tick: Option<i64> = None;
        let mut device_ready = false;
        let finished = loop {
            if signals.take() {
                break None;
            }
            if let Some(code) = self.service.exit_code() {
                break Some(code);
            }
            if self.serve_faults() {
                // Stalled: only a stop signal or another fault wakes it.
                self.wait_stalled(signals)?;
                continue;
            }
            if let Some(period_ns) = self.tick_period_ns {
                let now_ns = self.backend.time.now_ns();
                match next_tick {
                    // The first tick one period after the start, or after the played
                    // clock's first sample.
                    None if self.backend.time.started() => {
                        next_tick = Some(now_ns.saturating_add(period_ns));
                    }
                    Some(at) if now_ns >= at => {
                        self.backend.watch.step();
                        self.service
                            .on_tick(&mut event_context(&mut self.state, &mut self.backend));
                        self.handled("on_tick");
                        next_tick = Some(advance_ns(at, period_ns, now_ns));
                    }
                    // A played clock that went back (the player started again).
                    Some(at) if at.saturating_sub(now_ns) > period_ns => {
                        next_tick = Some(now_ns.saturating_add(period_ns));
                    }
                    _ => {}
                }
            }
            self.serve_commands();
            self.take_inputs()?;
            if device_ready {
                self.backend.watch.step();
                self.service
                    .on_device(&mut event_context(&mut self.state, &mut self.backend));
                self.handled("on_device");
            }
            let tick_due = next_tick.and_then(|at| self.backend.time.instant_at(at));
            let deadline = tick_due
                .into_iter()
                .chain(
                    self.backend
                        .clients
                        .values()
                        .filter_map(RawClient::deadline),
                )
                .min();
            if self.service.exit_code().is_some() {
                // Finished in this round's handlers: stop now, without waiting.
                device_ready = false;
                continue;
            }
            device_ready = self.wait(signals, deadline)?;
        };
        self.service
            .on_stop(&mut event_context(&mut self.state, &mut self.backend));
        Ok(finished)
    }

    /// After each handler: the CPU it used (IPC work left out) is watched.
    fn handled(&mut self, handler: &'static str) {
        self.overruns.ran(handler, self.backend.watch.step_cpu());
    }

    /// Waits for anything to do; returns whether the device is readable.
    fn wait(&self, signals: &StopSignals, deadline: Option<Instant>) -> Result<bool, LiveError> {
        let signal_fd = FdSource::new(signals.as_fd());
        let device_fd = self.service.device().map(FdSource::new);
        let mut sources: Vec<&dyn Waitable> = vec![&signal_fd];
        if let Some(device) = &device_fd {
            sources.push(device);
        }
        sources.extend(self.backend.time.waitable());
        for (_, server) in &self.servers {
            sources.push(server);
        }
        for client in self.backend.clients.values() {
            sources.extend(client.waitables());
        }
        // The device, when there is one, is source 1.
        self.backend.watch.waiting();
        let woken = self.waits.wait(&sources, deadline);
        self.backend.watch.step();
        Ok(match woken? {
            Woken::Ready(fired) => device_fd.is_some() && fired.contains(1),
            Woken::DeadlineReached | Woken::Interrupted => false,
        })
    }

    fn serve_commands(&mut self) {
        for (interface, server) in &self.servers {
            while let Ok(Some(request)) = self.backend.watch.ipc(|| server.receive()) {
                let received_ns = self.backend.time.now_ns();
                self.backend.event_ns = received_ns;
                let mut logged = (String::new(), request.bytes().to_vec());
                let answer = match wire::read_request(request.bytes()) {
                    Ok((command, bytes)) => {
                        logged = (command.to_owned(), bytes.to_vec());
                        let incoming = IncomingCommand {
                            interface,
                            command,
                            bytes,
                        };
                        self.state.set_inputs(Vec::new());
                        self.backend.watch.step();
                        let answer = self
                            .service
                            .on_command(&mut self.state.context(&mut self.backend), &incoming)
                            .map(lewis_service::Reply::into_bytes)
                            .map_err(|e| e.0);
                        self.overruns
                            .ran("on_command", self.backend.watch.step_cpu());
                        answer
                    }
                    Err(e) => Err(e.to_string()),
                };
                let frame = wire::reply_to_vec(&answer);
                if let Err(e) = self.backend.watch.ipc(|| server.reply(request, &frame)) {
                    tracing::warn!(service = self.backend.service, "cannot reply: {e}");
                }
                let (command, request) = logged;
                self.backend
                    .log_command(interface, command, request, answer, received_ns);
            }
        }
    }

    fn take_inputs(&mut self) -> Result<(), LiveError> {
        let interfaces: Vec<String> = self.backend.clients.keys().cloned().collect();
        for interface in interfaces {
            let Some(client) = self.backend.clients.get_mut(&interface) else {
                continue;
            };
            // A new binding opens the new provider's channel.
            if self.backend.watch.ipc(|| client.process())?.is_some() {
                self.fail_calls_of(&interface);
            }
            while let Some(client) = self.backend.clients.get_mut(&interface) {
                let provider = client.provider().unwrap_or_default().to_owned();
                let channel = client.data_channel().to_owned();
                let Some(received) = self.backend.watch.ipc(|| client.receive())? else {
                    break;
                };
                let seq = lewis_service::decode_header_seq(received.bytes());
                self.state.set_inputs(vec![InputRef {
                    channel: channel.clone(),
                    seq,
                }]);
                let input = lewis_service::Input {
                    interface: &interface,
                    provider: &provider,
                    channel: &channel,
                    bytes: received.bytes(),
                };
                self.backend.watch.step();
                self.service.on_input(
                    &mut event_context(&mut self.state, &mut self.backend),
                    &input,
                );
                self.handled("on_input");
            }
            self.state.set_inputs(Vec::new());
            while let Some(outcome) = self
                .backend
                .clients
                .get_mut(&interface)
                .and_then(RawClient::take_call_outcome)
            {
                let Some((call, command)) = self
                    .backend
                    .calls
                    .remove(&(interface.clone(), outcome.call))
                else {
                    continue;
                };
                let frame;
                let result = match outcome.result {
                    Ok(reply) => {
                        frame = reply;
                        match wire::read_reply(frame.bytes()) {
                            Ok(Ok(bytes)) => Ok(bytes),
                            Ok(Err(refusal)) => Err(CallFailure::Refused(refusal)),
                            Err(e) => Err(CallFailure::Transport(e.to_string())),
                        }
                    }
                    Err(CallError::Timeout { timeout, .. }) => Err(CallFailure::Timeout {
                        timeout_ns: i64::try_from(timeout.as_nanos()).unwrap_or(i64::MAX),
                    }),
                    Err(e) => Err(CallFailure::Transport(e.to_string())),
                };
                let event = ReplyEvent {
                    call,
                    interface: &interface,
                    command,
                    result,
                };
                self.backend.watch.step();
                self.service.on_reply(
                    &mut event_context(&mut self.state, &mut self.backend),
                    &event,
                );
                self.handled("on_reply");
            }
        }
        Ok(())
    }

    /// The calls to a provider the client just left will never be answered.
    fn fail_calls_of(&mut self, interface: &str) {
        let lost: Vec<(String, IpcCallId)> = self
            .backend
            .calls
            .keys()
            .filter(|(i, _)| i == interface)
            .cloned()
            .collect();
        for key in lost {
            if let Some((call, command)) = self.backend.calls.remove(&key) {
                let event = ReplyEvent {
                    call,
                    interface,
                    command,
                    result: Err(CallFailure::NoProvider {
                        interface: interface.to_owned(),
                    }),
                };
                self.service.on_reply(
                    &mut event_context(&mut self.state, &mut self.backend),
                    &event,
                );
            }
        }
    }
}

/// The context of one event. The service's clock reads the time the event was taken up for
/// the whole handler, as in the lockstep harness: what a handler computes from `now` and the
/// publish times it stamps agree, so a replay that runs the handler at that recorded time
/// computes the same.
fn event_context<'a>(state: &'a mut ContextState, backend: &'a mut LiveBackend) -> Context<'a> {
    backend.event_ns = backend.time.now_ns();
    state.context(backend)
}

/// The next time of a periodic event after `at`: one period later, or one period from now
/// when the loop fell behind (missed periods are skipped, not caught up in a burst).
fn advance(at: Instant, period: Duration, now: Instant) -> Instant {
    let next = at + period;
    if next <= now { now + period } else { next }
}

/// [`advance`] on the service's clock.
fn advance_ns(at: i64, period: i64, now: i64) -> i64 {
    let next = at.saturating_add(period);
    if next <= now {
        now.saturating_add(period)
    } else {
        next
    }
}

struct LiveBackend {
    service: String,
    /// The service's clock: events, ticks, publish times.
    time: ServiceClock,
    publishers: BTreeMap<String, Publisher>,
    clients: BTreeMap<String, RawClient>,
    calls: BTreeMap<(String, IpcCallId), (CallId, &'static str)>,
    /// The loop's steps, and the heartbeats sent from them (none for a program: the broker
    /// does not supervise it).
    watch: heartbeat::LoopWatch,
    /// The fault injected from outside, if any ([`fault`]).
    fault: fault::FaultState,
    /// Under a `frozen` fault, the payload repeated, by interface.
    frozen: BTreeMap<String, Vec<u8>>,
    /// Samples garbled so far: each garbage sample differs from the last.
    garbled: u64,
    /// `/lewis/commands/<service>`: every answered command, for the recorder (`None` for a
    /// program, which answers none).
    command_log: Option<Publisher>,
    command_log_seq: u64,
    /// The time the event being handled was taken up: the service's clock.
    event_ns: i64,
}

impl LiveBackend {
    /// Publishes a command this service answered, with its reply, on
    /// `/lewis/commands/<service>`.
    fn log_command(
        &mut self,
        interface: &str,
        command: String,
        request: Vec<u8>,
        answer: Result<Vec<u8>, String>,
        received_ns: i64,
    ) {
        let Some(publisher) = self.command_log.as_mut() else {
            return;
        };
        self.command_log_seq += 1;
        let (status, reply, error) = match answer {
            Ok(reply) => (CommandLogStatus::Ok, reply, String::new()),
            Err(error) => (CommandLogStatus::Refused, Vec::new(), error),
        };
        let mut message = CommandLog {
            interface: interface.to_owned(),
            command,
            request,
            status: status.into(),
            reply,
            error,
            received_ns,
            ..CommandLog::default()
        };
        // The time of the event, like every publication of the handler that answered it.
        if let Err(e) = publisher.publish_stamped(
            &mut message,
            &self.service,
            self.command_log_seq,
            received_ns,
        ) {
            tracing::warn!(service = self.service, "cannot publish a command log: {e}");
        }
    }
}

/// The `state` and `reason` fields of a Health message.
#[must_use]
pub fn health_fields(health: &Health) -> (HealthState, &str) {
    match health {
        Health::Ok => (HealthState::Ok, ""),
        Health::Degraded(why) => (HealthState::Degraded, why),
        Health::OutOfService(why) => (HealthState::OutOfService, why),
    }
}

/// The health a Health message declares (an unknown state counts as degraded).
#[must_use]
pub fn health_from_message(message: &HealthMessage) -> Health {
    health_from_fields(&message.state, &message.reason)
}

/// The health that a `state` and `reason` pair declares, as [`health_fields`] wrote them
/// (an unknown state counts as degraded).
#[must_use]
pub fn health_from_fields(state: &str, reason: &str) -> Health {
    match HealthState::parse(state) {
        Some(HealthState::Ok) => Health::Ok,
        // Stalled: its loop is stuck, it provides nothing now (the broker fails it on the
        // message itself, `heartbeat_event`).
        Some(HealthState::OutOfService | HealthState::Stalled) => {
            Health::OutOfService(reason.to_owned())
        }
        Some(HealthState::Degraded) => Health::Degraded(reason.to_owned()),
        None => Health::Degraded(format!("unknown health state `{state}`: {reason}")),
    }
}

/// The broker event a Health message of `service` stands for: a heartbeat with the health
/// it declares, or, for `stalled`, its heartbeat thread's word that the loop is stuck. The
/// live broker and replay read heartbeats through this one function, so they decide alike.
#[must_use]
pub fn heartbeat_event(service: &str, message: &HealthMessage) -> crate::broker::Event {
    if HealthState::parse(&message.state) == Some(HealthState::Stalled) {
        return crate::broker::Event::LoopStuck {
            service: service.to_owned(),
            why: message.reason.clone(),
        };
    }
    crate::broker::Event::Heartbeat {
        service: service.to_owned(),
        health: health_from_message(message),
    }
}

impl Backend for LiveBackend {
    fn now_ns(&self) -> i64 {
        self.event_ns
    }

    fn publishing(&self) -> bool {
        !matches!(
            self.fault,
            fault::FaultState::OutOfService | fault::FaultState::Stalled
        )
    }

    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        let publisher =
            self.publishers
                .get_mut(interface)
                .ok_or_else(|| ContextError::NotProvided {
                    service: self.service.clone(),
                    interface: interface.to_owned(),
                })?;
        let faulted = match self.fault {
            fault::FaultState::Normal => None,
            fault::FaultState::Frozen | fault::FaultState::Garbage => {
                let mut sample = vec![0; len_bytes];
                encode(&mut sample);
                Some(if self.fault == fault::FaultState::Garbage {
                    self.garbled += 1;
                    lewis_service::fault::garbled_payload(&self.service, self.garbled, len_bytes)
                } else {
                    match self.frozen.get(interface) {
                        Some(first) => lewis_service::fault::frozen_payload(first, &sample),
                        None => {
                            self.frozen.insert(interface.to_owned(), sample.clone());
                            sample
                        }
                    }
                })
            }
            // Stalled or out of service: the publication is dropped.
            fault::FaultState::OutOfService | fault::FaultState::Stalled => return Ok(()),
        };
        self.watch
            .ipc(|| match &faulted {
                None => publisher.publish_with(len_bytes, |buf| encode(buf)),
                Some(bytes) => {
                    publisher.publish_with(bytes.len(), |buf| buf.copy_from_slice(bytes))
                }
            })
            .map(|_| ())
            .map_err(|e| ContextError::Publish {
                interface: interface.to_owned(),
                reason: e.to_string(),
            })
    }

    fn call(
        &mut self,
        call: CallId,
        interface: &str,
        command: &'static str,
        frame: &[u8],
        timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        let client = self
            .clients
            .get_mut(interface)
            .ok_or_else(|| CallFailure::NotRequired {
                interface: interface.to_owned(),
            })?;
        let timeout = Duration::from_nanos(u64::try_from(timeout_ns).unwrap_or(0));
        let id = self
            .watch
            .ipc(|| client.call(frame, timeout))
            .map_err(|e| match e {
                ClientError::Unbound { .. } | ClientError::Call(CallError::NoServer { .. }) => {
                    CallFailure::NoProvider {
                        interface: interface.to_owned(),
                    }
                }
                e => CallFailure::Transport(e.to_string()),
            })?;
        self.calls
            .insert((interface.to_owned(), id), (call, command));
        Ok(())
    }

    fn health_changed(&mut self, health: &Health) {
        self.watch.declare(health);
    }

    fn log(&mut self, service: &str, level: Level, text: &str) {
        match level {
            Level::Error => tracing::error!(service, "{text}"),
            Level::Warn => tracing::warn!(service, "{text}"),
            Level::Info => tracing::info!(service, "{text}"),
            Level::Debug => tracing::debug!(service, "{text}"),
        }
    }
}
