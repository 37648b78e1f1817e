//! The broker's live driver, the heart of `lewis up`: it runs the [`BrokerCore`] on real
//! processes, heartbeats, requests and timers.
//!
//! - It turns the [`Supervisor`]'s exit events, the heartbeats on every service's health
//!   channel, the clients' `request`/`release` commands on `/lewis/broker/cmd` and the core's
//!   deadlines ([`BrokerCore::next_deadline`]) into [`Event`]s;
//! - it answers `robot` with the robot description it runs (file name and text), so that a
//!   recorder started on its own finds every provider's channel;
//! - it carries out the [`Action`]s: `Start` spawns `lewis service NAME --robot FILE` (or the
//!   service's command line) in the namespace; `Stop` sends SIGTERM and, after the grace
//!   period, SIGKILL, without blocking the loop (the exit comes back as an event); binds are
//!   answered to the requesting client and published;
//! - every decision is published on `/lewis/broker` (so clients follow rebinding and the
//!   recorder keeps it) and logged;
//! - services' stdout and stderr lines are published on `/lewis/log` with their names (by a
//!   forwarding thread, so a burst of output never delays a decision).
//!
//! - it reads every provider's data channels (its own subscription: every subscriber gets
//!   every sample, so clients lose nothing) and feeds them to the [`health`](super::health)
//!   checks while the provider is ready; a failed check is an [`Event::DataCheckFailed`].
//!
//! - about once a second it measures the CPU each service's process used ([`cpu`](super::cpu)),
//!   publishes it on `/lewis/broker/cpu` (recorded, so replay decides the same) and hands it
//!   to the core as an [`Event::CpuMeasured`].
//!
//! - for a robot on more than one host, it says on `/lewis/hosts` each host joined or lost
//!   and each joined host's clock offset (`broker/host_link.rs`), recorded so that
//!   replay loses and joins the hosts when it did.
//!
//! Everything waits on one [`WaitSet`]: the stop signals, the supervisor's descriptor, the
//! command server and the health channels, with the earliest deadline.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Broker as BrokerMessage, BrokerAction, BrokerCommand, BrokerReleaseReply, BrokerRequestReply,
    BrokerRequestReplyStatus, BrokerRobotReply, Health as HealthMessage, LogLine as LogLineMessage,
    LogLineLevel, LogLineStream, ProcessCpu,
};
use lewis_interfaces::{CommandSet, Message};
use nix::sys::signal::Signal;

use super::cpu::CpuSampler;
use super::health::DataMonitor;
use super::host_link::HostLinks;
use super::remote::{HostEvent, RemoteHosts, RemoteStartError};
use super::{Action, Binding, BrokerCore, Decision, Event, ExitStatus, Need, ServiceState};
use crate::clock::LiveClock;
use crate::ipc::{
    CommandServer, FdSource, Ipc, IpcError, Namespace, NodeCleaner, NodeLiveness, Publisher,
    Subscriber, WaitError, WaitSet, Waitable, WakeMode,
};
use crate::live::{CLOCK_ENV, ClockSource};
use crate::live::{StopSignals, heartbeat_event};
use crate::names;
use crate::supervise::{ChildSpec, LogLine, SuperviseError, Supervisor, SupervisorEvent};
use lewis_robot::{DataChecks, Robot, ServiceSpec};
use lewis_service::wire;

/// Log lines waiting to be published before new ones are dropped (and counted by the
/// supervisor).
const LOG_QUEUE: usize = 4096;

/// The longest the broker waits between two looks at the data channels while a provider
/// is judged (heartbeats usually wake it sooner).
const DATA_LOOK_PERIOD: Duration = Duration::from_millis(50);

/// A gap between two looks at the data channels longer than this (twice the period) means
/// the broker's loop was held up: a data channel's buffer (8 samples) may have overflowed
/// meanwhile, so the rate is judged afresh.
const DATA_LOOK_HELD_UP_NS: i64 = 100_000_000;

/// How often the broker looks for clients that died without a release.
const CLIENT_SWEEP: Duration = Duration::from_millis(500);

/// How often the broker measures the CPU of the services' processes: a second gives a
/// measurement good to 1% of a core (`/proc`'s clock ticks are 10 ms).
const CPU_SAMPLE_PERIOD: Duration = Duration::from_secs(1);

/// The IPC cleanups asked for at a service's exits ([`NodeCleaner::request`] tickets).
#[derive(Debug, Default)]
struct ExitCleanups {
    /// At its last exit.
    last: Option<u64>,
    /// At the exit before that one.
    before_last: Option<u64>,
}

/// The longest a start waits for the cleanup after an exit (it took 140-220 ms on a
/// loaded machine); past it the service is started anyway and the wait is logged.
const CLEANUP_WAIT_LIMIT: Duration = Duration::from_secs(2);

/// How `lewis up` runs.
#[derive(Debug, Clone)]
pub struct UpOptions {
    /// The robot file (handed to every `lewis service`).
    pub robot_path: PathBuf,
    /// The namespace of every IPC name.
    pub namespace: Namespace,
    /// The `lewis` executable that runs built-in service kinds.
    pub lewis_exe: PathBuf,
    /// Stop after this long (`None`: until SIGINT or SIGTERM).
    pub duration: Option<Duration>,
    /// Time between SIGTERM and SIGKILL when a service is stopped.
    pub stop_grace: Duration,
    /// The clock the services read (handed to each in [`CLOCK_ENV`]).
    pub clock: ClockSource,
}

/// Why `lewis up` could not run.
#[derive(Debug, thiserror::Error)]
pub enum UpError {
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// Process supervision failed.
    #[error(transparent)]
    Supervise(#[from] SuperviseError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// The log forwarding thread could not start.
    #[error("cannot start the log forwarding thread: {0}")]
    Thread(std::io::Error),
    /// The robot file could not be read again (the broker serves its text).
    #[error("cannot read the robot file {}: {source}", path.display())]
    RobotFile {
        /// The robot file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
}

/// What a run of `lewis up` ended with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UpSummary {
    /// Decisions taken.
    pub decisions: usize,
    /// Why it ended: `signal` (Ctrl-C, SIGTERM), `request` (a [`StopHandle`]: the goal or
    /// the mission is over) or `duration`.
    ///
    /// [`StopHandle`]: crate::live::StopHandle
    pub ended_by: &'static str,
}

/// The broker message of a decision.
#[must_use]
pub fn decision_message(decision: &Decision) -> BrokerMessage {
    let mut m = BrokerMessage {
        reason: decision.reason.clone(),
        at_ns: decision.at_ns,
        ..BrokerMessage::default()
    };
    let action = match &decision.action {
        Action::Start { service } => {
            m.service.clone_from(service);
            BrokerAction::Start
        }
        Action::Stop { service } => {
            m.service.clone_from(service);
            BrokerAction::Stop
        }
        Action::Bind {
            client,
            interface,
            service,
        } => {
            m.client.clone_from(client);
            m.interface.clone_from(interface);
            m.service.clone_from(service);
            BrokerAction::Bind
        }
        Action::Rebind {
            client,
            interface,
            from,
            to,
        } => {
            m.client.clone_from(client);
            m.interface.clone_from(interface);
            m.service.clone_from(to);
            m.from_service.clone_from(from);
            m.to_service.clone_from(to);
            BrokerAction::Rebind
        }
        Action::Unbind {
            client,
            interface,
            service,
        } => {
            m.client.clone_from(client);
            m.interface.clone_from(interface);
            m.service.clone_from(service);
            BrokerAction::Unbind
        }
        Action::Reject { client, interface } => {
            m.client.clone_from(client);
            m.interface.clone_from(interface);
            BrokerAction::Reject
        }
        Action::AskForHelp { need } => {
            match need {
                Need::Interface(interface) => m.interface.clone_from(interface),
                Need::Service(service) => m.service.clone_from(service),
            }
            BrokerAction::AskForHelp
        }
        Action::RestartScheduled { service, .. } => {
            m.service.clone_from(service);
            BrokerAction::RestartScheduled
        }
        Action::ServiceFailed { service } => {
            m.service.clone_from(service);
            BrokerAction::ServiceFailed
        }
        Action::ServiceDegraded { service } => {
            m.service.clone_from(service);
            BrokerAction::ServiceDegraded
        }
        Action::ServiceWaiting { service, interface } => {
            m.service.clone_from(service);
            m.interface.clone_from(interface);
            BrokerAction::ServiceWaiting
        }
        Action::ServiceResumed { service } => {
            m.service.clone_from(service);
            BrokerAction::ServiceResumed
        }
    };
    m.action = action.into();
    m
}

/// Runs the broker and the robot's services until a stop signal, a stop asked through
/// `stop`'s [`StopHandle`](crate::live::StopHandle), or the duration, then stops every
/// service, clients before their providers.
///
/// `before_close` runs once every service has stopped and its last lines are published, but
/// before the broker's own channels (`/lewis/broker`, `/lewis/log`) close: the place to stop
/// a recorder. A sample whose publisher is gone before a subscriber first maps the
/// publisher's shared memory is lost to that subscriber, so a recorder stopped after the
/// broker could miss the last lines. It does not run when the broker cannot start.
///
/// # Errors
/// When IPC or supervision cannot be set up.
pub fn run_up(
    robot: &Robot,
    options: &UpOptions,
    stop: &StopSignals,
    before_close: &mut dyn FnMut(),
) -> Result<UpSummary, UpError> {
    run_up_with_hosts(robot, options, stop, before_close, None)
}

/// As [`run_up`], for the robot host of a robot on more than one: the services of the other
/// hosts are started and stopped through `remote`, and their exits and the hosts' comings
/// and goings come from it. Until a host has joined, its services can be neither chosen nor
/// started.
///
/// # Errors
/// When IPC or supervision cannot be set up.
pub fn run_up_with_hosts<'a>(
    robot: &'a Robot,
    options: &'a UpOptions,
    stop: &StopSignals,
    before_close: &mut dyn FnMut(),
    remote: Option<&'a mut (dyn RemoteHosts + 'a)>,
) -> Result<UpSummary, UpError> {
    let (log_tx, log_rx) = sync_channel(LOG_QUEUE);
    let forwarder = spawn_log_forwarder(options.namespace.clone(), log_rx)?;
    let mut driver = Driver::new(robot, options, Supervisor::with_log_sink(log_tx)?, remote)?;
    let end = options.duration.map(|d| Instant::now() + d);
    let ended_by = driver.run(stop, end)?;
    let summary = UpSummary {
        decisions: driver.decisions,
        ended_by,
    };
    driver.shutdown();
    // Dropping the supervisor closes the log channel: the forwarder publishes what is left
    // and hands back its publisher, kept open (like the decisions' one) until after
    // `before_close`.
    let Driver {
        supervisor,
        ipc,
        decisions_out,
        ..
    } = driver;
    drop(supervisor);
    // Returns when every line is published (or the forwarder is gone).
    let _ = forwarder.flushed.recv();
    before_close();
    drop(forwarder.close);
    let _ = forwarder.thread.join();
    drop((decisions_out, ipc));
    Ok(summary)
}

/// How a service of the robot is spawned: its command line, the namespace and clock it
/// runs in, its environment; `None` for an empty command line. What the broker starts on
/// its host, and another host's supervisor on its own.
#[must_use]
pub fn service_child(spec: &ServiceSpec, options: &UpOptions) -> Option<ChildSpec> {
    let argv = spec.argv(&options.lewis_exe, &options.robot_path);
    let (program, args) = argv.split_first()?;
    let mut child = ChildSpec::new(&spec.name, Path::new(program))
        .args(args.iter().cloned())
        .env(crate::ipc::NAMESPACE_ENV, options.namespace.as_str())
        .env(CLOCK_ENV, options.clock.as_str())
        .stop_grace(options.stop_grace);
    for (key, value) in &spec.environment {
        child = child.env(key, value);
    }
    Some(child)
}

struct Driver<'r> {
    robot: &'r Robot,
    options: &'r UpOptions,
    /// The other hosts, for a robot on more than one.
    remote: Option<&'r mut (dyn RemoteHosts + 'r)>,
    /// The robot host's name, for a robot on more than one.
    local_host: Option<String>,
    /// The robot file's text, served to whoever asks (`robot`).
    robot_toml: String,
    clock: LiveClock,
    core: BrokerCore,
    supervisor: Supervisor,
    ipc: Ipc,
    /// Removes what exited services left in shared memory, off this loop.
    cleaner: NodeCleaner,
    /// The cleanup tickets asked for at each service's last two exits.
    exit_cleanups: BTreeMap<String, ExitCleanups>,
    /// The process id each service of another host last had there.
    remote_pids: BTreeMap<String, u32>,
    decisions_out: Publisher,
    server: CommandServer,
    health: Vec<(String, Subscriber)>,
    /// Every provision whose data is checked: its channel and the checks of its current run.
    watches: Vec<Watch>,
    /// When the data channels were last read.
    last_data_look_ns: i64,
    /// Services sent SIGTERM, and when they get SIGKILL.
    kills: BTreeMap<String, Instant>,
    waits: WaitSet,
    decisions: usize,
    /// The time of the last event handed to the core.
    last_ns: i64,
    /// Whether the exits of dying processes are being taken before an event past a
    /// deadline (see [`Driver::take_deaths_before`]): the exits are events themselves.
    taking_deaths: bool,
    /// Heartbeats read but sent after the time of the last event fed: fed with the next.
    later_beats: Vec<(i64, Event)>,
    /// The process of each client that told it, watched so that a client that dies without
    /// a release loses its bindings.
    client_pids: BTreeMap<String, i32>,
    /// When the clients' processes are looked at next.
    next_client_sweep: Instant,
    /// The CPU of the services' processes, measured.
    cpu: CpuSampler,
    /// Where each measurement is published.
    cpu_out: Publisher,
    /// Measurements published so far (the header's sequence).
    cpu_seq: u64,
    /// When the processes are measured next.
    next_cpu_sample: Instant,
    /// Where the other hosts' comings and goings are said, for a robot on more than one.
    host_links: Option<HostLinks>,
}

impl<'r> Driver<'r> {
    fn new(
        robot: &'r Robot,
        options: &'r UpOptions,
        supervisor: Supervisor,
        remote: Option<&'r mut (dyn RemoteHosts + 'r)>,
    ) -> Result<Self, UpError> {
        let robot_toml =
            std::fs::read_to_string(&options.robot_path).map_err(|source| UpError::RobotFile {
                path: options.robot_path.clone(),
                source,
            })?;
        let ipc = Ipc::open(&options.namespace, names::BROKER_NODE)?;
        let cleaner = NodeCleaner::start(&options.namespace, names::BROKER_CLEANER_NODE)?;
        let decisions_out = ipc.publisher(names::BROKER_CHANNEL, &names::broker_config())?;
        let cpu_out = ipc.publisher(names::CPU_CHANNEL, &names::cpu_config())?;
        let host_links = remote
            .is_some()
            .then(|| HostLinks::open(&ipc))
            .transpose()?;
        let server = ipc.command_server(names::BROKER_COMMAND, &names::broker_command_config())?;
        let health = robot
            .services
            .iter()
            .map(|s| {
                ipc.subscriber(&names::health_channel(&s.name), &names::health_config())
                    .map(|sub| (s.name.clone(), sub))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut watches = Vec::new();
        for spec in &robot.services {
            for provision in &spec.provides {
                let mut checks = robot.broker.checks_of(provision);
                if options.clock == ClockSource::Played {
                    // The services' time is a recording's, paused or played at another
                    // rate: neither a publish time nor a rate says anything against the
                    // broker's clock.
                    checks.freshness_ms = None;
                    checks.min_rate_fraction = 0.0;
                }
                if !checks.any() {
                    continue;
                }
                let channel = names::data_channel(&spec.name, &provision.interface);
                watches.push(Watch {
                    service: spec.name.clone(),
                    interface: provision.interface.clone(),
                    checks,
                    data_rate_hz: provision.data_rate_hz,
                    subscriber: ipc
                        .subscriber(&channel, &names::data_config(&provision.interface))?,
                    run: WatchRun::Idle,
                });
            }
        }
        Ok(Self {
            robot,
            options,
            remote,
            local_host: robot.robot_host().map(|h| h.name.clone()),
            robot_toml,
            clock: LiveClock::new(),
            core: BrokerCore::new(robot),
            supervisor,
            ipc,
            cleaner,
            exit_cleanups: BTreeMap::new(),
            remote_pids: BTreeMap::new(),
            decisions_out,
            server,
            health,
            watches,
            last_data_look_ns: 0,
            kills: BTreeMap::new(),
            waits: WaitSet::new(WakeMode::Event),
            decisions: 0,
            last_ns: 0,
            taking_deaths: false,
            later_beats: Vec::new(),
            client_pids: BTreeMap::new(),
            next_client_sweep: Instant::now() + CLIENT_SWEEP,
            cpu: CpuSampler::new(),
            cpu_out,
            cpu_seq: 0,
            next_cpu_sample: Instant::now() + CPU_SAMPLE_PERIOD,
            host_links,
        })
    }

    fn run(
        &mut self,
        signals: &StopSignals,
        end: Option<Instant>,
    ) -> Result<&'static str, UpError> {
        tracing::info!(
            robot = self.robot.name,
            namespace = self.options.namespace.as_str(),
            "broker up"
        );
        self.feed(Event::BrokerStarted);
        loop {
            if signals.take_requested() {
                return Ok("request");
            }
            if signals.take() {
                return Ok("signal");
            }
            let now = Instant::now();
            if end.is_some_and(|e| now >= e) {
                return Ok("duration");
            }
            // Every event is fed after the heartbeats sent before it (`feed_at`) and the
            // exits of the processes dying by its time (`handle`), so the order of these
            // steps does not matter to deadlines.
            self.take_exits()?;
            self.take_remote_events();
            self.serve_requests();
            let now_ns = self.clock.now_ns();
            if self.core.next_deadline().is_some_and(|d| now_ns >= d) {
                self.take_remote_events();
                self.judge_quiet_hosts(now_ns);
                // Now, not `now_ns`: waiting for the dying and restarting took time.
                self.feed(Event::TimePassed);
            } else {
                self.take_heartbeats(now_ns);
            }
            self.check_data();
            self.kill_overdue(now);
            if now >= self.next_client_sweep {
                self.sweep_dead_clients();
                self.next_client_sweep = now + CLIENT_SWEEP;
            }
            if now >= self.next_cpu_sample {
                self.measure_cpu();
                if let (Some(links), Some(remote)) = (&mut self.host_links, &self.remote) {
                    links.heard(&**remote, self.clock.now_ns());
                }
                self.next_cpu_sample = now + CPU_SAMPLE_PERIOD;
            }
            let sweep = (!self.client_pids.is_empty()).then_some(self.next_client_sweep);
            let deadline = self
                .core
                .next_deadline()
                .map(|ns| self.clock.to_instant(ns))
                .into_iter()
                .chain(self.kills.values().copied())
                .chain(self.watches.iter().filter_map(|w| match &w.run {
                    WatchRun::Judging(monitor) => {
                        monitor.deadline().map(|ns| self.clock.to_instant(ns))
                    }
                    WatchRun::Idle | WatchRun::Failed => None,
                }))
                // Data is read at least this often while a provider is judged, so that a
                // longer gap means the loop was held up.
                .chain(
                    self.watches
                        .iter()
                        .any(|w| matches!(w.run, WatchRun::Judging(_)))
                        .then(|| now + DATA_LOOK_PERIOD),
                )
                .chain(sweep)
                .chain([self.next_cpu_sample])
                .chain(end)
                .min();
            self.wait(signals, deadline)?;
        }
    }

    fn wait(&self, signals: &StopSignals, deadline: Option<Instant>) -> Result<(), UpError> {
        let signal_fd = FdSource::new(signals.as_fd());
        let supervisor_fd = FdSource::new(self.supervisor.as_fd());
        let remote_fd = self.remote.as_ref().map(|r| FdSource::new(r.wake_fd()));
        let mut sources: Vec<&dyn Waitable> = vec![&signal_fd, &supervisor_fd, &self.server];
        sources.extend(remote_fd.as_ref().map(|fd| fd as &dyn Waitable));
        sources.extend(self.health.iter().map(|(_, s)| s as &dyn Waitable));
        self.waits.wait(&sources, deadline)?;
        Ok(())
    }

    /// Hands an event that happens now to the core; see [`Driver::feed_at`].
    fn feed(&mut self, event: Event) -> Vec<Decision> {
        self.feed_at(self.clock.now_ns(), event)
    }

    /// Hands an event that happened at `at_ns` to the core, after every heartbeat sent
    /// before it, and carries out its decisions; see [`Driver::handle`]. Returns the
    /// decisions the event led to.
    ///
    /// The core judges every deadline at the time of the event it is handed. The loop can
    /// be held up between two reads of the health channels (iceoryx2's cleanup after an
    /// exit took 140-220 ms here before it moved to its own thread; a spawn takes tens of
    /// ms on a loaded machine), and an event taken after that, with the heartbeats sent
    /// meanwhile still unread, failed healthy services: a hot-standby sonar beating every
    /// 10 ms was given up while the crashed laser was restarted. Reading them first means
    /// a service is judged stalled only when it really sent nothing in time.
    fn feed_at(&mut self, at_ns: i64, event: Event) -> Vec<Decision> {
        self.take_heartbeats(at_ns);
        self.handle(at_ns, event)
    }

    /// As [`Driver::feed_at`] for an event dated before now (an exit, at the death it
    /// stands for): the heartbeats sent after it are fed later, at their own times. Dated
    /// back to it, they made every other service look silent since then, and its deadline
    /// failed them all.
    fn feed_in_the_past(&mut self, at_ns: i64, event: Event) -> Vec<Decision> {
        self.take_heartbeats_sent(at_ns, Later::Wait);
        self.handle(at_ns, event)
    }

    /// Hands an event that happened at `at_ns` to the core and carries out its decisions,
    /// and those of the events they cause, in order. Returns every decision taken.
    ///
    /// The time is when the event happened (a heartbeat's publish time, the moment an exit
    /// was seen), not when this loop got to it: on a loaded machine the loop may run late,
    /// and the core must not take a heartbeat that arrived in time for a missed one. Times
    /// never go backwards.
    fn handle(&mut self, at_ns: i64, event: Event) -> Vec<Decision> {
        self.take_deaths_before(at_ns.max(self.last_ns));
        let mut queue = VecDeque::from([event]);
        let mut all = Vec::new();
        let at_ns = at_ns.max(self.last_ns);
        self.last_ns = at_ns;
        while let Some(event) = queue.pop_front() {
            if let Some(links) = &mut self.host_links {
                links.on_event(&event, self.remote.as_deref().map(|r| r as _), at_ns);
            }
            // Events caused by decisions (a spawn, a failed spawn) are taken at the time of
            // the decision, not after it was carried out: a spawn can take tens of ms on a
            // loaded machine, and judging the deadlines at its end, before the heartbeats
            // that arrived meanwhile are read, failed healthy services (a hot standby was
            // given up while the crashed provider was being restarted).
            // A client that went away takes its bindings with it: routine, as its binding was.
            let client_left = matches!(event, Event::ClientGone { .. });
            for decision in self.core.handle(at_ns, &event) {
                self.publish(&decision, client_left);
                queue.extend(self.carry_out(&decision.action));
                all.push(decision);
            }
        }
        all
    }

    /// Takes the exits of the children dying now (killed, not yet gone; waiting at most
    /// [`DYING_GRACE`]) when an event at `at_ns` would judge a deadline: a process killed
    /// just now is silent already, and its exit, dated at its death, must come before the
    /// deadline its silence would miss. Whatever the event: a heartbeat of another service
    /// taken past the deadline called a killed laser's death a stall, and the demo's laser
    /// was given up after two deaths instead of three on a loaded machine.
    fn take_deaths_before(&mut self, at_ns: i64) {
        if self.taking_deaths || self.core.next_deadline().is_none_or(|d| at_ns < d) {
            return;
        }
        self.taking_deaths = true;
        self.supervisor.await_dying(DYING_GRACE);
        if let Err(e) = self.take_exits() {
            // The loop's own look at the exits meets it again and stops there.
            tracing::warn!("cannot take the exits of dying processes: {e}");
        }
        self.taking_deaths = false;
    }

    /// Measures what each service's process used of the CPU since the last look, publishes
    /// it and hands it to the core.
    fn measure_cpu(&mut self) {
        let now_ns = self.clock.now_ns();
        let running: Vec<(String, u32)> = self
            .supervisor
            .running()
            .into_iter()
            .filter_map(|name| Some((name.to_owned(), self.supervisor.pid(name)?)))
            .collect();
        for (service, pid) in &running {
            let Some(milli_cores) = self.cpu.sample(*pid, now_ns) else {
                continue;
            };
            self.cpu_seq += 1;
            let mut message = ProcessCpu {
                service: service.clone(),
                milli_cores: i32::try_from(milli_cores).unwrap_or(i32::MAX),
                ..ProcessCpu::default()
            };
            if let Err(e) =
                self.cpu_out
                    .publish_stamped(&mut message, names::BROKER_NODE, self.cpu_seq, now_ns)
            {
                tracing::debug!("cannot publish a CPU measurement: {e}");
            }
            self.feed_at(
                now_ns,
                Event::CpuMeasured {
                    service: service.clone(),
                    milli_cores,
                },
            );
        }
        self.cpu
            .retain(|pid| running.iter().any(|(_, p)| *p == pid));
    }

    fn publish(&mut self, decision: &Decision, client_left: bool) {
        self.decisions += 1;
        // Failures and failovers are what a person watching the robot needs; starting and
        // binding what is needed, and unbinding a client that left, is routine, shown with
        // `-v`.
        match &decision.action {
            Action::Unbind { .. } if client_left => {
                tracing::debug!(subject = "broker", "{decision}");
            }
            Action::AskForHelp { .. }
            | Action::ServiceFailed { .. }
            | Action::ServiceDegraded { .. } => {
                tracing::warn!(subject = "broker", "{decision}");
            }
            Action::Rebind { .. }
            | Action::Unbind { .. }
            | Action::Reject { .. }
            | Action::RestartScheduled { .. }
            | Action::ServiceWaiting { .. }
            | Action::ServiceResumed { .. } => tracing::info!(subject = "broker", "{decision}"),
            Action::Start { .. } | Action::Stop { .. } | Action::Bind { .. } => {
                tracing::debug!(subject = "broker", "{decision}");
            }
        }
        let mut message = decision_message(decision);
        // Stamped as every publication is, so that a reader sees who sent it, in which
        // order, and when (the broker's clock); a replay stamps its own the same way.
        let seq = u64::try_from(self.decisions).unwrap_or(u64::MAX);
        let now_ns = self.clock.now_ns();
        if let Err(e) =
            self.decisions_out
                .publish_stamped(&mut message, names::BROKER_NODE, seq, now_ns)
        {
            tracing::warn!("cannot publish a broker decision: {e}");
        }
    }

    /// The host `service` runs on when that is another than this one.
    fn remote_host_of(&self, service: &str) -> Option<String> {
        let host = self.robot.host_of(service)?;
        (Some(host) != self.local_host.as_deref()).then(|| host.to_owned())
    }

    /// Feeds what the other hosts reported: hosts joined or lost, exits of their services.
    fn take_remote_events(&mut self) {
        while let Some(event) = self.remote.as_mut().and_then(|r| r.take_event()) {
            match event {
                HostEvent::Joined { host } => {
                    tracing::info!(subject = "broker", "host {host} joined");
                    self.feed(Event::HostJoined { host });
                }
                HostEvent::Lost { host, why } => {
                    tracing::warn!(subject = "broker", "host {host} lost: {why}");
                    self.feed(Event::HostLost { host, why });
                }
                HostEvent::Exited { service, status } => {
                    let died_ns = self.death_time(&service, self.clock.now_ns());
                    self.feed_in_the_past(died_ns, Event::ProcessExited { service, status });
                }
            }
        }
    }

    /// A service of another host past its deadline, whose whole host went quiet with it
    /// (not even the host's own beat came), was not stalled: its host is lost, and that is
    /// what its clients are told.
    fn judge_quiet_hosts(&mut self, now_ns: i64) {
        let Some(remote) = self.remote.as_ref() else {
            return;
        };
        let mut lost = BTreeSet::new();
        for service in self.core.due_services(now_ns) {
            let Some(host) = self.remote_host_of(service) else {
                continue;
            };
            if let Some(silence) = remote.quiet_for(&host) {
                lost.insert((host, silence));
            }
        }
        for (host, silence) in lost {
            let why = format!(
                "nothing heard from it for {} ms, its services' heartbeats included",
                silence.as_millis()
            );
            tracing::warn!(subject = "broker", "host {host} lost: {why}");
            if let Some(remote) = self.remote.as_mut() {
                remote.mark_lost(&host);
            }
            self.feed(Event::HostLost { host, why });
        }
    }

    /// Does what an action asks; returns the events that follow from it at once, in order.
    fn carry_out(&mut self, action: &Action) -> Vec<Event> {
        if let Action::Start { service } | Action::Stop { service } = action
            && let Some(host) = self.remote_host_of(service)
        {
            return self.carry_out_remote(action, &host, service);
        }
        match action {
            Action::Start { service } => vec![self.start(service)],
            Action::Stop { service } => {
                match self.supervisor.signal(service, Signal::SIGTERM) {
                    Ok(()) => {
                        self.kills
                            .insert(service.clone(), Instant::now() + self.options.stop_grace);
                    }
                    // Already gone: its exit event is on its way.
                    Err(e) => tracing::debug!("stop {service}: {e}"),
                }
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    /// A start or a stop of a service of another host, by its supervisor.
    fn carry_out_remote(&mut self, action: &Action, host: &str, service: &str) -> Vec<Event> {
        let Some(remote) = self.remote.as_mut() else {
            return Vec::new();
        };
        if !matches!(action, Action::Start { .. }) {
            remote.stop(host, service);
            return Vec::new();
        }
        match remote.start(host, service) {
            Ok(pid) => {
                tracing::debug!(service, "started on {host} (pid {pid})");
                let mut events = vec![Event::ProviderStarted {
                    service: service.to_owned(),
                }];
                // Its process lived on through its host's loss (the robot host judged the
                // host lost, the host did not judge the robot host so): it asked for its
                // inputs once, as it started, and the core dropped those requests with the
                // host. They are asked again for it, after its start.
                if self.remote_pids.insert(service.to_owned(), pid) == Some(pid)
                    && let Some(spec) = self.robot.service(service)
                {
                    events.extend(spec.requires.iter().map(|interface| Event::ClientRequest {
                        client: service.to_owned(),
                        interface: interface.clone(),
                    }));
                }
                events
            }
            Err(RemoteStartError::Refused(error)) => vec![Event::StartFailed {
                service: service.to_owned(),
                error,
            }],
            // Not the service's fault: its host is cut off, and the service starts again
            // when the host is back.
            Err(RemoteStartError::Unreachable(why)) => {
                remote.mark_lost(host);
                vec![Event::HostLost {
                    host: host.to_owned(),
                    why,
                }]
            }
        }
    }

    fn start(&mut self, service: &str) -> Event {
        let Some(spec) = self.robot.service(service) else {
            return Event::StartFailed {
                service: service.to_owned(),
                error: "not in the robot file".to_owned(),
            };
        };
        let Some(child) = service_child(spec, self.options) else {
            return Event::StartFailed {
                service: service.to_owned(),
                error: "empty command line".to_owned(),
            };
        };
        // A service started again may meet one dead predecessor's ports (its channels
        // have a publisher and a server slot to spare for it: `names::command_config`),
        // not two: the cleanup after the exit before the last one must be over. It
        // usually is (a cleanup took about 150 ms, a backoff and a start as long), and
        // other services (an on-demand replacement) never wait for it.
        if let Some(ticket) = self.exit_cleanups.get(service).and_then(|c| c.before_last) {
            let waiting = Instant::now();
            if self.cleaner.wait_for(ticket, CLEANUP_WAIT_LIMIT) {
                tracing::debug!(
                    service,
                    "waited {:?} for the IPC cleanup after {service}'s exit",
                    waiting.elapsed()
                );
            } else {
                tracing::warn!(
                    service,
                    "the IPC cleanup after {service}'s exit took over {CLEANUP_WAIT_LIMIT:?}: starting it anyway"
                );
                // A pass that long waits on memory a killed process left empty: gone, the
                // pass goes on.
                let _ = crate::ipc::remove_abandoned_memory(&self.options.namespace);
            }
        }
        // A predecessor killed while it made its channels left them half made, refused to
        // every later process until removed (a retry after a cool-down would fail as it did).
        // Only a service that ran before has a predecessor: a first start meets what the
        // launch's wipe left, nothing, and skips the scan of the namespace's channels.
        if self.exit_cleanups.contains_key(service) {
            let _ = crate::ipc::remove_abandoned_channels(&self.options.namespace);
        }
        match self.supervisor.start(child) {
            Ok(pid) => {
                tracing::debug!(service, "started (pid {pid})");
                Event::ProviderStarted {
                    service: service.to_owned(),
                }
            }
            Err(e) => Event::StartFailed {
                service: service.to_owned(),
                error: e.to_string(),
            },
        }
    }

    fn take_exits(&mut self) -> Result<(), UpError> {
        while let Some(event) = self.supervisor.try_event()? {
            let seen_ns = self.clock.now_ns();
            if let SupervisorEvent::Exited { name, status, .. } = event {
                self.kills.remove(&name);
                // The dead process's ports and memory go, off this loop; a start of the
                // same service waits for that before it opens the same channels (`start`).
                let ticket = self.cleaner.request();
                let cleanups = self.exit_cleanups.entry(name.clone()).or_default();
                cleanups.before_last = cleanups.last.replace(ticket);
                let status = ExitStatus::from(status);
                let died_ns = self.death_time(&name, seen_ns);
                self.feed_in_the_past(
                    died_ns,
                    Event::ProcessExited {
                        service: name,
                        status,
                    },
                );
            }
        }
        Ok(())
    }

    /// When `service`'s process, whose exit was seen at `seen_ns`, died: the earliest time
    /// consistent with what was seen, just after its last heartbeat (or the last event
    /// handled, times never going back). Its heartbeat thread died with it, so its
    /// silence is the death's doing; dated when it was seen, an exit noticed late (a busy
    /// machine, a 100 ms deadline) was judged a stall first, and a crash that should have
    /// been restarted was failed for good.
    fn death_time(&self, service: &str, seen_ns: i64) -> i64 {
        self.core
            .last_heartbeat_ns(service)
            .map_or(seen_ns, |beat_ns| {
                seen_ns.min(beat_ns.saturating_add(1).max(self.last_ns))
            })
    }

    /// Feeds every heartbeat waiting on the health channels, in the order they were sent
    /// whatever their service, each at its publish time but no later than `until_ns`.
    fn take_heartbeats(&mut self, until_ns: i64) {
        self.take_heartbeats_sent(until_ns, Later::AtUntil);
    }

    /// Feeds the heartbeats sent up to `until_ns`, in the order they were sent; those sent
    /// after it are fed at their own times, no later than the present (a clock slightly
    /// ahead must not delay them), or wait for the next call (for an event in the past,
    /// which must come before them).
    fn take_heartbeats_sent(&mut self, until_ns: i64, later: Later) {
        let mut beats = std::mem::take(&mut self.later_beats);
        for (service, subscriber) in &mut self.health {
            while let Ok(Some(sample)) = subscriber.receive() {
                match cdr::from_bytes::<HealthMessage>(sample.bytes()) {
                    Ok(message) => beats.push((
                        message.header.publish_time_ns,
                        heartbeat_event(service, &message),
                    )),
                    Err(e) => tracing::warn!("bad heartbeat from {service}: {e}"),
                }
            }
        }
        if later == Later::Wait {
            let (due, after): (Vec<_>, Vec<_>) = beats
                .into_iter()
                .partition(|(sent_ns, _)| *sent_ns <= until_ns);
            beats = due;
            self.later_beats = after;
        }
        for (at_ns, event) in heartbeats_in_order(beats, until_ns, self.clock.now_ns()) {
            self.handle(at_ns, event);
        }
    }

    /// Reads what every watched provider published since the last look and judges it; a
    /// failed check goes to the core. A provider is judged from when it is ready (and not
    /// out of service) until it is not, then afresh: one report per run of its process.
    fn check_data(&mut self) {
        let now_ns = self.clock.now_ns();
        let last_look_ns = std::mem::replace(&mut self.last_data_look_ns, now_ns);
        let held_up = now_ns.saturating_sub(last_look_ns) > DATA_LOOK_HELD_UP_NS;
        let mut failures = Vec::new();
        for watch in &mut self.watches {
            let judged = self.core.data_is_judged(&watch.service);
            match (&watch.run, judged) {
                (WatchRun::Idle, true) => {
                    watch.run = WatchRun::Judging(Box::new(DataMonitor::new(
                        &watch.interface,
                        watch.checks,
                        watch.data_rate_hz,
                        now_ns,
                    )));
                }
                (WatchRun::Judging(_) | WatchRun::Failed, false) => watch.run = WatchRun::Idle,
                _ => {}
            }
            if held_up && let WatchRun::Judging(monitor) = &mut watch.run {
                // The samples of the gap beyond the channel's buffer are gone unread.
                monitor.restart_rate(now_ns);
            }
            // Always drained, judged or not: samples of a provider that is not judged now
            // must not be judged later, when they are stale.
            while let Ok(Some(sample)) = watch.subscriber.receive() {
                let WatchRun::Judging(monitor) = &mut watch.run else {
                    continue;
                };
                let bytes = sample.bytes();
                // No readable header: the values check says what is wrong with the bytes.
                let publish_ns =
                    cdr::peek_header(bytes).map_or(now_ns, |header| header.publish_time_ns);
                // Seen at the last look if it was published before it (it should have been
                // there then), else as it was published: a loop that reads late (a spawn, a
                // cleanup) does not make the provider's samples stale.
                let seen_ns = publish_ns.max(last_look_ns).min(now_ns);
                if let Err(failure) = monitor.sample(seen_ns, publish_ns, bytes) {
                    failures.push((watch.service.clone(), watch.interface.clone(), failure));
                    watch.run = WatchRun::Failed;
                }
            }
            if let WatchRun::Judging(monitor) = &mut watch.run
                && let Err(failure) = monitor.poll(now_ns)
            {
                failures.push((watch.service.clone(), watch.interface.clone(), failure));
                watch.run = WatchRun::Failed;
            }
        }
        for (service, interface, failure) in failures {
            self.feed_at(
                now_ns,
                Event::DataCheckFailed {
                    service,
                    interface,
                    check: failure.check.as_str().to_owned(),
                    reason: failure.reason,
                },
            );
        }
    }

    /// Clients whose process no longer holds a live IPC node are gone: their bindings go
    /// (a client killed with SIGKILL never sends its release).
    fn sweep_dead_clients(&mut self) {
        if self.client_pids.is_empty() {
            return;
        }
        let Ok(nodes) = self.ipc.nodes() else {
            return;
        };
        let alive: BTreeSet<i32> = nodes
            .iter()
            .filter(|n| n.liveness == NodeLiveness::Alive)
            .filter_map(|n| n.pid)
            .collect();
        let gone: Vec<String> = self
            .client_pids
            .iter()
            .filter(|(_, pid)| !alive.contains(pid))
            .map(|(client, _)| client.clone())
            .collect();
        if gone.is_empty() {
            return;
        }
        for client in gone {
            self.client_pids.remove(&client);
            tracing::info!(client, "client {client} died without a release");
            self.feed(Event::ClientGone { client });
        }
        self.cleaner.request();
    }

    fn kill_overdue(&mut self, now: Instant) {
        let due: Vec<String> = self
            .kills
            .iter()
            .filter(|(_, at)| now >= **at)
            .map(|(name, _)| name.clone())
            .collect();
        for name in due {
            self.kills.remove(&name);
            tracing::warn!(service = name, "{name} did not stop after SIGTERM: SIGKILL");
            let _ = self.supervisor.signal(&name, Signal::SIGKILL);
        }
    }

    fn serve_requests(&mut self) {
        while let Ok(Some(request)) = self.server.receive() {
            let answer = match wire::read_request(request.bytes()) {
                Ok((command, bytes)) => match BrokerCommand::decode(command, bytes) {
                    Ok(command) => Ok(self.answer(command)),
                    Err(e) => Err(e.to_string()),
                },
                Err(e) => Err(e.to_string()),
            };
            if let Err(e) = self.server.reply(request, &wire::reply_to_vec(&answer)) {
                tracing::warn!("cannot answer a broker request: {e}");
            }
        }
    }

    fn answer(&mut self, command: BrokerCommand) -> Vec<u8> {
        match command {
            BrokerCommand::Request(request) => {
                // Another host's process is not this host's to look for: its host's loss
                // takes its bindings.
                if request.pid > 0 && self.remote_host_of(&request.client).is_none() {
                    self.client_pids.insert(request.client.clone(), request.pid);
                }
                let decisions = self.feed(Event::ClientRequest {
                    client: request.client.clone(),
                    interface: request.interface.clone(),
                });
                let rejected = decisions.iter().any(|d| {
                    matches!(&d.action, Action::Reject { client, interface }
                        if *client == request.client && *interface == request.interface)
                });
                let bound = self
                    .core
                    .snapshot()
                    .bindings
                    .into_iter()
                    .find(|b| b.client == request.client && b.interface == request.interface)
                    .and_then(|b| b.service);
                let (status, service) = match (rejected, bound) {
                    (true, _) => (BrokerRequestReplyStatus::Rejected, String::new()),
                    (false, Some(service)) => (BrokerRequestReplyStatus::Bound, service),
                    (false, None) => (BrokerRequestReplyStatus::Waiting, String::new()),
                };
                let mut reply = BrokerRequestReply {
                    status: status.into(),
                    service,
                    ..BrokerRequestReply::default()
                };
                self.stamp(reply.header_mut());
                cdr::to_vec(&reply)
            }
            BrokerCommand::Release(release) => {
                self.client_pids.remove(&release.client);
                self.feed(Event::ClientGone {
                    client: release.client,
                });
                let mut reply = BrokerReleaseReply::default();
                self.stamp(reply.header_mut());
                cdr::to_vec(&reply)
            }
            BrokerCommand::Robot(_) => {
                let mut reply = BrokerRobotReply {
                    file_name: self
                        .options
                        .robot_path
                        .file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default(),
                    toml: self.robot_toml.clone(),
                    ..BrokerRobotReply::default()
                };
                self.stamp(reply.header_mut());
                cdr::to_vec(&reply)
            }
            BrokerCommand::Status(_) => {
                let mut reply = super::status::status_reply(
                    &self.robot.name,
                    self.options.namespace.as_str(),
                    &self.core.snapshot(),
                    self.clock.now_ns(),
                    |name| {
                        self.supervisor
                            .pid(name)
                            .and_then(|p| i32::try_from(p).ok())
                    },
                );
                self.stamp(reply.header_mut());
                cdr::to_vec(&reply)
            }
        }
    }

    fn stamp(&self, header: &mut lewis_interfaces::msg::Header) {
        header.provider = names::BROKER_NODE.to_owned();
        header.publish_time_ns = self.clock.now_ns();
    }

    fn shutdown(&mut self) {
        let running: Vec<String> = self
            .supervisor
            .running()
            .into_iter()
            .map(str::to_owned)
            .collect();
        let order = stop_order(&running, &self.core.snapshot().bindings);
        let mut results = order
            .into_iter()
            .map(|name| {
                let result = self.supervisor.stop(&name);
                (name, result)
            })
            .collect::<Vec<_>>();
        // Whatever is left (nothing, unless a process is not running): reverse start order.
        results.extend(self.supervisor.stop_all());
        // The other hosts' services, without waiting: each host stops what is left of the
        // robot once it has lost this broker.
        let remote: Vec<(String, String)> = self
            .core
            .snapshot()
            .services
            .iter()
            .filter(|s| {
                matches!(
                    s.state,
                    ServiceState::Starting { .. }
                        | ServiceState::Ready { .. }
                        | ServiceState::Stopping { .. }
                )
            })
            .filter_map(|s| Some((self.remote_host_of(&s.name)?, s.name.clone())))
            .collect();
        if let Some(hosts) = self.remote.as_mut() {
            for (host, service) in remote {
                hosts.stop(&host, &service);
            }
        }
        for (name, result) in results {
            match result {
                Ok(Some(status)) => tracing::debug!(service = name, "stopped: {status}"),
                Ok(None) => {}
                Err(e) => tracing::warn!(service = name, "cannot stop {name}: {e}"),
            }
        }
    }
}

/// One provider's data channel of one interface, watched by the broker.
struct Watch {
    service: String,
    interface: String,
    checks: DataChecks,
    data_rate_hz: Option<f64>,
    /// Open for the whole run, so that a restarted provider's first samples are seen.
    subscriber: Subscriber,
    run: WatchRun,
}

/// Where the watch of a provider's current process is.
enum WatchRun {
    /// The provider is not ready (or is out of service): its data is not judged.
    Idle,
    /// Ready: its samples go through the checks.
    Judging(Box<DataMonitor>),
    /// A check failed and was reported: nothing more until the provider's next run.
    Failed,
}

/// The order to stop the `running` services (given in start order): a service before the
/// services it is a client of (the ObstacleAvoider before the VectorMover it commands, so
/// that it never sees its provider go), otherwise the latest started first. A cycle of
/// bindings falls back to reverse start order.
fn stop_order(running: &[String], bindings: &[Binding]) -> Vec<String> {
    let mut left: Vec<&String> = running.iter().rev().collect();
    let mut order = Vec::with_capacity(left.len());
    while !left.is_empty() {
        let serves_one_left = |provider: &String| {
            bindings.iter().any(|b| {
                b.service.as_ref() == Some(provider)
                    && b.client != *provider
                    && left.iter().any(|l| **l == b.client)
            })
        };
        let next = left
            .iter()
            .position(|name| !serves_one_left(name))
            .unwrap_or(0);
        order.push(left.remove(next).clone());
    }
    order
}

/// What [`Driver::take_heartbeats_sent`] does with a heartbeat sent after the time it is
/// given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Later {
    /// Feeds it at that time: the present.
    AtUntil,
    /// Keeps it for the next call: a time in the past.
    Wait,
}

/// How long the broker waits, before judging a deadline, for a process that is exiting
/// to be gone (its threads' teardown). Only a process already killed or exiting is waited
/// for, and the wait ends when it is gone; on a machine whose cores are busy, a killed
/// process's threads wait for a core before they exit, and a shorter grace let CI judge
/// the demo's killed laser a stall, failed for good instead of restarted.
const DYING_GRACE: Duration = Duration::from_millis(500);

/// Heartbeats drained from the health channels (publish time, event), one
/// channel after the other, as the core must take them: in the order they were sent across
/// services (the core judges every deadline at each one's time, so a later heartbeat of one
/// service taken before an earlier one of another would judge that other too early), each
/// at its publish time but no later than `until_ns`, the time of the event they precede, or
/// the present `now_ns` if that is later (a clock ahead of the broker's must not delay
/// deadlines). A heartbeat is never dated before it was sent: when the event's time was
/// taken before the loop was held up (a restart after a killed laser took 144 ms), the
/// heartbeats sent meanwhile, dated back to it, made every service look silent since then,
/// and the next heartbeat's time failed them all. Sorting is stable: one service's
/// heartbeats keep their order.
fn heartbeats_in_order(
    mut beats: Vec<(i64, Event)>,
    until_ns: i64,
    now_ns: i64,
) -> Vec<(i64, Event)> {
    beats.sort_by_key(|(sent_ns, _)| *sent_ns);
    let latest_ns = until_ns.max(now_ns);
    beats
        .into_iter()
        .map(|(sent_ns, event)| (sent_ns.min(latest_ns), event))
        .collect()
}

/// The log level a line of a service says it has (tracing's format writes it as a word).
fn level_of(text: &str) -> &'static str {
    for (word, level) in [
        ("ERROR", LogLineLevel::Error),
        ("WARN", LogLineLevel::Warn),
        ("INFO", LogLineLevel::Info),
        ("DEBUG", LogLineLevel::Debug),
        ("TRACE", LogLineLevel::Trace),
    ] {
        if text.split_whitespace().take(3).any(|w| w == word) {
            return level.as_str();
        }
    }
    ""
}

/// The thread that publishes the services' lines on `/lewis/log`.
struct LogForwarder {
    /// Says that the supervisor closed the lines and every one is published.
    flushed: Receiver<()>,
    /// Dropped to let the thread close its publisher and end.
    close: SyncSender<()>,
    thread: std::thread::JoinHandle<()>,
}

/// Publishes `lines` until the supervisor closes them, then keeps its publisher open until
/// told to close (the publisher is bound to its thread).
fn spawn_log_forwarder(
    namespace: Namespace,
    lines: Receiver<LogLine>,
) -> Result<LogForwarder, UpError> {
    let (flushed_tx, flushed) = sync_channel(1);
    let (close, close_rx) = sync_channel::<()>(0);
    let thread = std::thread::Builder::new()
        .name("lewis-log".into())
        .spawn(move || {
            let publisher = Ipc::open(&namespace, "lewis-log").and_then(|ipc| {
                ipc.publisher(names::LOG_CHANNEL, &names::log_config())
                    .map(|p| (ipc, p))
            });
            let mut publisher = match publisher {
                Ok(opened) => Some(opened),
                Err(e) => {
                    tracing::warn!("service logs are not published on /lewis/log: {e}");
                    None
                }
            };
            // Each line is stamped when it is published (the supervisor does not stamp lines):
            // the recorder takes the header's time as the MCAP publish time.
            let clock = LiveClock::new();
            let mut seq = 0;
            for line in lines {
                let Some((_, publisher)) = &mut publisher else {
                    continue;
                };
                seq += 1;
                let mut message = LogLineMessage {
                    service: line.name.to_string(),
                    stream: LogLineStream::from(line.stream).into(),
                    level: level_of(&line.text).to_owned(),
                    text: line.text,
                    ..LogLineMessage::default()
                };
                let _ = publisher.publish_stamped(
                    &mut message,
                    names::BROKER_NODE,
                    seq,
                    clock.now_ns(),
                );
            }
            let _ = flushed_tx.send(());
            // Ends when `close` is dropped.
            let _ = close_rx.recv();
            drop(publisher);
        })
        .map_err(UpError::Thread)?;
    Ok(LogForwarder {
        flushed,
        close,
        thread,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn clients_are_stopped_before_their_providers() {
        let binding = |client: &str, service: &str| Binding {
            client: client.to_owned(),
            interface: "Mover".to_owned(),
            service: Some(service.to_owned()),
        };
        let names = |list: &[&str]| list.iter().map(|n| (*n).to_owned()).collect::<Vec<_>>();
        // Started as the goal asked: the avoider, then the mover it commands, then the
        // base the mover drives; an unrelated laser last.
        let running = names(&["avoider", "mover", "base", "laser"]);
        let bindings = [
            binding("lewis-goal", "avoider"),
            binding("avoider", "mover"),
            binding("mover", "base"),
            binding("avoider", "laser"),
        ];
        assert_eq!(
            stop_order(&running, &bindings),
            names(&["avoider", "laser", "mover", "base"])
        );
        // Without bindings: the latest started first, as before.
        assert_eq!(
            stop_order(&running, &[]),
            names(&["laser", "base", "mover", "avoider"])
        );
        // A cycle stops in reverse start order rather than never.
        let cycle = [binding("avoider", "mover"), binding("mover", "avoider")];
        assert_eq!(
            stop_order(&names(&["avoider", "mover"]), &cycle),
            names(&["mover", "avoider"])
        );
    }

    use super::*;
    use crate::broker::ServiceState;
    use lewis_service::Health;

    #[test]
    fn decisions_become_broker_messages_with_every_field_in_place() {
        fn check(action: Action, expected: [&str; 6]) {
            let m = decision_message(&Decision {
                at_ns: 5,
                action,
                reason: "why".into(),
            });
            assert_eq!(
                [
                    m.action.as_str(),
                    &m.client,
                    &m.interface,
                    &m.service,
                    &m.from_service,
                    &m.to_service
                ],
                expected
            );
            assert_eq!((m.at_ns, m.reason.as_str()), (5, "why"));
        }
        check(
            Action::Start {
                service: "laser".into(),
            },
            ["start", "", "", "laser", "", ""],
        );
        check(
            Action::Rebind {
                client: "app".into(),
                interface: "RangeFinder".into(),
                from: "laser".into(),
                to: "sonar".into(),
            },
            ["rebind", "app", "RangeFinder", "sonar", "laser", "sonar"],
        );
        check(
            Action::AskForHelp {
                need: Need::Interface("RangeFinder".into()),
            },
            ["ask-for-help", "", "RangeFinder", "", "", ""],
        );
    }

    const MS: i64 = 1_000_000;

    fn service_state(driver: &Driver<'_>, service: &str) -> ServiceState {
        driver
            .core
            .snapshot()
            .services
            .into_iter()
            .find(|s| s.name == service)
            .map(|s| s.state)
            .expect("the service is in the snapshot")
    }

    /// A heartbeat of `service` stamped `sent_ns`, as its harness publishes it.
    fn beat(publisher: &mut Publisher, service: &str, sent_ns: i64) {
        let mut message = HealthMessage {
            state: "ok".to_owned(),
            ..HealthMessage::default()
        };
        message.header.provider = service.to_owned();
        message.header.publish_time_ns = sent_ns;
        publisher.publish(&cdr::to_vec(&message)).unwrap();
    }

    /// The crash loop with a hot standby (issue 3): while the broker's loop is held up
    /// (iceoryx2's cleanup after the laser's exit), the laser and the sonar keep sending
    /// heartbeats; the next event the loop takes must come after them, or the sonar is
    /// given up although it beat every 10 ms. A service that then really goes silent is
    /// still failed at its deadline. The driver is real (IPC, processes); the times are
    /// given, not measured.
    /// A laser and a sonar that beat every 10 ms against a 50 ms deadline.
    const TWO_RANGE_FINDERS: &str = r#"
[robot]
name = "held-up"
[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
startup_deadline_ms = 10000
[[services]]
name = "laser"
command = ["sleep", "30"]
start = "standby"
restart = { max_restarts = 2, window_ms = 60000, backoff_initial_ms = 20, backoff_max_ms = 100 }
provides = [{ interface = "RangeFinder", quality = 10, cost = 2 }]
[[services]]
name = "sonar"
command = ["sleep", "30"]
start = "standby"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
"#;

    /// The robot file `text` written into `dir` and parsed, and options to run it.
    fn robot_and_options(dir: &Path, text: &str, tag: &str) -> (Robot, UpOptions) {
        let robot_path = dir.join("robot.toml");
        std::fs::write(&robot_path, text).unwrap();
        let robot = lewis_robot::parse(text, &robot_path, &["RangeFinder"]).unwrap();
        let options = UpOptions {
            robot_path,
            namespace: Namespace::unique(tag),
            lewis_exe: PathBuf::from("lewis"),
            duration: None,
            stop_grace: Duration::from_millis(300),
            clock: ClockSource::Wall,
        };
        (robot, options)
    }

    /// [`TWO_RANGE_FINDERS`] ready to drive, its IPC and processes real.
    struct TwoRangeFinders {
        robot: Robot,
        options: UpOptions,
        services: Ipc,
        _dir: tempfile::TempDir,
    }

    impl TwoRangeFinders {
        fn driver(&self) -> Driver<'_> {
            Driver::new(&self.robot, &self.options, Supervisor::new().unwrap(), None).unwrap()
        }

        /// A heartbeat publisher for the laser and one for the sonar, as their harnesses
        /// have.
        fn heartbeats(&self) -> (Publisher, Publisher) {
            let health = |name: &str| {
                self.services
                    .publisher(&names::health_channel(name), &names::health_config())
                    .unwrap()
            };
            (health("laser"), health("sonar"))
        }
    }

    fn two_range_finders(tag: &str) -> TwoRangeFinders {
        let dir = tempfile::tempdir().unwrap();
        let (robot, options) = robot_and_options(dir.path(), TWO_RANGE_FINDERS, tag);
        let services = Ipc::open(&options.namespace, "services").unwrap();
        TwoRangeFinders {
            robot,
            options,
            services,
            _dir: dir,
        }
    }

    /// Boots the broker and makes both services ready with a beat each at the time
    /// returned: ahead of the broker's clock however slowly this runs (beats sent after the
    /// time an event is taken at are dated no later than the present), and within the
    /// startup deadline of the two standbys started with the broker.
    fn both_ready_ahead(driver: &mut Driver, laser: &mut Publisher, sonar: &mut Publisher) -> i64 {
        driver.feed(Event::BrokerStarted);
        let t0 = driver.clock.now_ns() + 5_000 * MS;
        beat(laser, "laser", t0);
        beat(sonar, "sonar", t0);
        driver.take_heartbeats(t0);
        t0
    }

    #[test]
    fn an_exit_seen_after_the_deadline_is_a_crash_restarted_not_a_stall() {
        let rig = two_range_finders("late-exit");
        let mut driver = rig.driver();
        let (mut laser, mut sonar) = rig.heartbeats();
        let t0 = both_ready_ahead(&mut driver, &mut laser, &mut sonar);
        // The laser is killed; its exit is seen 80 ms later, past its 50 ms deadline. The
        // sonar beat meanwhile, after the laser's death.
        for k in 1..=8 {
            beat(&mut sonar, "sonar", t0 + k * 10 * MS);
        }
        let seen_ns = t0 + 80 * MS;
        let died_ns = driver.death_time("laser", seen_ns);
        assert_eq!(died_ns, t0 + 1);
        let decisions = driver.feed_in_the_past(
            died_ns,
            Event::ProcessExited {
                service: "laser".to_owned(),
                status: ExitStatus::Signal(9),
            },
        );
        assert!(
            matches!(&decisions[..], [Decision { action: Action::RestartScheduled { service, .. }, .. }] if service == "laser"),
            "{decisions:?}"
        );
        // The sonar's beats after the death were not dated back to it: 10 ms past the
        // deadline it would then have had, it is alive, its last beat the latest due.
        driver.feed_at(t0 + 60 * MS, Event::TimePassed);
        assert_eq!(
            service_state(&driver, "sonar"),
            ServiceState::Ready {
                last_heartbeat_ns: t0 + 60 * MS
            }
        );
        driver.shutdown();
    }

    #[test]
    fn a_killed_process_is_not_called_stalled_by_another_service_s_heartbeat_past_its_deadline() {
        let rig = two_range_finders("killed");
        let mut driver = rig.driver();
        let (mut laser, mut sonar) = rig.heartbeats();
        let t0 = both_ready_ahead(&mut driver, &mut laser, &mut sonar);

        // The laser's process is killed and its exit not yet taken; the sonar beats on,
        // past the laser's 50 ms deadline, and its beats are read first.
        let pid = driver.supervisor.pid("laser").unwrap();
        nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(i32::try_from(pid).unwrap()),
            Signal::SIGKILL,
        )
        .unwrap();
        for k in 1..=8 {
            beat(&mut sonar, "sonar", t0 + k * 10 * MS);
        }
        driver.take_heartbeats(t0 + 80 * MS);

        // A crash within its restart policy: restarted, not failed as stalled.
        assert!(
            matches!(
                service_state(&driver, "laser"),
                ServiceState::Restarting { attempt: 1, .. } | ServiceState::Starting { .. }
            ),
            "{}",
            driver.core.snapshot()
        );
        assert_eq!(
            service_state(&driver, "sonar"),
            ServiceState::Ready {
                last_heartbeat_ns: t0 + 80 * MS
            }
        );
        driver.shutdown();
    }

    #[test]
    fn heartbeats_sent_while_the_loop_was_held_up_are_taken_before_the_next_event() {
        let rig = two_range_finders("held-up");
        let mut driver = rig.driver();
        let (mut laser, mut sonar) = rig.heartbeats();

        driver.feed(Event::BrokerStarted);
        let t0 = driver.clock.now_ns();
        beat(&mut laser, "laser", t0);
        beat(&mut sonar, "sonar", t0);
        driver.take_heartbeats(t0);
        assert_eq!(
            service_state(&driver, "sonar"),
            ServiceState::Ready {
                last_heartbeat_ns: t0
            }
        );

        // Held up 155 ms: both beat every 10 ms meanwhile, the sonar's channel read after
        // the laser's; then the laser's exit is taken.
        for k in 1..=15 {
            beat(&mut laser, "laser", t0 + k * 10 * MS);
            beat(&mut sonar, "sonar", t0 + k * 10 * MS - 5 * MS);
        }
        let decisions = driver.feed_at(
            t0 + 155 * MS,
            Event::ProcessExited {
                service: "laser".to_owned(),
                status: ExitStatus::Signal(6),
            },
        );
        assert!(
            matches!(&decisions[..], [Decision { action: Action::RestartScheduled { service, .. }, .. }] if service == "laser"),
            "{decisions:?}"
        );
        assert_eq!(
            service_state(&driver, "sonar"),
            ServiceState::Ready {
                last_heartbeat_ns: t0 + 145 * MS
            }
        );

        // From now on the sonar is silent: failed at its deadline, not later.
        driver.feed_at(t0 + 194 * MS, Event::TimePassed);
        assert!(matches!(
            service_state(&driver, "sonar"),
            ServiceState::Ready { .. }
        ));
        driver.feed_at(t0 + 195 * MS, Event::TimePassed);
        assert!(
            matches!(
                service_state(&driver, "sonar"),
                ServiceState::Stopping { .. }
            ),
            "{}",
            driver.core.snapshot()
        );
        driver.shutdown();
    }

    #[test]
    fn heartbeats_are_taken_in_the_order_they_were_sent_and_never_after_the_event() {
        let beat = |service: &str, health: Health| Event::Heartbeat {
            service: service.to_owned(),
            health,
        };
        let beats = vec![
            (30, beat("laser", Health::Ok)),
            (40, beat("laser", Health::Degraded("dusty".to_owned()))),
            (10, beat("sonar", Health::Ok)),
            (35, beat("sonar", Health::Ok)),
            (50, beat("sonar", Health::Ok)),
        ];
        let order: Vec<(i64, String)> = heartbeats_in_order(beats, 45, 0)
            .into_iter()
            .map(|(at, event)| (at, event.to_string()))
            .collect();
        assert_eq!(
            order,
            [
                (10, "sonar heartbeat: ok".to_owned()),
                (30, "laser heartbeat: ok".to_owned()),
                (35, "sonar heartbeat: ok".to_owned()),
                (40, "laser heartbeat: degraded (dusty)".to_owned()),
                (45, "sonar heartbeat: ok".to_owned()),
            ]
        );
    }

    #[test]
    fn heartbeats_sent_after_a_stale_event_time_keep_their_own_times() {
        let rig = two_range_finders("stale-now");
        let mut driver = rig.driver();
        let (_, mut sonar) = rig.heartbeats();
        // All of it a second ago, so that every beat is in the past when it is taken.
        let t0 = driver.clock.now_ns() - 1000 * MS;
        driver.feed_at(t0, Event::BrokerStarted);
        beat(&mut sonar, "sonar", t0);
        driver.take_heartbeats(t0);
        // The loop took the time t0 + 10 ms, then was held up while the sonar beat on.
        for k in 1..=15 {
            beat(&mut sonar, "sonar", t0 + k * 10 * MS);
        }
        driver.feed_at(t0 + 10 * MS, Event::TimePassed);
        assert_eq!(
            service_state(&driver, "sonar"),
            ServiceState::Ready {
                last_heartbeat_ns: t0 + 150 * MS
            }
        );
        // Dated back to t0 + 10 ms, its beats would have made it silent for 180 ms here.
        driver.feed_at(t0 + 190 * MS, Event::TimePassed);
        assert!(matches!(
            service_state(&driver, "sonar"),
            ServiceState::Ready { .. }
        ));
        driver.shutdown();
    }

    #[test]
    fn the_level_of_a_tracing_line_is_found() {
        assert_eq!(level_of("2025-01-01T00:00:00Z  WARN lewis: x"), "warn");
        assert_eq!(level_of("plain output"), "");
    }
}
