//! Through our typed layers, as an application and a service use them: a real `lewis up`
//! broker (`run_up`), a source service in its own process under the live harness
//! (`run_service`) that publishes a `RangeFinder` with `Context::publish` on its ticks (CDR
//! encoding into the loan included) or computes its arrays straight into the loan with
//! `Context::publish_in_place`, and an application process with a
//! `Client<RangeFinder>` (CDR decoding included) bound to it by the broker.
//!
//! The send time rides in the message: `x_offset` holds the publisher's `CLOCK_MONOTONIC`
//! just before `publish` (exact in an f64 for 104 days of uptime), and `y_offset` the time
//! the previous `publish` call took.

use std::time::Duration;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{INTERFACES, Pose3D, RangeFinder, RangeFinderBulkLens};
use lewis_robot::Robot;
use lewis_runtime::broker::live::{UpOptions, run_up};
use lewis_runtime::client::Client;
use lewis_runtime::ipc::{Ipc, Namespace};
use lewis_service::{BuildError, Context, Service, ServiceRegistry};
use serde::Deserialize;

use crate::common::{
    CpuMeter, IDLE_LIMIT, Mode, Res, RoleChild, Row, Stats, mono_ns, print_result, var,
};
use crate::raw::{Fill, RawPublisher, RawReceiver, wake};

/// The service kind of the source, known only to this benchmark.
const KIND: &str = "bench-source";
/// The source's name: its provider name in every header, so part of the payload.
const SOURCE: &str = "src";

/// The robot: one source publishing every `period`, started on demand when the
/// application asks for RangeFinder. With `twin`, the source alternates its publications
/// with raw iceoryx2 ones ([`Twin`]), one every `period` each.
fn robot_text(beams: u32, period: Duration, publish: Publish, twin: Option<Mode>) -> String {
    format!(
        r#"[robot]
name = "ipc-bench"

[broker]
heartbeat_period_ms = 100
heartbeat_deadline_ms = 10000
startup_deadline_ms = 30000

[[services]]
name = "{SOURCE}"
kind = "{KIND}"
provides = [{{ interface = "RangeFinder", quality = 1, cost = 1 }}]

[services.parameters]
beams = {beams}
period_us = {period}
in_place = {in_place}
twin = "{twin}"
"#,
        period = period.as_micros(),
        in_place = publish == Publish::InPlace,
        twin = twin.map(Mode::encode).unwrap_or_default(),
    )
}

fn load(path: &std::path::Path) -> Res<Robot> {
    let known: Vec<&str> = INTERFACES.iter().map(|i| i.name).collect();
    Ok(lewis_robot::load(path, &known)?)
}

/// A scan of `beams` beams as the source publishes it.
fn scan(beams: u32) -> RangeFinder {
    let n = usize::try_from(beams).unwrap_or(0);
    RangeFinder {
        range_count: i32::try_from(beams).unwrap_or(i32::MAX),
        ranges: (0..n).map(range).collect(),
        max_range: 8.0,
        uniform: false,
        sensor_positions: vec![Pose3D::default(); n],
        ..RangeFinder::default()
    }
}

/// Beam `i` of the source's scan.
fn range(i: usize) -> f64 {
    1.0 + (i % 100) as f64 * 0.01
}

/// The bytes of a scan of `beams` beams on the wire (what the raw baseline sends).
pub fn payload_len(beams: u32) -> usize {
    let mut message = scan(beams);
    message.header.provider = SOURCE.to_owned();
    cdr::encoded_len(&message)
}

/// The beams that make a scan of about `target` bytes (the smallest scan for less).
pub fn beams_for(target: usize) -> u32 {
    let empty = payload_len(0);
    let per_beam = payload_len(1) - empty;
    u32::try_from(target.saturating_sub(empty) / per_beam).unwrap_or(u32::MAX)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Params {
    beams: u32,
    period_us: u64,
    in_place: bool,
    /// The wake-up mode of the raw twin's receiver, empty for none.
    twin: String,
}

/// How the source publishes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Publish {
    /// The scan it holds in its vectors, encoded into the loan (`Context::publish`): one
    /// copy, as raw copying its message in.
    Encode,
    /// The scan's arrays written straight into the loan (`Context::publish_in_place`), by
    /// the same memset of the same byte as raw fills its loan.
    InPlace,
}

/// The source: on every tick, stamps and publishes its scan.
struct Source {
    scan: RangeFinder,
    in_place: bool,
    period: Duration,
    last_publish_ns: u64,
    twin: Option<Twin>,
}

/// A raw iceoryx2 publisher in the source's process, publishing the same bytes on the
/// baseline's channel ([`RawPublisher`]) on every other tick: the baseline and our layers
/// then wake the same way, in the same processes, taking turns every tick.
struct Twin {
    publisher: RawPublisher,
    /// Whether the next tick is the twin's.
    due: bool,
}

impl Service for Source {
    fn tick_period_ns(&self) -> Option<i64> {
        // Taking turns, each stream still publishes once every period.
        let ticks_per_period = if self.twin.is_some() { 2 } else { 1 };
        i64::try_from(self.period.as_nanos() / ticks_per_period).ok()
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let t0 = mono_ns();
        if let Some(twin) = &mut self.twin {
            twin.due = !twin.due;
            if !twin.due {
                let _ = twin.publisher.send(t0);
                return;
            }
        }
        self.scan.x_offset = t0 as f64;
        self.scan.y_offset = self.last_publish_ns as f64;
        if self.in_place {
            // The template holds no arrays; the beams are computed where they are sent.
            let n = usize::try_from(self.scan.range_count).unwrap_or(0);
            let lens = RangeFinderBulkLens {
                ranges: n,
                sensor_positions: n,
            };
            let _ = ctx.publish_in_place(&mut self.scan, &lens, |mut bulk| {
                // The same work as raw's fill: every byte of the arrays set to the same
                // constant by a memset (what a real source computes costs both the same).
                bulk.ranges.as_bytes_mut().fill(0x5a);
                bulk.sensor_positions.as_bytes_mut().fill(0x5a);
            });
        } else {
            let _ = ctx.publish(&mut self.scan);
        }
        self.last_publish_ns = mono_ns().saturating_sub(t0);
    }
}

/// `BENCH service NAME --robot FILE`: what the broker starts for the source.
pub fn service_role(args: &[String]) -> Res<()> {
    let (Some(name), Some(path)) = (args.get(2), args.get(4)) else {
        return Err("usage: service NAME --robot FILE".into());
    };
    let robot = load(std::path::Path::new(path))?;
    let mut registry = ServiceRegistry::new();
    registry.register(KIND, |config| {
        let params: Params = config.parameters()?;
        let mut message = scan(params.beams);
        message.header.provider = SOURCE.to_owned();
        let fail = |e: Box<dyn std::error::Error>| BuildError::Parameters {
            service: SOURCE.to_owned(),
            reason: format!("cannot open the raw twin: {e}"),
        };
        let twin = if params.twin.is_empty() {
            None
        } else {
            let mode = Mode::decode(&params.twin).map_err(fail)?;
            // Fill as our layers write: a memset in place, or a copy of the encoded scan.
            let fill = if params.in_place {
                Fill::Pattern
            } else {
                Fill::CopyIn
            };
            let namespace = Namespace::from_env().map_err(|e| fail(e.into()))?;
            let publisher = RawPublisher::open(
                &namespace,
                wake(mode).map_err(fail)?,
                fill,
                cdr::to_vec(&message),
            )
            .map_err(|e| fail(e.into()))?;
            Some(Twin {
                publisher,
                due: false,
            })
        };
        if params.in_place {
            message.ranges = Vec::new();
            message.sensor_positions = Vec::new();
        }
        Ok(Box::new(Source {
            scan: message,
            in_place: params.in_place,
            period: Duration::from_micros(params.period_us),
            last_publish_ns: 0,
            twin,
        }) as Box<dyn Service>)
    });
    lewis_runtime::live::run_service(
        &robot,
        name,
        &registry,
        &Namespace::from_env()?,
        lewis_runtime::live::ClockSource::Wall,
    )?;
    Ok(())
}

/// The broker, until SIGTERM.
pub fn up_role() -> Res<()> {
    let path = std::path::PathBuf::from(var("BENCH_ROBOT")?);
    let robot = load(&path)?;
    let options = UpOptions {
        robot_path: path,
        namespace: Namespace::new(&var("BENCH_NAMESPACE")?)?,
        lewis_exe: std::env::current_exe()?,
        duration: None,
        stop_grace: Duration::from_millis(300),
        clock: lewis_runtime::live::ClockSource::Wall,
    };
    let signals = lewis_runtime::live::StopSignals::install()?;
    run_up(&robot, &options, &signals, &mut || {})?;
    Ok(())
}

/// How the application reads each scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Read {
    /// Decoded into an owned `RangeFinder` (`recv_timeout`): every byte copied out.
    Decode,
    /// Read in place from shared memory (`recv_view_timeout`): nothing copied.
    View,
}

/// The application: a `Client<RangeFinder>` receiving `count` scans in `mode`; with
/// `BENCH_TWIN_SIZE`, also the raw twin's samples, taking turns with the scans.
pub fn receive_role() -> Res<()> {
    let namespace = Namespace::new(&var("BENCH_NAMESPACE")?)?;
    let mode = Mode::decode(&var("BENCH_MODE")?)?;
    let count: usize = var("BENCH_COUNT")?.parse()?;
    let read = if var("BENCH_READ")? == "view" {
        Read::View
    } else {
        Read::Decode
    };
    let twin = match std::env::var("BENCH_TWIN_SIZE") {
        Ok(len) => Some(RawReceiver::open(&namespace, wake(mode)?, len.parse()?)?),
        Err(_) => None,
    };
    let ipc = std::rc::Rc::new(Ipc::open(&namespace, "bench-app")?);
    let mut client =
        Client::<RangeFinder>::connect(&ipc, "bench-app")?.with_wake_mode(mode.wake_mode());
    client.wait_bound(Duration::from_secs(30))?;
    let mut latencies_ns = Vec::with_capacity(count);
    let mut twin_latencies_ns = Vec::with_capacity(count);
    let mut sends_ns = Vec::with_capacity(count);
    // The send time of the last sample counted, ours or the twin's ([`next_newer`]).
    let mut last_sent = 0;
    let meter = CpuMeter::start();
    while latencies_ns.len() < count {
        if let Some(twin) = &twin {
            let next = || Ok(twin.next(IDLE_LIMIT)?.map(|sent| (mono_ns(), sent, 0)));
            let Some((latency, _)) = next_newer(&mut last_sent, next)? else {
                break;
            };
            twin_latencies_ns.push(latency);
        }
        // The clock is read once the sample is in hand: decoded, or its view built.
        let next = || -> Res<_> {
            let stamps = match read {
                Read::Decode => client.recv_timeout(IDLE_LIMIT)?.map(|sample| {
                    let t1 = mono_ns();
                    (t1, sample.message.x_offset, sample.message.y_offset)
                }),
                Read::View => client.recv_view_timeout(IDLE_LIMIT, |scan| {
                    let t1 = mono_ns();
                    (t1, scan.x_offset, scan.y_offset)
                })?,
            };
            Ok(stamps.map(|(t1, sent, send_ns)| (t1, sent as u64, send_ns as u64)))
        };
        let Some((latency, send_ns)) = next_newer(&mut last_sent, next)? else {
            break;
        };
        latencies_ns.push(latency);
        sends_ns.push(send_ns);
    }
    let stats = meter.stop(latencies_ns);
    // Taking turns, both share the receiver's CPU time.
    let twin_stats = Stats {
        latencies_ns: twin_latencies_ns,
        ..stats
    };
    print_result(stats, sends_ns);
    if twin.is_some() {
        print_result(twin_stats, Vec::new());
    }
    Ok(())
}

/// The latency of the first sample from `next` (its receipt time, its send time and what
/// else it carries) sent after `last_sent`, and what else it carries; `None` when `next`
/// gives up. A sample sent before is one left over from before the receiver joined, or
/// out of turn, and is skipped.
fn next_newer<E>(
    last_sent: &mut u64,
    mut next: impl FnMut() -> Res<Option<(u64, u64, E)>>,
) -> Res<Option<(u64, E)>> {
    while let Some((t1, sent, extra)) = next()? {
        if sent > *last_sent {
            *last_sent = sent;
            return Ok(Some((t1.saturating_sub(sent), extra)));
        }
    }
    Ok(None)
}

/// What one row of the client runs: a broker with the source publishing every `period`
/// as `publish` says, and the application waiting in `mode` for `count` scans of `beams`
/// beams, reading them as `read` says.
#[derive(Debug, Clone, Copy)]
pub struct Setup {
    pub mode: Mode,
    pub publish: Publish,
    pub read: Read,
    pub beams: u32,
    pub period: Duration,
    pub count: usize,
}

impl Setup {
    /// A row of the latency tables: a scan every [`crate::common::gap`], published and read
    /// as `how` says.
    pub fn spaced(mode: Mode, (publish, read): (Publish, Read), beams: u32, count: usize) -> Self {
        Self {
            mode,
            publish,
            read,
            beams,
            period: crate::common::gap(),
            count,
        }
    }
}

/// One row, as `setup` says.
pub fn run(setup: Setup) -> Res<Row> {
    let mut running = start(setup, false)?;
    let ours = running.receiver.row(&mut []);
    running.stop()?;
    ours
}

/// One row taking turns with the raw baseline in the same processes: the source publishes
/// as the setup says and its raw twin the same bytes (copied in, or filled as in place
/// fills), one tick each, each once a period; the application reads our scans as the setup
/// says and the twin's samples with a raw subscriber, both waiting in its mode. Returns
/// (raw, ours).
pub fn run_paired(setup: Setup) -> Res<(Row, Row)> {
    let mut running = start(setup, true)?;
    let receiver = &mut running.receiver;
    let rows = receiver
        .row(&mut [])
        .and_then(|ours| Ok((receiver.row(&mut [])?, ours)));
    running.stop()?;
    rows
}

/// A broker (with its source) and an application, running.
struct Running {
    up: RoleChild,
    receiver: RoleChild,
    /// Holds the robot file the broker reads.
    _dir: tempfile::TempDir,
}

impl Running {
    fn stop(mut self) -> Res<()> {
        let _ = self.receiver.child.wait();
        stop(self.up)
    }
}

fn start(setup: Setup, twin: bool) -> Res<Running> {
    let Setup {
        mode,
        publish,
        read,
        beams,
        period,
        count,
    } = setup;
    let dir = tempfile::tempdir()?;
    let robot_path = dir.path().join("robot.toml");
    let text = robot_text(beams, period, publish, twin.then_some(mode));
    std::fs::write(&robot_path, text)?;
    let namespace = Namespace::unique("bench-client");
    let up = RoleChild::spawn(
        "up",
        &[
            ("BENCH_ROBOT", robot_path.display().to_string()),
            ("BENCH_NAMESPACE", namespace.to_string()),
        ],
    )?;
    let mut env = vec![
        ("BENCH_NAMESPACE", namespace.to_string()),
        ("BENCH_MODE", mode.encode()),
        ("BENCH_COUNT", count.to_string()),
        (
            "BENCH_READ",
            if read == Read::View { "view" } else { "decode" }.to_owned(),
        ),
    ];
    if twin {
        env.push(("BENCH_TWIN_SIZE", payload_len(beams).to_string()));
    }
    match RoleChild::spawn("client", &env) {
        Ok(receiver) => Ok(Running {
            up,
            receiver,
            _dir: dir,
        }),
        Err(e) => {
            stop(up)?;
            Err(e)
        }
    }
}

fn stop(mut up: RoleChild) -> Res<()> {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(up.child.id())?);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM)?;
    up.child.wait()?;
    Ok(())
}
