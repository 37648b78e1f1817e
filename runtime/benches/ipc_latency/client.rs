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
use lewis_runtime::broker::live::{UpOptions, run_up};
use lewis_runtime::client::Client;
use lewis_runtime::ipc::{Ipc, Namespace};
use lewis_runtime::robot::{self, Robot};
use lewis_runtime::service::{Context, Service, ServiceRegistry};
use serde::Deserialize;

use crate::common::{CpuMeter, IDLE_LIMIT, Mode, Res, RoleChild, Row, mono_ns, print_result, var};

/// The service kind of the source, known only to this benchmark.
const KIND: &str = "bench-source";
/// The source's name: its provider name in every header, so part of the payload.
const SOURCE: &str = "src";

/// The robot: one source publishing every `period`, started on demand when the
/// application asks for RangeFinder.
fn robot_text(beams: u32, period: Duration, publish: Publish) -> String {
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
"#,
        period = period.as_micros(),
        in_place = publish == Publish::InPlace,
    )
}

fn load(path: &std::path::Path) -> Res<Robot> {
    let known: Vec<&str> = INTERFACES.iter().map(|i| i.name).collect();
    Ok(robot::load(path, &known)?)
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
}

impl Service for Source {
    fn tick_period_ns(&self) -> Option<i64> {
        i64::try_from(self.period.as_nanos()).ok()
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let t0 = mono_ns();
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
        if params.in_place {
            message.ranges = Vec::new();
            message.sensor_positions = Vec::new();
        }
        Ok(Box::new(Source {
            scan: message,
            in_place: params.in_place,
            period: Duration::from_micros(params.period_us),
            last_publish_ns: 0,
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
    run_up(&robot, &options, &mut || {})?;
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

/// The application: a `Client<RangeFinder>` receiving `count` scans in `mode`.
pub fn receive_role() -> Res<()> {
    let namespace = Namespace::new(&var("BENCH_NAMESPACE")?)?;
    let mode = Mode::decode(&var("BENCH_MODE")?)?;
    let count: usize = var("BENCH_COUNT")?.parse()?;
    let read = if var("BENCH_READ")? == "view" {
        Read::View
    } else {
        Read::Decode
    };
    let ipc = std::rc::Rc::new(Ipc::open(&namespace, "bench-app")?);
    let mut client =
        Client::<RangeFinder>::connect(&ipc, "bench-app")?.with_wake_mode(mode.wake_mode());
    client.wait_bound(Duration::from_secs(30))?;
    let mut latencies_ns = Vec::with_capacity(count);
    let mut sends_ns = Vec::with_capacity(count);
    let meter = CpuMeter::start();
    while latencies_ns.len() < count {
        // The clock is read once the sample is in hand: decoded, or its view built.
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
        let Some((t1, sent, send_ns)) = stamps else {
            break;
        };
        latencies_ns.push(t1.saturating_sub(sent as u64));
        sends_ns.push(send_ns as u64);
    }
    let stats = meter.stop(latencies_ns);
    print_result(stats, sends_ns);
    Ok(())
}

/// One row: a broker with the source publishing every `period` as `publish` says, and the
/// application in `mode`, reading as `read` says.
pub fn run(
    mode: Mode,
    publish: Publish,
    read: Read,
    beams: u32,
    period: Duration,
    count: usize,
) -> Res<Row> {
    let dir = tempfile::tempdir()?;
    let robot_path = dir.path().join("robot.toml");
    std::fs::write(&robot_path, robot_text(beams, period, publish))?;
    let namespace = Namespace::unique("bench-client");
    let up = RoleChild::spawn(
        "up",
        &[
            ("BENCH_ROBOT", robot_path.display().to_string()),
            ("BENCH_NAMESPACE", namespace.to_string()),
        ],
    )?;
    let receiver = RoleChild::spawn(
        "client",
        &[
            ("BENCH_NAMESPACE", namespace.to_string()),
            ("BENCH_MODE", mode.encode()),
            ("BENCH_COUNT", count.to_string()),
            (
                "BENCH_READ",
                if read == Read::View { "view" } else { "decode" }.to_owned(),
            ),
        ],
    );
    let result = receiver.and_then(|r| r.result(&mut []));
    stop(up)?;
    result
}

fn stop(mut up: RoleChild) -> Res<()> {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(up.child.id())?);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM)?;
    up.child.wait()?;
    Ok(())
}
