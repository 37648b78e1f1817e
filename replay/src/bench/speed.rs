//! `lewis bench replay RUN.mcap`: how fast a recording replays, side by side in one run:
//!
//! 1. **`lewis replay`**: the whole command (read and decompress the file, re-simulate,
//!    compare, write the output file), as a multiple of the recording's real time.
//! 2. **The lockstep harness** alone: the same re-simulation, the messages already read
//!    into memory, nothing written or compared.
//! 3. **The services called directly** in a loop with the same inputs: the followed
//!    services built from the same robot file, handed each sample of the channels their
//!    recorded provenance names, ticked at their recorded tick times, given their recorded
//!    commands, through a backend that does nothing. No broker, no ordering window, no
//!    provenance bookkeeping: the floor the harness is measured against.
//!
//! Each is run several times and the best time kept (the machine's other work only ever
//! makes a run slower). The wall clock is read here, never in a replay.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::time::Instant;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{CommandLog, InputRef};
use lewis_robot::Robot;
use lewis_service::Health;
use lewis_service::{
    Backend, CallFailure, CallId, ContextError, ContextState, IncomingCommand, Input, Level,
    Service, ServiceConfig, ServiceRegistry,
};
use serde::Serialize;

use crate::lockstep::{Emitted, Lockstep, Route, Sink, route};
use crate::resim::lookahead::Lookahead;
use crate::resim::{ReplayError, ReplayOptions, prepare, replay};
use lewis_recording::{RecordedMessage, Recording};

/// How to measure.
#[derive(Debug, Clone)]
pub struct SpeedOptions {
    /// The replay measured (its output goes to a scratch file).
    pub replay: ReplayOptions,
    /// Runs of each measure; the best is kept.
    pub runs: usize,
}

/// One measure: the best of its runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Timing {
    /// The best time, in seconds.
    pub best_secs: f64,
    /// The recording's length over that time.
    pub times_real_time: f64,
}

/// The three measures, side by side.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpeedReport {
    /// The recording.
    pub recording: String,
    /// Its length, in seconds.
    pub duration_secs: f64,
    /// Its messages.
    pub messages: u64,
    /// The services re-simulated.
    pub resimulated: Vec<String>,
    /// The services called directly (the followed ones).
    pub direct: Vec<String>,
    /// Events handed to them in the direct loop (samples, ticks, commands).
    pub direct_events: u64,
    /// Runs of each measure.
    pub runs: usize,
    /// `lewis replay`, whole.
    pub replay: Timing,
    /// The harness alone, messages in memory.
    pub harness: Timing,
    /// The services called directly.
    pub direct_loop: Timing,
}

/// Measures (see the module documentation).
///
/// # Errors
/// When the recording cannot be replayed.
pub fn measure(
    options: &SpeedOptions,
    registry: &ServiceRegistry,
) -> Result<SpeedReport, ReplayError> {
    let runs = options.runs.max(1);
    let recording = Recording::open(&options.replay.inputs)?;
    let duration_secs = nanos_to_secs(recording.end_ns() - recording.start_ns());
    let speed = |secs: f64| Timing {
        best_secs: secs,
        times_real_time: if secs > 0.0 {
            duration_secs / secs
        } else {
            f64::INFINITY
        },
    };

    let mut best_replay = f64::INFINITY;
    let mut report = None;
    for _ in 0..runs {
        let started = Instant::now();
        report = Some(replay(&options.replay, registry, &mut |_| {})?);
        best_replay = best_replay.min(started.elapsed().as_secs_f64());
    }
    let messages = report.map_or(0, |r| r.messages_read);

    let prepared = prepare(&recording, &options.replay, registry, None)?;
    let robot = &prepared.replayed.robot;
    let stored: Vec<RecordedMessage> = recording.messages()?.collect::<Result<_, _>>()?;
    let mut best_harness = f64::INFINITY;
    for _ in 0..runs {
        let messages = stored.clone();
        let mut harness = Lockstep::new(robot, registry, prepared.plan.clone())?;
        let mut sink = CountingSink::default();
        let started = Instant::now();
        let mut window = Lookahead::new(messages.into_iter().map(Ok));
        let first = window
            .peek_time(&mut |m, t| harness.preview(m, t))?
            .unwrap_or(recording.start_ns());
        harness.start(first.min(recording.start_ns()), &mut sink);
        while let Some((at, message)) = window.next(&mut |m, t| harness.preview(m, t))? {
            if window.read_whole() {
                harness.read_whole();
            }
            harness.feed(&message, at, &mut sink);
        }
        harness.finish(recording.end_ns(), &mut sink);
        best_harness = best_harness.min(started.elapsed().as_secs_f64());
    }

    let ordered = replay_order(stored)?;
    let direct: Vec<String> = prepared.plan.followed.iter().cloned().collect();
    let named = named_channels(&ordered, robot, &prepared.plan.followed);
    let mut best_direct = f64::INFINITY;
    let mut direct_events = 0;
    for _ in 0..runs {
        let mut services = DirectServices::build(robot, registry, &direct)?;
        let started = Instant::now();
        direct_events = services.run(&ordered, robot, &named);
        best_direct = best_direct.min(started.elapsed().as_secs_f64());
    }

    Ok(SpeedReport {
        recording: options
            .replay
            .inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "),
        duration_secs,
        messages,
        resimulated: prepared.resimulated.iter().cloned().collect(),
        direct,
        direct_events,
        runs,
        replay: speed(best_replay),
        harness: speed(best_harness),
        direct_loop: speed(best_direct),
    })
}

impl fmt::Display for SpeedReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "replay speed of {} ({:.1} s recorded, {} messages; re-simulated: {}); best of {} runs",
            self.recording,
            self.duration_secs,
            self.messages,
            self.resimulated.join(", "),
            self.runs
        )?;
        let row = |f: &mut fmt::Formatter<'_>, what: &str, t: &Timing| {
            writeln!(
                f,
                "  {what:<58} {:>9.1} ms {:>9.0}x real time",
                t.best_secs * 1e3,
                t.times_real_time
            )
        };
        row(
            f,
            "lewis replay (read, re-simulate, compare, write)",
            &self.replay,
        )?;
        row(
            f,
            "lockstep harness (messages in memory, no output)",
            &self.harness,
        )?;
        row(
            f,
            &format!("{} called directly, same inputs", self.direct.join(" and ")),
            &self.direct_loop,
        )?;
        let extra = self.harness.best_secs - self.direct_loop.best_secs;
        let per_message = extra / self.messages.max(1) as f64;
        write!(
            f,
            "harness overhead over the direct calls: {:.2}x ({:+.1} ms, {:.2} us per recorded message; {} events in the direct loop)",
            self.harness.best_secs / self.direct_loop.best_secs.max(f64::MIN_POSITIVE),
            extra * 1e3,
            per_message * 1e6,
            self.direct_events
        )
    }
}

fn nanos_to_secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

/// The messages (read in log-time order) in replay order, with their replay times.
fn replay_order(
    messages: Vec<RecordedMessage>,
) -> Result<Vec<(i64, RecordedMessage)>, ReplayError> {
    let mut window = Lookahead::new(messages.into_iter().map(Ok));
    let mut out = Vec::new();
    while let Some(next) = window.next(&mut |_, _| {})? {
        out.push(next);
    }
    Ok(out)
}

/// The input channels each service's recorded outputs name: what it was fed live.
fn named_channels(
    messages: &[(i64, RecordedMessage)],
    robot: &Robot,
    services: &BTreeSet<String>,
) -> BTreeMap<String, BTreeSet<String>> {
    let mut named: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (_, m) in messages {
        if let Route::Data { service, .. } = route(&m.topic, robot)
            && services.contains(&service)
            && let Ok(header) = (Input {
                interface: "",
                provider: "",
                channel: &m.topic,
                bytes: &m.data,
            })
            .header()
        {
            named
                .entry(service)
                .or_default()
                .extend(header.inputs.into_iter().map(|i| i.channel));
        }
    }
    named
}

/// Counts what the harness produced, and drops it.
#[derive(Default)]
struct CountingSink {
    produced: u64,
}

impl Sink for CountingSink {
    fn emit(&mut self, _event: Emitted<'_>) {
        self.produced += 1;
    }
}

/// A backend that does nothing but hold the clock (and encode what is published, as any
/// harness must).
#[derive(Default)]
struct NullBackend {
    now_ns: i64,
    buffer: Vec<u8>,
}

impl Backend for NullBackend {
    fn now_ns(&self) -> i64 {
        self.now_ns
    }

    fn publish(
        &mut self,
        _interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        self.buffer.resize(len_bytes, 0);
        encode(&mut self.buffer);
        Ok(())
    }

    fn call(
        &mut self,
        _call: CallId,
        _interface: &str,
        _command: &'static str,
        _frame: &[u8],
        _timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        Ok(())
    }

    fn health_changed(&mut self, _health: &Health) {}

    fn log(&mut self, _service: &str, _level: Level, _text: &str) {}
}

/// The services of the direct loop.
struct DirectServices {
    services: BTreeMap<String, (Box<dyn Service>, ContextState, NullBackend, bool)>,
}

impl DirectServices {
    fn build(
        robot: &Robot,
        registry: &ServiceRegistry,
        names: &[String],
    ) -> Result<Self, ReplayError> {
        let mut services = BTreeMap::new();
        for name in names {
            let Some(spec) = robot.service(name) else {
                continue;
            };
            let config = ServiceConfig {
                spec,
                heartbeat_period_ms: robot.broker.heartbeat_period_ms,
            };
            let instance = registry
                .build(&config)
                .map_err(|e| ReplayError::Lockstep(e.into()))?;
            let ticks = instance.tick_period_ns().is_some();
            services.insert(
                name.clone(),
                (
                    instance,
                    ContextState::new(name, config.seed()),
                    NullBackend::default(),
                    ticks,
                ),
            );
        }
        Ok(Self { services })
    }

    /// Hands every event over in order; returns how many.
    fn run(
        &mut self,
        messages: &[(i64, RecordedMessage)],
        robot: &Robot,
        named: &BTreeMap<String, BTreeSet<String>>,
    ) -> u64 {
        let mut events = 0;
        let mut last_tick: BTreeMap<String, i64> = BTreeMap::new();
        for (at, m) in messages {
            match route(&m.topic, robot) {
                Route::Data { service, interface } => {
                    if let Some((instance, state, backend, true)) = self.services.get_mut(&service)
                        && last_tick.insert(service.clone(), *at) != Some(*at)
                    {
                        backend.now_ns = *at;
                        instance.on_tick(&mut state.context(backend));
                        events += 1;
                    }
                    for (name, (instance, state, backend, _)) in &mut self.services {
                        if !named.get(name).is_some_and(|c| c.contains(&*m.topic)) {
                            continue;
                        }
                        backend.now_ns = *at;
                        state.set_inputs(vec![InputRef {
                            channel: m.topic.to_string(),
                            seq: m.seq,
                        }]);
                        let input = Input {
                            interface: &interface,
                            provider: &service,
                            channel: &m.topic,
                            bytes: &m.data,
                        };
                        instance.on_input(&mut state.context(backend), &input);
                        state.set_inputs(Vec::new());
                        events += 1;
                    }
                }
                Route::Commands { service } => {
                    let Some((instance, state, backend, _)) = self.services.get_mut(&service)
                    else {
                        continue;
                    };
                    let Ok(log) = cdr::from_bytes::<CommandLog>(&m.data) else {
                        continue;
                    };
                    backend.now_ns = *at;
                    let command = IncomingCommand {
                        interface: &log.interface,
                        command: &log.command,
                        bytes: &log.request,
                    };
                    let _ = instance.on_command(&mut state.context(backend), &command);
                    events += 1;
                }
                Route::Health { .. } | Route::Broker | Route::Cpu | Route::Hosts | Route::Other => {
                }
            }
        }
        events
    }
}
