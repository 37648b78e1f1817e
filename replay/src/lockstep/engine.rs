//! The machinery of the harness: the work queue and the timers, the broker's actions, the
//! lives of re-simulated services (start, stop, heartbeats, ticks), handing samples over
//! (or holding them back, see [`super::script`]) and carrying out what a handler did.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::Arc;

use lewis_interfaces::msg::InputRef;
use lewis_robot::ServiceSpec;
use lewis_runtime::broker::{Action, Event, ExitStatus};
use lewis_runtime::names;
use lewis_service::Health;
use lewis_service::{
    CallFailure, CallId, Context, ContextState, Input, Level, ReplyEvent, Service, ServiceConfig,
    decode_header_seq,
};

use super::backend::{Effect, StepBackend};
use super::calls::ReplyTo;
use super::faults::{SIGABRT, injected_out_of_service};
use super::{Emitted, Feed, Gap, Lockstep, Sink, script};
use crate::fault::FaultKind;

/// The longest a start is held back to when the service came up live: a process's start
/// (a debug build's takes most of a second) with room to spare.
const MAX_READY_WAIT_NS: i64 = 2_000_000_000;

/// SIGKILL: how a stalled process is stopped.
const SIGKILL: i32 = 9;
/// SIGTERM: how the broker stops a process.
const SIGTERM: i32 = 15;

/// A re-simulated service and what the harness keeps of it.
pub(super) struct Sim {
    pub(super) instance: Option<Box<dyn Service>>,
    pub(super) state: ContextState,
    pub(super) backend: StepBackend,
    /// Counts the service's lives, so that a timer or reply of an old life is ignored.
    pub(super) generation: u64,
    pub(super) stalled: bool,
    pub(super) tick_period_ns: Option<i64>,
    pub(super) commands_answered: u64,
    /// Samples held back until its next recorded event ([`Work::Input`] only).
    pub(super) held: VecDeque<Work>,
    /// The interfaces it has been bound for in this life: binding one again later is a new
    /// subscriber of a running process.
    pub(super) subscribed: BTreeSet<String>,
}

/// A provider's sample on an interface. The newest is the history (depth 1) of its sensor
/// channel, which a client that subscribes after it was published gets with the next.
#[derive(Clone)]
pub(super) struct Latest {
    channel: Arc<str>,
    seq: u64,
    bytes: Arc<[u8]>,
}

/// Something due at a time.
#[derive(Debug)]
pub(super) enum Timer {
    /// A followed service comes up when it came up live.
    Start {
        service: String,
        generation: u64,
    },
    Tick {
        service: String,
        generation: u64,
    },
    Heartbeat {
        service: String,
        generation: u64,
    },
    BrokerDeadline,
    FaultStarts(usize),
    FaultEnds(usize),
    /// Work due later: a call taken up at its recorded time, a timeout.
    Work(Box<Work>),
    /// The recorded mission started: the sequencer starts ([`super::mission`]).
    MissionStarts,
    /// A mission program comes up (live, a process takes a while to start).
    ProgramComesUp {
        program: String,
        generation: u64,
    },
    /// A mission state's timeout for its program's run `generation`.
    ProgramTimeout {
        program: String,
        generation: u64,
    },
}

/// Something to do now, in order.
#[derive(Debug)]
pub(super) enum Work {
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
        /// When the sample was made.
        published_ns: i64,
        bytes: Arc<[u8]>,
    },
    Command {
        target: String,
        interface: String,
        command: String,
        request: Vec<u8>,
        reply_to: Option<ReplyTo>,
    },
    Reply {
        caller: String,
        generation: u64,
        call: CallId,
        interface: String,
        command: String,
        result: Result<Vec<u8>, CallFailure>,
    },
    /// An event for the mission's sequencer.
    Mission(lewis_sequencer::Event),
    /// A mission program's run ends: its `on_stop`, then `event` for the sequencer.
    ProgramEnded {
        program: String,
        generation: u64,
        event: lewis_sequencer::Event,
    },
}

/// A fresh backend for a service of the robot.
pub(super) fn backend_for(spec: &ServiceSpec) -> StepBackend {
    StepBackend::new(
        &spec.name,
        spec.provides.iter().map(|p| p.interface.clone()),
        spec.requires.iter().cloned(),
    )
}

impl Lockstep<'_> {
    pub(super) fn schedule(&mut self, at_ns: i64, timer: Timer) {
        self.timer_seq += 1;
        self.timers
            .insert((at_ns.max(self.now_ns), self.timer_seq), timer);
    }

    /// Hands a provider's sample to the broker's data checks, then to every re-simulated
    /// client bound to it; a client whose subscriber is new gets the channel's history
    /// (the provider's sample before this one) first.
    pub(super) fn deliver(
        &mut self,
        provider: &str,
        interface: &str,
        channel: &Arc<str>,
        seq: u64,
        bytes: &[u8],
    ) {
        self.check_data(provider, interface, bytes);
        let sample = Latest {
            channel: channel.clone(),
            seq,
            bytes: Arc::from(bytes),
        };
        let history = self
            .latest
            .insert((provider.to_owned(), interface.to_owned()), sample.clone());
        let clients: Vec<String> = self
            .bindings
            .iter()
            .filter(|((client, i), p)| {
                i == interface && *p == provider && self.sims.contains_key(client)
            })
            .map(|((client, _), _)| client.clone())
            .collect();
        // Live, a client moved away had not taken in the move yet when its next recorded
        // event names this sample (shortly after the move: a replay gone another way does
        // not keep it on the old provider).
        let not_yet_moved: Vec<String> = self
            .left
            .iter()
            .filter(|((client, i), (p, moved_ns))| {
                i == interface
                    && p == provider
                    && self.now_ns - moved_ns < script::MAX_HOLD_NS
                    && self.sims.contains_key(client)
                    && self.script.next_names(client, channel, seq)
            })
            .map(|((client, _), _)| client.clone())
            .collect();
        for client in not_yet_moved {
            self.queue_input(client, interface, provider, &sample);
        }
        for client in clients {
            let due = self
                .history_due
                .remove(&(client.clone(), interface.to_owned()));
            if let Some(history) = history.as_ref().filter(|_| due) {
                self.queue_input(client.clone(), interface, provider, history);
            }
            self.queue_input(client, interface, provider, &sample);
        }
    }

    /// Queues `sample` of `provider`'s channel of `interface` for `client`, as published now.
    fn queue_input(&mut self, client: String, interface: &str, provider: &str, sample: &Latest) {
        self.work.push_back(Work::Input {
            client,
            interface: interface.to_owned(),
            provider: provider.to_owned(),
            channel: sample.channel.clone(),
            seq: sample.seq,
            published_ns: self.now_ns,
            bytes: sample.bytes.clone(),
        });
    }

    pub(super) fn note_gap(&mut self, client: &str, interface: &str, from_ns: i64, to_ns: i64) {
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

    pub(super) fn fire(&mut self, timer: Timer, sink: &mut dyn Sink) {
        match timer {
            Timer::Start {
                service,
                generation,
            } => {
                if self
                    .sims
                    .get(&service)
                    .is_some_and(|s| s.generation == generation)
                {
                    self.start_service(&service);
                }
            }
            Timer::Tick {
                service,
                generation,
            } => {
                let Some(sim) = self.running(&service, generation) else {
                    return;
                };
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
                let Some(sim) = self.running(&service, generation) else {
                    return;
                };
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
            Timer::Work(work) => self.work.push_back(*work),
            Timer::MissionStarts => self.mission_starts(sink),
            Timer::ProgramComesUp {
                program,
                generation,
            } => self.program_comes_up(&program, generation),
            Timer::ProgramTimeout {
                program,
                generation,
            } => self.program_timed_out(&program, generation),
        }
    }

    /// Carries out queued work until none is left, then sets the broker's next deadline.
    pub(super) fn pump(&mut self, sink: &mut dyn Sink) {
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
                if let Event::HostLost { host, .. } = &event {
                    self.host_lost(host);
                }
                for decision in self.core.handle(self.now_ns, &event) {
                    sink.emit(Emitted::Decision(&decision));
                    self.carry_out(&decision.action, sink);
                }
            }
            Work::Start {
                service,
                generation,
            } => self.run_start(&service, generation, sink),
            input @ Work::Input { .. } => self.take_input(input, sink),
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
            Work::Mission(event) => self.mission_event(event, sink),
            Work::ProgramEnded {
                program,
                generation,
                event,
            } => self.program_ended(&program, generation, event, sink),
        }
    }

    /// A sample for a client: handed over now, or held back until the client's next
    /// recorded event when the recording says it had not reached the client by then.
    fn take_input(&mut self, input: Work, sink: &mut dyn Sink) {
        let Work::Input {
            client,
            channel,
            seq,
            published_ns,
            ..
        } = &input
        else {
            return;
        };
        let Some(sim) = self.sims.get(client) else {
            return;
        };
        // Live, the client had stopped: the sample never reached it.
        if self.script.gone(client, self.now_ns) {
            self.stats.inputs_after_stop += 1;
            return;
        }
        // A channel's samples keep their order: behind a held one, the next waits too.
        let behind = sim
            .held
            .iter()
            .any(|h| matches!(h, Work::Input { channel: c, .. } if c == channel));
        if behind
            || self
                .script
                .holds(client, channel, *seq, *published_ns, self.now_ns)
        {
            self.stats.inputs_held += 1;
            if let Some(sim) = self.sims.get_mut(client) {
                sim.held.push_back(input);
            }
            return;
        }
        self.hand_over(input, sink);
    }

    /// Hands over the samples held for `service` that need not wait any more, in order.
    pub(super) fn release_held(&mut self, service: &str, sink: &mut dyn Sink) {
        let Some(held) = self
            .sims
            .get_mut(service)
            .map(|s| std::mem::take(&mut s.held))
        else {
            return;
        };
        let mut still: VecDeque<Work> = VecDeque::new();
        for input in held {
            let Work::Input {
                channel,
                seq,
                published_ns,
                ..
            } = &input
            else {
                continue;
            };
            let behind = still
                .iter()
                .any(|h| matches!(h, Work::Input { channel: c, .. } if c == channel));
            if behind
                || self
                    .script
                    .holds(service, channel, *seq, *published_ns, self.now_ns)
            {
                still.push_back(input);
            } else {
                self.hand_over(input, sink);
            }
        }
        if let Some(sim) = self.sims.get_mut(service) {
            sim.held = still;
        }
        self.pump(sink);
    }

    fn hand_over(&mut self, input: Work, sink: &mut dyn Sink) {
        let Work::Input {
            client,
            interface,
            provider,
            channel,
            seq,
            bytes,
            ..
        } = input
        else {
            return;
        };
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

    fn carry_out(&mut self, action: &Action, sink: &mut dyn Sink) {
        match action {
            Action::Start { service } => {
                // The first start of a followed service waits until it came up live; not
                // one much earlier than live (a fault in the replay failed a provider over
                // to it sooner): that one is a start the live run never made.
                let came_up = self.ready_at.remove(service);
                let later = came_up
                    .filter(|at| *at > self.now_ns && *at - self.now_ns <= MAX_READY_WAIT_NS);
                if came_up.is_some_and(|at| at - self.now_ns > MAX_READY_WAIT_NS) {
                    // Its recorded ticks are of a later life: it runs free.
                    self.script.unfollow(service);
                }
                match (later, self.sims.get(service)) {
                    (Some(at), Some(sim)) => {
                        let generation = sim.generation;
                        self.schedule(
                            at,
                            Timer::Start {
                                service: service.clone(),
                                generation,
                            },
                        );
                    }
                    _ => self.start_service(service),
                }
            }
            Action::Stop { service } => {
                self.forget_restart(service);
                self.forget_latest(service);
                self.stop_service(service, sink);
            }
            Action::Bind {
                client,
                interface,
                service,
            } => self.bind(client, interface, service),
            Action::Rebind {
                client,
                interface,
                to,
                ..
            } => self.bind(client, interface, to),
            Action::Unbind {
                client, interface, ..
            } => {
                let key = (client.clone(), interface.clone());
                self.history_due.remove(&key);
                if let Some(old) = self.bindings.remove(&key) {
                    self.left.insert(key, (old, self.now_ns));
                }
            }
            Action::ServiceFailed { service, .. } => {
                self.forget_restart(service);
                self.forget_latest(service);
            }
            Action::RestartScheduled { .. }
            | Action::Reject { .. }
            | Action::AskForHelp { .. }
            | Action::ServiceDegraded { .. }
            | Action::ServiceWaiting { .. }
            | Action::ServiceResumed { .. } => {}
        }
    }

    /// Binds `client` to `provider` for `interface`, as its subscriber sees it live:
    /// - The first binding of an interface in a client's life is made as the process starts,
    ///   before its first heartbeat (where the replay starts it): what the provider published
    ///   since waited in the subscriber's buffer, so the provider's newest sample is handed at
    ///   once (held back like any other when the recording says it had not arrived yet).
    /// - A running client moved to another provider gets a new subscriber, which iceoryx2
    ///   connects, and hands the channel's history (depth 1), when the provider next
    ///   publishes: the provider's sample before that one comes with it, and nothing before
    ///   (a rebind in a run's last moments hands over nothing). Until it takes in the move
    ///   (when it next wakes), the old provider's samples still reach it: those the
    ///   recording says it had are handed over ([`Lockstep::deliver`]).
    fn bind(&mut self, client: &str, interface: &str, provider: &str) {
        let key = (client.to_owned(), interface.to_owned());
        let before = self.bindings.insert(key.clone(), provider.to_owned());
        let Some(sim) = self.sims.get_mut(client) else {
            return;
        };
        let first = sim.subscribed.insert(interface.to_owned());
        // A binding said again (a client asking again) subscribes nothing new.
        if !first && before.as_deref() == Some(provider) {
            return;
        }
        self.history_due.remove(&key);
        self.left.remove(&key);
        if first {
            if let Some(latest) = self
                .latest
                .get(&(provider.to_owned(), interface.to_owned()))
                .cloned()
            {
                self.queue_input(client.to_owned(), interface, provider, &latest);
            }
            return;
        }
        if let Some(old) = before {
            self.left.insert(key.clone(), (old, self.now_ns));
        }
        self.history_due.insert(key);
    }

    /// A provider whose process ended: its channels' history went with its publisher.
    fn forget_latest(&mut self, provider: &str) {
        self.latest.retain(|(p, _), _| p != provider);
    }

    /// A restart that will not come (the service stopped or failed for good): nothing kept
    /// for it strikes a later start.
    fn forget_restart(&mut self, service: &str) {
        self.strikes.remove(service);
    }

    fn start_service(&mut self, service: &str) {
        let strike = self.strikes.get_mut(service).and_then(VecDeque::pop_front);
        let active = self.fault_of(service);
        let crashing = active == Some(FaultKind::Crash) || strike == Some(FaultKind::Crash);
        let stuck = active == Some(FaultKind::Stuck) || strike == Some(FaultKind::Stuck);
        let stalling = active == Some(FaultKind::Stall);
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
        sim.held.clear();
        sim.subscribed.clear();
        let generation = sim.generation;
        if let Ok(instance) = self.registry.build(&config) {
            sim.tick_period_ns = instance.tick_period_ns().filter(|p| *p > 0);
            sim.instance = Some(instance);
        } else {
            // Checked when the harness was made; a constructor that fails later is a
            // process that exits at once.
            sim.instance = None;
            self.work.push_back(Work::Broker(Event::ProcessExited {
                service: service.to_owned(),
                status: ExitStatus::Code(1),
            }));
            return;
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
        if stuck {
            self.stick(service, "its loop stuck at its start (a fault)");
        }
        self.work.push_back(Work::Start {
            service: service.to_owned(),
            generation,
        });
    }

    /// The service's simulation when `generation` is its current instance and it runs (a
    /// timer or start queued for an instance that crashed or was replaced is dropped).
    fn running(&self, service: &str, generation: u64) -> Option<&Sim> {
        self.sims
            .get(service)
            .filter(|s| s.generation == generation && s.instance.is_some())
    }

    fn run_start(&mut self, service: &str, generation: u64, sink: &mut dyn Sink) {
        if self.running(service, generation).is_none() {
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
            let text = format!("{service} could not start: {reason}");
            sink.emit(Emitted::Log {
                service,
                time_ns: self.now_ns,
                level: Level::Error,
                text: &text,
            });
            if self.robot.service(service).is_none() {
                // A mission's program: the sequencer hears of it, not the broker.
                self.program_failed_to_start(service, generation);
                return;
            }
            if let Some(sim) = self.sims.get_mut(service) {
                sim.generation += 1;
            }
            self.work.push_back(Work::Broker(Event::ProcessExited {
                service: service.to_owned(),
                status: ExitStatus::Code(1),
            }));
            return;
        }
        let tick = sim.tick_period_ns;
        let (now, period) = (self.now_ns, self.heartbeat_period_ns);
        // A service that follows the recording ticks when it ticked live, not on its own.
        if let Some(tick) = tick
            && !self.script.follows(service)
        {
            self.schedule(
                now.saturating_add(tick),
                Timer::Tick {
                    service: service.to_owned(),
                    generation,
                },
            );
        }
        // Services heartbeat to the broker; a mission's programs are only its clients.
        if self.robot.service(service).is_some() {
            self.schedule(
                now.saturating_add(period),
                Timer::Heartbeat {
                    service: service.to_owned(),
                    generation,
                },
            );
        }
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
            sim.held.clear();
        }
        self.work.push_back(Work::Broker(Event::ProcessExited {
            service: service.to_owned(),
            status,
        }));
    }

    /// Runs one handler of a running service, then carries out what it did.
    pub(super) fn dispatch(
        &mut self,
        name: &str,
        inputs: Vec<InputRef>,
        sink: &mut dyn Sink,
        handler: impl FnOnce(&mut dyn Service, &mut Context<'_>),
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
        self.check_program_exit(name);
    }

    fn carry_effect(&mut self, name: &str, generation: u64, effect: Effect, sink: &mut dyn Sink) {
        match effect {
            Effect::Publish { interface, bytes } => {
                let seq = decode_header_seq(&bytes);
                let garbled = match self.through_faults(name, &interface, seq, &bytes) {
                    None => return,
                    Some(Cow::Owned(garbled)) => Some(garbled),
                    Some(Cow::Borrowed(_)) => None,
                };
                let bytes = garbled.unwrap_or(bytes);
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
}
