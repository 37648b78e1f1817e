//! Reflex latency through three processes, end to end: from the publication of the laser
//! scan in which an obstacle first appears on the robot's way to the arrival at the base of
//! the velocity command that scan caused (laser -> obstacle_avoider -> vector_mover ->
//! base).
//!
//! Real processes under a real broker (`run_up`, what `lewis up` runs), each service under
//! the live harness: the real `obstacle_avoider` and `vector_mover` services (the motion
//! crate's code, registered here as in `lewis`), and `bench-robot`, a small simulated robot
//! of this benchmark in a process of its own: a synchro-drive base (Synchrodrive, Egomotion
//! at 50 Hz) and a forward laser (RangeFinder, 181 beams over 180 degrees, at the SICK's
//! 37.5 Hz) in a corridor 3 m wide. The avoider drives to a goal 1 km down it. At most
//! every half second, once the robot cruises straight down the corridor, a post appears
//! 0.75 m ahead of it (a person stepping in) and walks off 200 ms later; the robot goes
//! round it (the avoider remembers it) and cruises on, so a trial takes 3-5 s. The
//! avoider's reflex sees the post in the first scan that shows it and sends the
//! VectorMover a stop, which sends the base slower velocities at once; the first
//! `set_velocity` after that scan that asks for at least 0.02 m/s less than the robot
//! cruised at is its effect (the ticks' commands while cruising differ by less). Both times are the robot process's clock: the scan's header stamp (its
//! publication) and the handling of the command. A trial without an effect within 300 ms
//! is counted as missed.
//!
//! Beside it, in the same run, the IPC hop alone: raw iceoryx2 publish-subscribe of a CDR
//! `RangeFinder` of the same 181 beams, one process to another, woken by an event, the
//! baseline of `runtime/benches/ipc_latency` (`lewis_runtime::ipc::baseline`).
//!
//! `cargo bench -p lewis-tests --bench reflex` (`-- --trials N`, default 300; the first 10
//! are dropped as warm-up).

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stdout,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "a benchmark: it reports on stdout, and its statistics are floating point"
)]

use std::f64::consts::{FRAC_PI_2, PI};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Egomotion, INTERFACES, Pose2D, Pose3D, RangeFinder, Synchrodrive, SynchrodriveCommand,
    SynchrodriveSetVelocityReply, SynchrodriveStopReply,
};
use lewis_robot::Robot;
use lewis_runtime::broker::live::{UpOptions, run_up};
use lewis_runtime::ipc::Namespace;
use lewis_runtime::ipc::baseline::{Fill, RawPublisher, RawReceiver, Wake};
use lewis_runtime::live::{ClockSource, StopSignals, run_service};
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceRegistry,
};
use serde::Deserialize;

/// Selects the broker role of a child process of the benchmark.
const ROLE_ENV: &str = "LEWIS_BENCH_ROLE";
/// The kind of the simulated robot, known only to this benchmark.
const ROBOT_KIND: &str = "bench-robot";
/// Trials dropped at the start (connections, page faults, the first plans).
const WARMUP: usize = 10;
/// The laser's beams.
const BEAMS: usize = 181;
/// How far the laser sees, in m.
const MAX_RANGE_M: f64 = 8.0;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().collect();
    // What the broker starts for every service: `BENCH service NAME --robot FILE`.
    if args.get(1).map(String::as_str) == Some("service") {
        return service_role(&args);
    }
    match std::env::var(ROLE_ENV).as_deref() {
        Ok("up") => return up_role(),
        Ok("raw") => return raw_role(),
        _ => {}
    }
    let trials = args
        .iter()
        .position(|a| a == "--trials")
        .and_then(|i| args.get(i + 1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(300_usize);
    let costs = costs();
    let reflex = reflex_run(trials)?;
    let hop = raw_hop(trials.max(300))?;
    println!(
        "reflex latency, scan publication -> set_velocity at the base, {} trials ({WARMUP} warm-up dropped), ms",
        reflex.latencies_ns.len()
    );
    println!(
        "{:<58} | {:>7} {:>7} {:>7} | missed",
        "path", "p50", "p99", "max"
    );
    print_row(
        "laser -> obstacle_avoider -> vector_mover -> base",
        &reflex.latencies_ns,
        reflex.missed,
    );
    print_row(
        "raw iceoryx2, one hop (event, the same scan's bytes)",
        &hop,
        0,
    );
    println!(
        "in one thread, on a scan of the corridor: a reflex (ObstacleAvoider::react, every \
         point checked) {:.1} us, a step (observe and plan) {:.2} ms, medians",
        costs.0 as f64 / 1e3,
        costs.1 as f64 / 1e6
    );
    Ok(())
}

/// The median cost of the avoider's reflex and of its step, in ns, on a scan of this
/// benchmark's corridor with nothing in the way: the reflex's longest path (every point of
/// the scan checked, nothing found), a step planning 8 m down the corridor.
fn costs() -> (u64, u64) {
    let config = lewis_motion::ObstacleAvoiderConfig::default();
    let mut avoider = lewis_motion::ObstacleAvoider::new(config.clone()).unwrap();
    avoider.goto(1000.0, 0.0).unwrap();
    let robot = BenchRobot::new(None, 0);
    let reading = robot.scan();
    let scan =
        lewis_motion::RangeScan::from_range_finder(&reading, config.non_uniform_half_width_rad)
            .unwrap();
    let (mut reflexes, mut steps) = (Vec::new(), Vec::new());
    for i in 0..300_i64 {
        let now_ns = i * 100 * MS;
        let started = Instant::now();
        avoider.observe_scan(&scan, &robot.pose, now_ns).unwrap();
        let _ = avoider.step(&robot.pose, now_ns);
        steps.push(started.elapsed().as_nanos() as u64);
        let started = Instant::now();
        let stop = avoider.react(&scan, &robot.pose);
        reflexes.push(started.elapsed().as_nanos() as u64);
        assert_eq!(stop, None, "nothing in the way");
    }
    reflexes.sort_unstable();
    steps.sort_unstable();
    (percentile(&reflexes, 0.5), percentile(&steps, 0.5))
}

fn print_row(label: &str, latencies_ns: &[u64], missed: usize) {
    let mut sorted = latencies_ns.to_vec();
    sorted.sort_unstable();
    let ms = |p: f64| percentile(&sorted, p) as f64 / 1e6;
    println!(
        "{label:<58} | {:>7.3} {:>7.3} {:>7.3} | {missed}",
        ms(0.5),
        ms(0.99),
        ms(1.0)
    );
}

/// Nearest rank.
fn percentile(sorted: &[u64], p: f64) -> u64 {
    if sorted.is_empty() {
        return 0;
    }
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// What the reflex trials measured.
struct Reflex {
    latencies_ns: Vec<u64>,
    missed: usize,
}

fn robot_text(log: &Path, trials: usize) -> String {
    format!(
        r#"[robot]
name = "reflex-bench"

[broker]
heartbeat_period_ms = 100
heartbeat_deadline_ms = 10000
startup_deadline_ms = 30000

[[services]]
name = "robot"
kind = "{ROBOT_KIND}"
provides = [
    {{ interface = "Synchrodrive", quality = 10, cost = 1 }},
    {{ interface = "Egomotion", quality = 10, cost = 1, data_rate_hz = 50.0 }},
    {{ interface = "RangeFinder", quality = 10, cost = 1, data_rate_hz = 37.5 }},
]

[services.parameters]
log = "{log}"
trials = {trials}

[[services]]
name = "vector_mover"
kind = "vector_mover"
requires = ["Egomotion", "Synchrodrive"]
provides = [{{ interface = "Mover", quality = 5, cost = 1 }}]

[services.parameters]
rate_hz = 10.0
max_translation_m_s = 0.5

[[services]]
name = "obstacle_avoider"
kind = "obstacle_avoider"
start = "always"
requires = ["RangeFinder", "Egomotion", "Mover"]
provides = [{{ interface = "Mover", quality = 10, cost = 2 }}]

[services.parameters]
rate_hz = 10.0
goal = {{ x_m = 1000.0, y_m = 0.0 }}
"#,
        log = log.display()
    )
}

/// Runs the robot until `trials` obstacles (and the warm-up) have come and gone, and reads
/// what its robot process wrote.
fn reflex_run(trials: usize) -> Res<Reflex> {
    let dir = tempfile::tempdir()?;
    let log = dir.path().join("trials.txt");
    let robot_path = dir.path().join("robot.toml");
    std::fs::write(&robot_path, robot_text(&log, trials + WARMUP))?;
    let namespace = Namespace::unique("bench-reflex");
    let mut up = Command::new(std::env::current_exe()?)
        .env(ROLE_ENV, "up")
        .env("BENCH_ROBOT", &robot_path)
        .env("BENCH_NAMESPACE", namespace.as_str())
        .spawn()?;
    // A trial every 3-5 s (the robot goes round each post before it cruises again), with
    // room for a slow start.
    let deadline =
        Instant::now() + Duration::from_secs(60) + Duration::from_secs(8 * trials as u64);
    let lines = loop {
        let lines = std::fs::read_to_string(&log).unwrap_or_default();
        if lines.lines().count() >= trials + WARMUP || Instant::now() >= deadline {
            break lines;
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    stop(&mut up)?;
    let mut latencies_ns = Vec::new();
    let mut missed = 0;
    for line in lines.lines().skip(WARMUP) {
        match line.split_once(' ') {
            Some(("hit", ns)) => latencies_ns.push(ns.parse()?),
            _ => missed += 1,
        }
    }
    if latencies_ns.is_empty() {
        return Err(format!("no trial measured: {}", lines.lines().count()).into());
    }
    Ok(Reflex {
        latencies_ns,
        missed,
    })
}

fn stop(child: &mut Child) -> Res<()> {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(child.id())?);
    nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM)?;
    child.wait()?;
    Ok(())
}

fn load(path: &Path) -> Res<Robot> {
    let known: Vec<&str> = INTERFACES.iter().map(|i| i.name).collect();
    Ok(lewis_robot::load(path, &known)?)
}

/// The broker, until SIGTERM; it starts every service as this executable.
fn up_role() -> Res<()> {
    let path = PathBuf::from(std::env::var("BENCH_ROBOT")?);
    let robot = load(&path)?;
    let options = UpOptions {
        robot_path: path,
        namespace: Namespace::new(&std::env::var("BENCH_NAMESPACE")?)?,
        lewis_exe: std::env::current_exe()?,
        duration: None,
        stop_grace: Duration::from_millis(300),
        clock: ClockSource::Wall,
    };
    let signals = StopSignals::install()?;
    run_up(&robot, &options, &signals, &mut || {})?;
    Ok(())
}

/// `BENCH service NAME --robot FILE`: one service, the motion kinds as `lewis` has them.
fn service_role(args: &[String]) -> Res<()> {
    let (Some(name), Some(path)) = (args.get(2), args.get(4)) else {
        return Err("usage: service NAME --robot FILE".into());
    };
    let robot = load(Path::new(path))?;
    let mut registry = ServiceRegistry::new();
    lewis_motion::service::register(&mut registry);
    registry.register(ROBOT_KIND, |config| {
        let params: RobotParams = config.parameters()?;
        let log = std::fs::File::create(&params.log).map_err(|e| BuildError::Parameters {
            service: config.name().to_owned(),
            reason: format!("cannot write {}: {e}", params.log.display()),
        })?;
        Ok(Box::new(BenchRobot::new(Some(log), params.trials)) as Box<dyn Service>)
    });
    run_service(
        &robot,
        name,
        &registry,
        &Namespace::from_env()?,
        ClockSource::Wall,
    )?;
    Ok(())
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotParams {
    /// Where each trial's outcome goes, one line each: `hit NS` or `miss`.
    log: PathBuf,
    /// Obstacles to put in the way.
    trials: usize,
}

/// The base and the laser of the benchmark, in one process so that a scan's publication and
/// the command it caused are stamped by one clock.
struct BenchRobot {
    log: Option<std::fs::File>,
    trials_left: usize,
    pose: Pose2D,
    /// The velocities last commanded (the base follows them at once).
    translation_m_s: f64,
    rotation_rad_s: f64,
    last_tick_ns: Option<i64>,
    next_egomotion_ns: i64,
    next_scan_ns: i64,
    next_obstacle_ns: i64,
    /// Posts in the odometry frame: centre, radius, until when they stand.
    posts: Vec<(f64, f64, f64, i64)>,
    /// The trial under way: the publication of the scan that first showed the post, and
    /// the speed the robot cruised at then.
    trial: Option<(i64, f64)>,
}

const MS: i64 = 1_000_000;
const SCAN_PERIOD_NS: i64 = 26_666_667;
const EGOMOTION_PERIOD_NS: i64 = 20 * MS;
const OBSTACLE_PERIOD_NS: i64 = 500 * MS;
const POST_STANDS_NS: i64 = 200 * MS;
const TRIAL_LIMIT_NS: i64 = 300 * MS;
/// The corridor the robot drives along: walls this far either side of the x axis, in m.
const CORRIDOR_HALF_WIDTH_M: f64 = 1.5;
/// A command this much slower than the cruise is the reflex's, in m/s.
const SLOWER_M_S: f64 = 0.02;
/// The robot heads down the corridor when the sine of its heading is within this (about
/// 6 degrees either way).
const DOWN_THE_CORRIDOR_SIN: f64 = 0.1;

impl BenchRobot {
    fn new(log: Option<std::fs::File>, trials: usize) -> Self {
        Self {
            log,
            trials_left: trials,
            pose: Pose2D::default(),
            translation_m_s: 0.0,
            rotation_rad_s: 0.0,
            last_tick_ns: None,
            next_egomotion_ns: 0,
            next_scan_ns: 0,
            next_obstacle_ns: 2_000 * MS,
            posts: Vec::new(),
            trial: None,
        }
    }

    fn record(&mut self, line: &str) {
        if let Some(log) = &mut self.log {
            let _ = writeln!(log, "{line}");
        }
    }

    /// The range along `bearing_rad` (odometry frame) from the robot to the nearest wall
    /// or post.
    fn range(&self, bearing_rad: f64) -> f64 {
        let (dx, dy) = (bearing_rad.cos(), bearing_rad.sin());
        let walls = [-CORRIDOR_HALF_WIDTH_M, CORRIDOR_HALF_WIDTH_M]
            .into_iter()
            .filter_map(|y| {
                let t = (y - self.pose.y) / dy;
                (t.is_finite() && t > 0.0).then_some(t)
            })
            .fold(MAX_RANGE_M, f64::min);
        self.posts
            .iter()
            .filter_map(|&(cx, cy, r, _)| {
                let (ox, oy) = (cx - self.pose.x, cy - self.pose.y);
                let along = ox * dx + oy * dy;
                let lateral2 = (ox * ox + oy * oy) - along * along;
                (along > 0.0 && lateral2 < r * r).then(|| along - (r * r - lateral2).sqrt())
            })
            .fold(walls, f64::min)
    }

    fn scan(&self) -> RangeFinder {
        let separation = PI / (BEAMS - 1) as f64;
        RangeFinder {
            range_count: BEAMS as i32,
            ranges: (0..BEAMS)
                .map(|i| self.range(self.pose.theta - FRAC_PI_2 + i as f64 * separation))
                .collect(),
            max_range: MAX_RANGE_M,
            uniform: true,
            sensor_positions: vec![Pose3D::default(); BEAMS],
            theta_offset: -FRAC_PI_2,
            theta_separation: separation,
            ..RangeFinder::default()
        }
    }

    /// A post steps in 0.75 m ahead, once the robot cruises straight down the corridor.
    ///
    /// Down the corridor, not merely straight: while the robot swerves round the last post
    /// it may for a moment drive straight towards a wall, its waypoint well off its heading;
    /// a post in front of it then stands off the way it is taking, the reflex rightly lets
    /// it be, and the next plan slows the robot some 90 ms later, which is no reflex.
    fn maybe_put_post(&mut self, now_ns: i64) -> bool {
        let cruising = self.translation_m_s >= 0.4
            && self.rotation_rad_s.abs() <= 0.2
            && self.pose.theta.sin().abs() <= DOWN_THE_CORRIDOR_SIN;
        if self.trials_left == 0 || now_ns < self.next_obstacle_ns || !cruising {
            return false;
        }
        let ahead = 0.75;
        self.posts.push((
            self.pose.x + ahead * self.pose.theta.cos(),
            self.pose.y + ahead * self.pose.theta.sin(),
            0.1,
            now_ns + POST_STANDS_NS,
        ));
        self.next_obstacle_ns = now_ns + OBSTACLE_PERIOD_NS;
        self.trials_left -= 1;
        true
    }
}

impl Service for BenchRobot {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(2 * MS)
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let dt_s = self.last_tick_ns.map_or(0.0, |t| (now - t) as f64 / 1e9);
        self.last_tick_ns = Some(now);
        self.pose.x += self.translation_m_s * self.pose.theta.cos() * dt_s;
        self.pose.y += self.translation_m_s * self.pose.theta.sin() * dt_s;
        self.pose.theta += self.rotation_rad_s * dt_s;
        self.posts.retain(|p| p.3 > now);
        if let Some((published_ns, _)) = self.trial
            && now - published_ns > TRIAL_LIMIT_NS
        {
            self.trial = None;
            self.record("miss");
        }
        if now >= self.next_egomotion_ns {
            self.next_egomotion_ns = now + EGOMOTION_PERIOD_NS;
            let _ = ctx.publish(&mut Egomotion {
                pose: self.pose.clone(),
                translation_velocity: self.translation_m_s,
                rotation_velocity: self.rotation_rad_s,
                ..Egomotion::default()
            });
        }
        if now >= self.next_scan_ns {
            self.next_scan_ns = now + SCAN_PERIOD_NS;
            let appeared = self.trial.is_none() && self.maybe_put_post(now);
            let _ = ctx.publish(&mut self.scan());
            if appeared {
                // The scan's header stamp: this event's time.
                self.trial = Some((now, self.translation_m_s));
            }
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        let now = ctx.now();
        match command.decode::<Synchrodrive>()? {
            SynchrodriveCommand::SetVelocity(c) => {
                if let Some((published_ns, cruise_m_s)) = self.trial
                    && c.translation_velocity < cruise_m_s - SLOWER_M_S
                {
                    self.trial = None;
                    self.record(&format!("hit {}", now - published_ns));
                }
                self.translation_m_s = c.translation_velocity;
                self.rotation_rad_s = c.rotation_velocity;
                Ok(ctx.reply(SynchrodriveSetVelocityReply::default()))
            }
            SynchrodriveCommand::Stop(_) => {
                self.translation_m_s = 0.0;
                self.rotation_rad_s = 0.0;
                Ok(ctx.reply(SynchrodriveStopReply::default()))
            }
            SynchrodriveCommand::SetBrake(_) => Err(CommandError::new("no brake here")),
        }
    }
}

/// The raw iceoryx2 hop of `runtime/benches/ipc_latency` (its baseline, shared through
/// `lewis_runtime::ipc::baseline`): this process publishes the bytes of a scan of the
/// laser's 181 beams, copied into the loan, at the laser's pace, to a child process woken by
/// an event; `count` latencies in ns, the first [`WARMUP`] dropped.
fn raw_hop(count: usize) -> Res<Vec<u64>> {
    let namespace = Namespace::unique("bench-reflex-raw");
    let message = cdr::to_vec(&BenchRobot::new(None, 0).scan());
    let publisher = RawPublisher::open(&namespace, Wake::Event, Fill::CopyIn, message.clone())?;
    let total = count + WARMUP;
    let mut child = Command::new(std::env::current_exe()?)
        .env(ROLE_ENV, "raw")
        .env("BENCH_NAMESPACE", namespace.as_str())
        .env("BENCH_LEN", message.len().to_string())
        .env("BENCH_COUNT", total.to_string())
        .stdout(Stdio::piped())
        .spawn()?;
    let mut lines = BufReader::new(child.stdout.take().ok_or("no child stdout")?).lines();
    if lines.next().transpose()?.as_deref() != Some("ready") {
        return Err("the raw receiver did not start".into());
    }
    let period = Duration::from_nanos(SCAN_PERIOD_NS as u64);
    let mut next = Instant::now();
    for _ in 0..total {
        publisher.send(mono_ns())?;
        next += period;
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    let line = lines
        .next()
        .transpose()?
        .ok_or("the raw receiver gave no result")?;
    child.wait()?;
    let latencies: Vec<u64> = line
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    Ok(latencies.into_iter().skip(WARMUP).collect())
}

/// The receiving end of [`raw_hop`]: prints `ready`, then the latency of every sample on
/// one line.
fn raw_role() -> Res<()> {
    let namespace = Namespace::new(&std::env::var("BENCH_NAMESPACE")?)?;
    let len: usize = std::env::var("BENCH_LEN")?.parse()?;
    let count: usize = std::env::var("BENCH_COUNT")?.parse()?;
    let receiver = RawReceiver::open(&namespace, Wake::Event, len)?;
    println!("ready");
    std::io::stdout().flush()?;
    let mut latencies = Vec::with_capacity(count);
    while latencies.len() < count {
        let Some(sent) = receiver.next(Duration::from_secs(5))? else {
            break;
        };
        latencies.push(mono_ns().saturating_sub(sent).to_string());
    }
    println!("{}", latencies.join(" "));
    Ok(())
}

/// `CLOCK_MONOTONIC`, one clock for every process of the machine, in ns.
fn mono_ns() -> u64 {
    let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_MONOTONIC)
        .expect("CLOCK_MONOTONIC is always there");
    (t.tv_sec() as u64) * 1_000_000_000 + t.tv_nsec() as u64
}
