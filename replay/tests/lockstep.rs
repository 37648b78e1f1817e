//! The lockstep harness and `lewis replay`'s library on a recording made here with the
//! recorder library: a `test-range` laser (and a sonar that never ran), and a consumer
//! service written below that asks the laser for its geometry at start and publishes the
//! nearest reading of every scan as Distance. The recording is what a live run writes:
//! data, heartbeats, the broker's decisions and the laser's command log.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use lewis_emulators::testing::range::{Params, Room, SyntheticScanner};
use lewis_interfaces::msg::{
    CommandLog, Distance, Health as HealthMessage, HostLink, RangeFinder, RangeFinderGetGeometry,
    RangeFinderGetGeometryReply, UnansweredCall,
};
use lewis_interfaces::{Interface, Message, cdr};
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_replay::fault::FaultSpec;
use lewis_replay::report::Report;
use lewis_replay::resim::{ReplayError, ReplayOptions, ServiceSelection, replay};
use lewis_runtime::broker::live::decision_message;
use lewis_runtime::broker::{Action, Decision};
use lewis_runtime::names;
use lewis_service::{Context, Input, ReplyEvent, Rng, Service, ServiceConfig, ServiceRegistry};

const T0: i64 = 1_000_000_000;
const MS: i64 = 1_000_000;

const ROBOT: &str = r#"
[robot]
name = "bench"
description = "a laser, a sonar and a consumer"

[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
data_checks = true
restart = { max_restarts = 2, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }

[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 2, data_rate_hz = 10.0 }]
[services.parameters]
beams = 19
rate_hz = 10.0
noise_m = 0.01
seed = 1

[[services]]
name = "sonar"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1, data_rate_hz = 5.0 }]
[services.parameters]
beams = 24
field_of_view_deg = 360.0
max_range_m = 5.0
rate_hz = 5.0
noise_m = 0.05
seed = 2

[[services]]
name = "consumer"
kind = "test-consumer"
start = "always"
requires = ["RangeFinder"]
provides = [{ interface = "Distance", quality = 1, cost = 1 }]
[services.parameters]
offset_m = 0.25
"#;

/// The consumer's computation: the nearest reading plus an offset, with the range the
/// laser said it has.
fn consumer_distance(scan: &RangeFinder, offset_m: f64, max_range_m: f64) -> Distance {
    let min = scan.ranges.iter().copied().fold(f64::INFINITY, f64::min);
    Distance {
        min_distance: min + offset_m,
        max_range: max_range_m,
        ..Distance::default()
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ConsumerParams {
    offset_m: f64,
}

struct Consumer {
    offset_m: f64,
    max_range_m: f64,
}

impl Service for Consumer {
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        ctx.call(&mut RangeFinderGetGeometry::default())
            .map_err(|e| e.to_string())?;
        Ok(())
    }

    fn on_reply(&mut self, _ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        if let Ok(geometry) = reply.decode::<RangeFinderGetGeometry>() {
            self.max_range_m = geometry.max_range;
        }
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        match input.decode::<RangeFinder>() {
            Ok(scan) => {
                let mut distance = consumer_distance(&scan, self.offset_m, self.max_range_m);
                ctx.publish(&mut distance).unwrap();
            }
            Err(e) => ctx.warn(&format!("bad scan: {e}")),
        }
    }
}

fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_emulators::testing::register(&mut registry);
    registry.register("test-consumer", |config: &ServiceConfig<'_>| {
        let params: ConsumerParams = config.parameters()?;
        Ok(Box::new(Consumer {
            offset_m: params.offset_m,
            max_range_m: 0.0,
        }) as Box<dyn Service>)
    });
    registry
}

struct Writer {
    recorder: Recorder,
}

impl Writer {
    fn channel<T: Interface>(&mut self, provider: &str, topic: &str) -> ChannelId {
        let info = lewis_interfaces::interface_info(T::NAME).unwrap();
        self.recorder
            .add_channel(ChannelSpec::publication(info, provider, topic))
            .unwrap()
    }

    fn write<T: Message>(&mut self, channel: ChannelId, log_ns: i64, message: &T) {
        let data = cdr::to_vec(message);
        self.recorder
            .write(&Sample {
                channel,
                seq: message.header().seq,
                publish_time_ns: message.header().publish_time_ns,
                log_time_ns: log_ns,
                data: &data,
            })
            .unwrap();
    }
}

fn stamp<T: Message>(mut message: T, provider: &str, seq: u64, time_ns: i64) -> T {
    let header = message.header_mut();
    header.provider = provider.into();
    header.seq = seq;
    header.publish_time_ns = time_ns;
    message
}

/// Writes a recording of `duration_ms` of a live run of the robot, the consumer using
/// `offset_m`.
fn make_recording(dir: &Path, duration_ms: i64, offset_m: f64) -> PathBuf {
    make_recording_of(dir, ROBOT, duration_ms, offset_m, &[])
}

/// The robot on two hosts: the laser on the workstation, the rest on the robot host.
fn two_hosts_robot() -> String {
    let hosts = "[[hosts]]\nname = \"robot\"\nlisten = [\"tcp/10.0.0.1:7447\"]\n\n\
                 [[hosts]]\nname = \"workstation\"\n\n";
    let first = ROBOT.find("[[services]]").unwrap();
    format!("{}{hosts}{}", &ROBOT[..first], &ROBOT[first..]).replacen(
        "name = \"laser\"\n",
        "name = \"laser\"\nhost = \"workstation\"\n",
        1,
    )
}

/// As [`make_recording`] of `robot`, with what the broker heard of the other hosts on
/// `/lewis/hosts`: (time from the start, host, event, reason).
fn make_recording_of(
    dir: &Path,
    robot: &str,
    duration_ms: i64,
    offset_m: f64,
    hosts: &[(i64, &str, &str, &str)],
) -> PathBuf {
    make_recording_with(dir, robot, duration_ms, offset_m, hosts, Live::default())
}

/// How the recorded live run went, where it differs from the plain one.
#[derive(Debug, Clone, Copy, Default)]
struct Live {
    /// When the consumer's process came up (its first heartbeat), from the start: it
    /// subscribed as it started, so the scan published before then waits in its buffer.
    consumer_up_ms: i64,
    /// What befalls the laser, the sonar running from the start at 5 Hz (none: the sonar
    /// never runs).
    laser: Option<LaserTrouble>,
}

/// What befalls the laser in a [`Live`] run.
#[derive(Debug, Clone, Copy)]
enum LaserTrouble {
    /// It stalls for good at this time (no heartbeat nor scan from then on); the broker
    /// moves the consumer to the sonar 50 ms later (its deadline).
    Stalls { at_ms: i64 },
    /// It says it is out of service from `from_ms` until `to_ms` and publishes no scan
    /// then; the broker moves the consumer to the sonar as it says so, and back as it says
    /// it is ready again. The consumer takes in the move back late: the sonar's next scan
    /// still reaches it.
    OutOfService { from_ms: i64, to_ms: i64 },
}

/// The time of the generator's first 10 ms step at or after `ms` from the start (steps
/// are at 2 ms, 12 ms, ...).
fn step_at_or_after(ms: i64) -> i64 {
    T0 + 2 * MS + ((ms - 2).max(0) + 9) / 10 * 10 * MS
}

/// The robot whose sonar runs from the start (see [`Live::laser`]), its clients moving
/// back to the laser when it is ready again.
fn robot_with_sonar_running() -> String {
    ROBOT
        .replacen(
            "name = \"sonar\"\n",
            "name = \"sonar\"\nstart = \"always\"\n",
            1,
        )
        .replacen(
            "data_checks = true\n",
            "data_checks = true\nfail_back = true\n",
            1,
        )
}

/// What the consumer's RangeFinder subscriber got live, as iceoryx2 delivers: a sample of
/// its provider as it is published (or as the consumer comes up, for one published before);
/// after a move, the new provider's history (its sample before) with its next sample; with
/// `late`, the old provider's next sample still, the consumer taking in the move after it.
struct ConsumerSubscriber {
    /// The moves still to come: when, and to which provider.
    moves: VecDeque<(i64, &'static str)>,
    late: bool,
    up_ns: i64,
    provider: &'static str,
    history_due: bool,
    /// The provider left behind whose next sample still reaches the consumer.
    leaving: Option<&'static str>,
    /// Each provider's newest sample: its channel's history.
    newest: BTreeMap<&'static str, RangeFinder>,
    /// What the consumer handled: when, from which provider.
    handled: Vec<(i64, &'static str, RangeFinder)>,
}

impl ConsumerSubscriber {
    fn new(moves: Vec<(i64, &'static str)>, late: bool, up_ns: i64) -> Self {
        Self {
            moves: moves.into(),
            late,
            up_ns,
            provider: "laser",
            history_due: false,
            leaving: None,
            newest: BTreeMap::new(),
            handled: Vec::new(),
        }
    }

    fn published(&mut self, provider: &'static str, at_ns: i64, scan: RangeFinder) {
        while let Some((_, to)) = self.moves.pop_front_if(|(m, _)| *m <= at_ns) {
            self.leaving = self.late.then_some(self.provider);
            self.provider = to;
            self.history_due = true;
        }
        let handled_at = (at_ns + MS).max(self.up_ns + MS);
        if provider == self.provider {
            if std::mem::take(&mut self.history_due)
                && let Some(history) = self.newest.get(provider)
            {
                self.handled.push((handled_at, provider, history.clone()));
            }
            self.handled.push((handled_at, provider, scan.clone()));
        } else if self.leaving == Some(provider) {
            self.leaving = None;
            self.handled.push((handled_at, provider, scan.clone()));
        }
        self.newest.insert(provider, scan);
    }
}

/// As [`make_recording_of`], the run going as `live` says.
fn make_recording_with(
    dir: &Path,
    robot: &str,
    duration_ms: i64,
    offset_m: f64,
    hosts: &[(i64, &str, &str, &str)],
    live: Live,
) -> PathBuf {
    let path = dir.join("run.mcap");
    let mut options = RecorderOptions::new(&path);
    options.sync_on_flush = false;
    options.disk_reserve_bytes = 0;
    options.robot_description = Some(RobotDescription {
        file_name: "bench.toml".into(),
        toml: robot.into(),
    });
    let mut w = Writer {
        recorder: Recorder::create(options).unwrap(),
    };
    let broker =
        w.channel::<lewis_interfaces::msg::Broker>(names::BROKER_NODE, names::BROKER_CHANNEL);
    if !hosts.is_empty() {
        let links = w.channel::<HostLink>(names::BROKER_NODE, names::HOSTS_CHANNEL);
        for (seq, (after_ns, host, event, reason)) in (1..).zip(hosts) {
            let at_ns = T0 + after_ns;
            let heard = HostLink {
                host: (*host).into(),
                event: (*event).into(),
                reason: (*reason).into(),
                ..HostLink::default()
            };
            w.write(links, at_ns, &stamp(heard, names::BROKER_NODE, seq, at_ns));
        }
    }
    let laser_health = w.channel::<HealthMessage>("laser", &names::health_channel("laser"));
    let consumer_health =
        w.channel::<HealthMessage>("consumer", &names::health_channel("consumer"));
    let scans = w.channel::<RangeFinder>("laser", &names::data_channel("laser", "RangeFinder"));
    let sonar = live.laser.map(|_| {
        (
            w.channel::<HealthMessage>("sonar", &names::health_channel("sonar")),
            w.channel::<RangeFinder>("sonar", &names::data_channel("sonar", "RangeFinder")),
        )
    });
    let distances = w.channel::<Distance>("consumer", &names::data_channel("consumer", "Distance"));
    let commands = w.channel::<CommandLog>("laser", &names::command_log_channel("laser"));
    // Many publishers, each numbering its own: the copy must keep saying so.
    let calls = {
        let info = lewis_interfaces::interface_info(UnansweredCall::NAME).unwrap();
        let mut spec = ChannelSpec::publication(info, names::BROKER_NODE, names::CALLS_CHANNEL);
        spec.extra_metadata.insert(
            lewis_recorder::META_NUMBERING.into(),
            lewis_recorder::NUMBERED_PER_PUBLISHER.into(),
        );
        w.recorder.add_channel(spec).unwrap()
    };
    for (client, seq) in [("consumer", 7), ("sonar", 1_000_000), ("consumer", 8)] {
        let at_ns = T0 + 20 * MS;
        w.write(
            calls,
            at_ns,
            &stamp(UnansweredCall::default(), client, seq, at_ns),
        );
    }

    let mut decisions = vec![
        (
            T0,
            Action::Start {
                service: "consumer".into(),
            },
        ),
        (
            T0 + MS,
            Action::Bind {
                client: "consumer".into(),
                interface: "RangeFinder".into(),
                service: "laser".into(),
            },
        ),
        (
            T0 + MS,
            Action::Start {
                service: "laser".into(),
            },
        ),
    ];
    // When the broker moved the consumer, to which provider; whether the consumer took in
    // the moves late.
    let (moves, late): (Vec<(i64, &str)>, bool) = match live.laser {
        None => (Vec::new(), false),
        // The broker's deadline is 50 ms after the laser's last heartbeat.
        Some(LaserTrouble::Stalls { at_ms }) => (vec![(T0 + (at_ms + 50) * MS, "sonar")], false),
        // As the laser's health says so, 3 ms into a step.
        Some(LaserTrouble::OutOfService { from_ms, to_ms }) => (
            vec![
                (step_at_or_after(from_ms) + 3 * MS, "sonar"),
                (step_at_or_after(to_ms) + 3 * MS, "laser"),
            ],
            true,
        ),
    };
    if live.laser.is_some() {
        decisions.push((
            T0 + MS,
            Action::Start {
                service: "sonar".into(),
            },
        ));
    }
    if let Some(LaserTrouble::Stalls { .. }) = live.laser {
        decisions.push((
            moves[0].0,
            Action::ServiceFailed {
                service: "laser".into(),
            },
        ));
    }
    let mut from = "laser";
    for &(at_ns, to) in &moves {
        decisions.push((
            at_ns,
            Action::Rebind {
                client: "consumer".into(),
                interface: "RangeFinder".into(),
                from: from.into(),
                to: to.into(),
            },
        ));
        from = to;
    }
    for (seq, (at_ns, action)) in (1..).zip(decisions) {
        let message = decision_message(&Decision {
            at_ns,
            action,
            reason: "recorded".into(),
        });
        w.write(
            broker,
            at_ns,
            &stamp(message, names::BROKER_NODE, seq, at_ns),
        );
    }

    let params = Params {
        beams: 19,
        noise_m: 0.01,
        ..Params::default()
    };
    let scanner = SyntheticScanner::new(&params, Room::DEFAULT);
    let mut rng = Rng::new(1);
    let geometry = RangeFinderGetGeometryReply {
        range_count: 19,
        max_range: params.max_range_m,
        rate: params.rate_hz,
        ..RangeFinderGetGeometryReply::default()
    };
    // The consumer asks for the geometry as it starts.
    let up = T0 + live.consumer_up_ms * MS;
    let request = stamp(
        RangeFinderGetGeometry::default(),
        "consumer",
        1,
        up + 3 * MS,
    );
    let replied_at = up + 6 * MS;
    let log = CommandLog {
        interface: "RangeFinder".into(),
        command: "get_geometry".into(),
        request: cdr::to_vec(&request),
        status: "ok".into(),
        reply: cdr::to_vec(&stamp(geometry, "laser", 1, replied_at)),
        received_ns: up + 5 * MS,
        ..CommandLog::default()
    };
    w.write(commands, replied_at, &stamp(log, "laser", 1, replied_at));

    let end = T0 + duration_ms * MS;
    let stall = match live.laser {
        Some(LaserTrouble::Stalls { at_ms }) => T0 + at_ms * MS,
        _ => i64::MAX,
    };
    let out_of_service = match live.laser {
        Some(LaserTrouble::OutOfService { from_ms, to_ms }) => {
            step_at_or_after(from_ms)..step_at_or_after(to_ms)
        }
        _ => 0..0,
    };
    let sonar_scanner = SyntheticScanner::new(
        &Params {
            beams: 24,
            field_of_view_deg: 360.0,
            max_range_m: 5.0,
            rate_hz: 5.0,
            noise_m: 0.05,
            ..Params::default()
        },
        Room::DEFAULT,
    );
    let mut subscriber = ConsumerSubscriber::new(moves, late, up);
    let (mut health_seq, mut distance_seq) = (0, 0);
    let (mut scan_seq, mut sonar_seq) = (0, 0);
    let mut t = T0 + 2 * MS;
    while t <= end {
        health_seq += 1;
        let ok = HealthMessage {
            state: "ok".into(),
            ..HealthMessage::default()
        };
        if t >= up {
            w.write(
                consumer_health,
                t,
                &stamp(ok.clone(), "consumer", health_seq, t),
            );
        }
        if t < stall {
            let health = if out_of_service.contains(&t) {
                HealthMessage {
                    state: "out-of-service".into(),
                    reason: "no scan".into(),
                    ..HealthMessage::default()
                }
            } else {
                ok.clone()
            };
            w.write(
                laser_health,
                t + 3 * MS,
                &stamp(health, "laser", health_seq, t + 3 * MS),
            );
        }
        if (t - T0 - 2 * MS) % (100 * MS) == 0
            && t > T0 + 50 * MS
            && t < stall
            && !out_of_service.contains(&t)
        {
            scan_seq += 1;
            let scan_at = t + 5 * MS;
            let scan = stamp(
                scanner.range_finder(scanner.ranges(&mut rng)),
                "laser",
                scan_seq,
                scan_at,
            );
            w.write(scans, scan_at, &scan);
            subscriber.published("laser", scan_at, scan);
        }
        if let Some((sonar_health, sonar_scans)) = sonar {
            w.write(
                sonar_health,
                t + 4 * MS,
                &stamp(ok, "sonar", health_seq, t + 4 * MS),
            );
            if (t - T0 - 2 * MS) % (200 * MS) == 0 && t > T0 + 50 * MS {
                sonar_seq += 1;
                let scan_at = t + 6 * MS;
                let scan = stamp(
                    sonar_scanner.range_finder(sonar_scanner.ranges(&mut rng)),
                    "sonar",
                    sonar_seq,
                    scan_at,
                );
                w.write(sonar_scans, scan_at, &scan);
                subscriber.published("sonar", scan_at, scan);
            }
        }
        for (handled_at, provider, scan) in subscriber.handled.drain(..) {
            // A scan from the history is handled before the geometry's reply came.
            let max_range_m = if handled_at < replied_at {
                0.0
            } else {
                params.max_range_m
            };
            distance_seq += 1;
            let mut distance = stamp(
                consumer_distance(&scan, offset_m, max_range_m),
                "consumer",
                distance_seq,
                handled_at,
            );
            distance.header.inputs = vec![lewis_interfaces::msg::InputRef {
                channel: names::data_channel(provider, "RangeFinder"),
                seq: scan.header.seq,
            }];
            w.write(distances, handled_at, &distance);
        }
        t += 10 * MS;
    }
    w.recorder.close().unwrap();
    path
}

fn run(
    input: &Path,
    output: &Path,
    faults: &[&str],
    services: ServiceSelection,
) -> Result<Report, ReplayError> {
    let mut options = ReplayOptions::new(vec![input.to_path_buf()]);
    options.output = Some(output.to_path_buf());
    options.services = services;
    options.faults = faults
        .iter()
        .map(|f| f.parse::<FaultSpec>().unwrap())
        .collect();
    replay(&options, &registry(), &mut |_| {})
}

fn replay_default(dir: &Path, faults: &[&str]) -> Report {
    replay_robot(dir, ROBOT, &[], faults)
}

/// Replays 2 s of `robot` (with `hosts` on `/lewis/hosts`, see [`make_recording_of`]),
/// re-simulating every service but the sources, with `faults`.
fn replay_robot(
    dir: &Path,
    robot: &str,
    hosts: &[(i64, &str, &str, &str)],
    faults: &[&str],
) -> Report {
    let input = make_recording_of(dir, robot, 2000, 0.25, hosts);
    run(
        &input,
        &dir.join("out.mcap"),
        faults,
        ServiceSelection::NonSources,
    )
    .unwrap()
}

/// Replays, re-simulating every service but the sources, `duration_ms` of `robot` run live
/// as `live` says ([`make_recording_with`]).
fn replay_live(robot: &str, duration_ms: i64, live: Live) -> Report {
    let dir = tempfile::tempdir().unwrap();
    let input = make_recording_with(dir.path(), robot, duration_ms, 0.25, &[], live);
    run(
        &input,
        &dir.path().join("out.mcap"),
        &[],
        ServiceSelection::NonSources,
    )
    .unwrap()
}

#[test]
fn a_replay_without_faults_matches_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &[]);
    assert!(report.check.passed, "{report}");
    assert_eq!(report.resimulated, ["consumer", "sonar"], "{report}");
    assert_eq!(report.fed, ["laser"]);
    let distance = &report.divergence[0];
    assert_eq!(distance.channel, "/consumer/Distance");
    assert_eq!(
        (distance.recorded, distance.resimulated),
        (19, 19),
        "{report}"
    );
    assert_eq!(distance.differing, 0);
    // The geometry call was answered from the laser's recorded command log.
    assert_eq!(report.harness.calls_answered_from_log, 1, "{report}");
    assert_eq!(report.harness.calls_defaulted, 0);
}

#[test]
fn a_client_bound_after_a_sample_gets_it_as_the_channels_history() {
    // The consumer came up after the laser's first scan: live, its new subscriber got
    // that scan from the channel's history, and its first distance stands on it.
    let live = Live {
        consumer_up_ms: 150,
        ..Live::default()
    };
    let report = replay_live(ROBOT, 2000, live);
    assert!(report.check.passed, "{report}");
    let distance = &report.divergence[0];
    assert_eq!(
        (distance.recorded, distance.resimulated, distance.differing),
        (19, 19, 0),
        "{report}"
    );
}

#[test]
fn a_client_moved_to_a_running_provider_gets_its_history_with_its_next_sample() {
    // Live, the laser stalled at 1.5 s and the broker moved the consumer to the sonar at
    // 1.55 s; the sonar had run all along. The consumer's new subscriber got the sonar's scan
    // of 1.408 s (its history) only with the next one, at 1.608 s: a run that ended before
    // then had no distance from the sonar at all, one that went on had two at 1.609 s (and
    // one more at 1.809 s).
    for (duration_ms, from_sonar) in [(1600, 0), (2000, 3)] {
        let live = Live {
            laser: Some(LaserTrouble::Stalls { at_ms: 1500 }),
            ..Live::default()
        };
        let report = replay_live(&robot_with_sonar_running(), duration_ms, live);
        assert!(report.check.passed, "{duration_ms} ms: {report}");
        let distance = &report.divergence[0];
        assert_eq!(
            (distance.recorded, distance.resimulated, distance.differing),
            (14 + from_sonar, 14 + from_sonar, 0),
            "{duration_ms} ms: {report}"
        );
    }
}

#[test]
fn a_client_slow_to_take_in_a_move_still_gets_what_the_old_provider_sent_meanwhile() {
    // Live, the laser was out of service from 1 s to 1.3 s: the consumer moved to the sonar
    // and back. It took in the move back only after the sonar's scan of 1.408 s, which it
    // handled: the recording names that scan, so the replay hands it over too.
    let live = Live {
        laser: Some(LaserTrouble::OutOfService {
            from_ms: 1000,
            to_ms: 1300,
        }),
        ..Live::default()
    };
    let report = replay_live(&robot_with_sonar_running(), 2000, live);
    assert!(report.check.passed, "{report}");
    let distance = &report.divergence[0];
    // 16 scans of the laser and its history again after the move back; the sonar's
    // history, 2 scans of its own and the one after the move back.
    assert_eq!(
        (distance.recorded, distance.resimulated, distance.differing),
        (21, 21, 0),
        "{report}"
    );
}

#[test]
fn a_stalled_laser_fails_over_to_the_sonar_within_the_heartbeat_deadline() {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &["laser"]);
    let fault = &report.faults[0];
    assert_eq!(
        fault.at_ns,
        report.duration_ns / 2,
        "half-way through: {report}"
    );
    println!("{report}");
    let takeover = &fault.takeovers[0];
    assert_eq!(
        (takeover.client.as_str(), takeover.provider.as_str()),
        ("consumer", "sonar"),
        "{report}"
    );
    // The deadline is 50 ms after the last heartbeat, which came at most 10 ms before.
    assert!(
        (40 * MS..=60 * MS).contains(&takeover.latency_ns),
        "{report}"
    );
    assert!(
        fault.reactions.iter().any(|r| r.action == "laser failed"),
        "{report}"
    );
    // The consumer went on with sonar data, so its outputs diverged from the laser's.
    let distance = &report.divergence[0];
    assert!(distance.differing > 0, "{report}");
    assert!(
        distance.first_divergence_ns.unwrap() >= 1000 * MS,
        "{report}"
    );
    assert!(!report.check.passed);
    let gap = report.longest_gap.as_ref().unwrap();
    assert_eq!(gap.client, "consumer");
    assert!(gap.gap_ns > 100 * MS && gap.gap_ns < 500 * MS, "{report}");
}

#[test]
fn out_of_service_moves_the_client_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &["laser@0.5s:out-of-service"]);
    let takeover = &report.faults[0].takeovers[0];
    assert_eq!(
        (takeover.provider.as_str(), takeover.latency_ns),
        ("sonar", 0),
        "{report}"
    );
}

#[test]
fn a_crash_window_restarts_the_laser_and_the_client_stays_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &["laser@0.5s-0.52s:crash"]);
    let fault = &report.faults[0];
    assert!(fault.takeovers.is_empty(), "{report}");
    assert!(
        fault
            .reactions
            .iter()
            .any(|r| r.action.starts_with("restart laser")),
        "{report}"
    );
}

#[test]
fn a_stuck_laser_is_failed_at_once_and_its_client_moves_to_the_sonar() {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &["laser@0.5s:stuck"]);
    let fault = &report.faults[0];
    let takeover = &fault.takeovers[0];
    // Its heartbeat thread says so: no deadline of silence is waited for.
    assert_eq!(
        (takeover.provider.as_str(), takeover.latency_ns),
        ("sonar", 0),
        "{report}"
    );
    assert!(
        fault
            .reactions
            .iter()
            .any(|r| r.action == "laser failed" && r.reason.contains("stuck")),
        "{report}"
    );
}

#[test]
fn crashes_between_a_death_and_its_restart_strike_the_restarted_processes() {
    let dir = tempfile::tempdir().unwrap();
    // The second and third crash come before the restart after the first (20 ms of
    // backoff): there was no process to strike then, so the next two processes die at their
    // start. Three deaths: beyond the restart policy (2), as if each had found a process.
    let report = replay_default(
        dir.path(),
        &[
            "laser@0.5s-0.501s:crash",
            "laser@0.505s-0.506s:crash",
            "laser@0.51s-0.511s:crash",
        ],
    );
    let failed: Vec<&str> = report
        .failures
        .iter()
        .filter(|f| f.service == "laser")
        .map(|f| f.reason.as_str())
        .collect();
    assert!(
        failed.iter().any(|r| r.contains("its failure 3")),
        "{failed:?}\n{report}"
    );
}

/// The laser on the workstation: a replay joins the host when the recording says the live
/// broker heard it join, and loses it when it was lost, or when a fault says so.
fn replay_two_hosts(dir: &Path, hosts: &[(i64, &str, &str, &str)], faults: &[&str]) -> Report {
    replay_robot(dir, &two_hosts_robot(), hosts, faults)
}

#[test]
fn a_recording_of_two_hosts_replays_as_one_robot() {
    let dir = tempfile::tempdir().unwrap();
    let joined = [(0, "workstation", "joined", "")];
    let report = replay_two_hosts(dir.path(), &joined, &[]);
    assert!(report.check.passed, "{report}");
    assert_eq!(report.divergence[0].resimulated, 19, "{report}");
}

#[test]
fn a_host_lost_in_the_recording_is_lost_again_and_its_clients_move() {
    let dir = tempfile::tempdir().unwrap();
    let hosts = [
        (0, "workstation", "joined", ""),
        (1000 * MS, "workstation", "lost", "its Zenoh session closed"),
    ];
    let report = replay_two_hosts(dir.path(), &hosts, &[]);
    let text = report.to_string();
    assert!(
        text.contains(
            "laser failed at 1s: laser runs on host workstation, which is lost: its Zenoh session closed"
        ),
        "{report}"
    );
    assert!(
        text.contains("consumer got RangeFinder from sonar"),
        "{report}"
    );
    // Without the host's word, its services never run: as live, they wait for it to join.
    let dir = tempfile::tempdir().unwrap();
    let report = replay_two_hosts(dir.path(), &[], &[]);
    assert!(
        !report
            .to_string()
            .contains("consumer got RangeFinder from laser"),
        "{report}"
    );
}

#[test]
fn a_host_injected_lost_takes_its_providers_and_joins_again_at_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let joined = [(0, "workstation", "joined", "")];
    let report = replay_two_hosts(dir.path(), &joined, &["workstation@1s-1.5s"]);
    let fault = &report.faults[0];
    assert_eq!(fault.kind, lewis_replay::fault::FaultKind::HostLost);
    let takeover = &fault.takeovers[0];
    assert_eq!(
        (
            takeover.client.as_str(),
            takeover.provider.as_str(),
            takeover.latency_ns
        ),
        ("consumer", "sonar", 0),
        "{report}"
    );
    assert!(
        report.to_string().contains(
            "laser runs on host workstation, which is lost: injected fault workstation@1s-1.5s"
        ),
        "{report}"
    );
}

/// The laser's data goes bad at 1 s (heartbeats go on): the check named `check` fails it
/// and the consumer moves to the sonar, with the check in the reason.
fn bad_data_fails_over(fault: &str, check: &str) -> Report {
    let dir = tempfile::tempdir().unwrap();
    let report = replay_default(dir.path(), &[fault]);
    let fault = &report.faults[0];
    let takeover = fault
        .takeovers
        .first()
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(
        (takeover.client.as_str(), takeover.provider.as_str()),
        ("consumer", "sonar"),
        "{report}"
    );
    assert!(
        fault.reactions.iter().any(|r| r.action == "laser failed"
            && r.reason
                .contains(&format!("laser failed its {check} check on RangeFinder"))),
        "{report}"
    );
    assert!(
        report
            .to_string()
            .contains(&format!("failed its {check} check")),
        "the report names the check: {report}"
    );
    // The broker's failures are listed whatever caused them, at the time of the reaction.
    let failure = report
        .failures
        .first()
        .unwrap_or_else(|| panic!("{report}"));
    let reaction = fault
        .reactions
        .iter()
        .find(|r| r.action == "laser failed")
        .unwrap();
    assert_eq!(
        (failure.service.as_str(), failure.at_ns, &failure.reason),
        ("laser", reaction.at_ns, &reaction.reason),
        "{report}"
    );
    assert!(
        report.to_string().contains(&format!(
            "broker: laser failed at {}: ",
            lewis_replay::fault::format_seconds(failure.at_ns)
        )),
        "{report}"
    );
    report
}

#[test]
fn garbage_fails_the_laser_over_on_its_values_check() {
    // Garbage used to make no decision; the broker's values check fails the laser on its
    // first bad sample, the scan 7 ms after the fault starts.
    let report = bad_data_fails_over("laser@1s-1.5s:garbage", "values");
    assert_eq!(report.faults[0].takeovers[0].latency_ns, 7 * MS, "{report}");
    assert!(report.harness.faulted_publications >= 1, "{report}");
}

#[test]
fn a_frozen_laser_fails_over_on_its_frozen_check() {
    let report = bad_data_fails_over("laser@1s:frozen", "frozen");
    // The last good scan (0.907 s) and four repeats of it from 1.007 s: the fifth identical
    // payload comes 307 ms after the fault starts.
    assert_eq!(
        report.faults[0].takeovers[0].latency_ns,
        307 * MS,
        "{report}"
    );
}

#[test]
fn a_slow_laser_fails_over_on_its_rate_check() {
    bad_data_fails_over("laser@1s:slow", "rate");
}

#[test]
fn a_changed_parameter_fails_the_check_with_the_size_of_the_difference() {
    let dir = tempfile::tempdir().unwrap();
    // Recorded with an offset of 0.5 m, replayed with the robot file's 0.25 m: the
    // recording stores the robot file, so record with another offset to change the code's
    // input instead.
    let input = make_recording(dir.path(), 1000, 0.5);
    let report = run(
        &input,
        &dir.path().join("out.mcap"),
        &[],
        ServiceSelection::NonSources,
    )
    .unwrap();
    assert!(!report.check.passed);
    let distance = &report.divergence[0];
    assert_eq!(distance.differing, distance.recorded, "{report}");
    assert!(
        (distance.max_numeric_difference - 0.25).abs() < 1e-9,
        "{report}"
    );
    assert!(
        report
            .to_string()
            .contains("outputs differ from the recording"),
        "{report}"
    );
}

#[test]
fn the_same_replay_gives_the_same_bytes_with_and_without_faults() {
    let dir = tempfile::tempdir().unwrap();
    let input = make_recording(dir.path(), 2000, 0.25);
    for faults in [
        &[][..],
        &["laser@0.7s:crash", "laser@1.2s-1.6s:garbage"][..],
        &["laser@1s:frozen"][..],
        &["laser@0.8s:slow"][..],
    ] {
        // The file name is in the recorder's stats: same name, two folders.
        std::fs::create_dir_all(dir.path().join("a")).unwrap();
        std::fs::create_dir_all(dir.path().join("b")).unwrap();
        let a = dir.path().join("a/out.mcap");
        let b = dir.path().join("b/out.mcap");
        run(&input, &a, faults, ServiceSelection::NonSources).unwrap();
        run(&input, &b, faults, ServiceSelection::NonSources).unwrap();
        let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
        assert!(a.len() > 1000);
        assert!(a == b, "replays of {faults:?} differ");
    }
}

#[test]
fn the_output_holds_the_recording_and_the_replay_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.mcap");
    let input = make_recording(dir.path(), 1000, 0.25);
    run(&input, &out, &["laser@0.5s"], ServiceSelection::NonSources).unwrap();
    let info = lewis_recording::inspect(&out, &lewis_recording::InfoOptions::default()).unwrap();
    let topics: Vec<&str> = info.channels.iter().map(|c| c.topic.as_str()).collect();
    for topic in [
        "/laser/RangeFinder",
        "/consumer/Distance",
        "/replay/consumer/Distance",
        "/replay/sonar/RangeFinder",
        "/replay/lewis/broker",
        "/replay/lewis/faults",
    ] {
        assert!(topics.contains(&topic), "{topic} missing from {topics:?}");
    }
    // The recording's channels are copied as they were, metadata and all (a channel of
    // many publishers read as one would count their numbering as losses), and lose nothing.
    let before = lewis_recording::Recording::open(&[input]).unwrap();
    let after = lewis_recording::Recording::open(&[out]).unwrap();
    for (name, topic) in before.topics() {
        // The replay's recorder writes statistics of its own.
        if &**name == lewis_recorder::STATS_TOPIC {
            continue;
        }
        let copy = &after.topics()[name];
        assert_eq!(copy.metadata, topic.metadata, "{name}");
    }
    assert!(
        info.channels.iter().all(|c| c.lost_count.unwrap_or(0) == 0),
        "{:?}",
        info.channels
    );
}

#[test]
fn options_that_do_not_fit_the_recording_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let input = make_recording(dir.path(), 1000, 0.25);
    let out = dir.path().join("out.mcap");
    let check = |faults: &[&str], services: ServiceSelection, expected: &str| {
        let e = run(&input, &out, faults, services).unwrap_err().to_string();
        assert!(e.contains(expected), "{e}");
    };
    check(
        &["lidar"],
        ServiceSelection::NonSources,
        "no service `lidar`; it has: laser, sonar, consumer",
    );
    check(
        &["laser@5s"],
        ServiceSelection::NonSources,
        "5s is outside the recording; choose times from 0s to 0.995s (its length)",
    );
    check(
        &[],
        ServiceSelection::Only(vec!["ghost".into()]),
        "`ghost`, which the recorded robot does not have; it has: laser, sonar, consumer",
    );
    let e = run(&input, &input, &[], ServiceSelection::NonSources).unwrap_err();
    assert!(
        e.to_string().contains("is one of the recordings replayed"),
        "{e}"
    );
}

#[test]
fn re_simulating_everything_runs_the_laser_from_its_seed() {
    let dir = tempfile::tempdir().unwrap();
    let input = make_recording(dir.path(), 1000, 0.25);
    let report = run(
        &input,
        &dir.path().join("out.mcap"),
        &[],
        ServiceSelection::All,
    )
    .unwrap();
    assert_eq!(report.resimulated, ["consumer", "laser", "sonar"]);
    assert!(report.fed.is_empty());
    let laser = report
        .divergence
        .iter()
        .find(|d| d.channel == "/laser/RangeFinder")
        .unwrap();
    assert!(laser.resimulated >= 9, "{report}");
}
