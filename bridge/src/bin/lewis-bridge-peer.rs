//! One host's side of the bridge benchmark (`bridge/benches/bridge.rs`), run inside a host of
//! the test kit's `lewis_testkit::hosts`: `lewis-bridge-peer ROLE ADDRESS [--frames N]`.
//!
//! Each peer runs both transports at once, each on its own Zenoh session:
//!
//! - `raw`: plain Zenoh publishers and subscribers (`bench/ping`, `bench/pong`,
//!   `bench/camera`), the pong put from the subscriber's callback; `a` listens on
//!   `tcp/ADDRESS:7447`.
//! - `bridge`: the same through Lewis, IPC to IPC: each host has a [`Forwarder`] on a Zenoh
//!   session of the same settings, and the program publishes and subscribes in the host's
//!   shared memory (`/bench/ping` exported by `a`, `/bench/pong` by `b`,
//!   `/camera/ImageSource` by `a`), with the channel settings the bridge takes from the
//!   names ([`names::channel_config`]), as iceoryx2 requires; `a` listens on
//!   `tcp/ADDRESS:7448`.
//!
//! `ROLE` `a` measures round trips (64 B, 64 KiB, 1 MiB), a raw one and a bridge one in
//! turn, so that both see the same machine at the same moments (on a shared machine the
//! latency drifts by more than the difference measured); then it sends a camera, raw and
//! then through the bridge: `FRAMES` frames of 921,600 B at 30 Hz each. `ROLE` `b`
//! connects to `a`, echoes every ping back as a pong and counts the camera's frames, the
//! raw ones on a thread of their own.
//!
//! Every payload carries its sequence number in its first 8 bytes (and a camera frame the
//! wall-clock time it was sent, in ns, in the next 8: both hosts share the kernel's clock).
//! It says what it measured on stdout, one line each (`T`: `raw` or `bridge`):
//!
//! - `ready` once both transports are set up (both roles);
//! - `latency T SIZE ROUNDS TIMEOUTS P50_NS P99_NS MIN_NS` (`a`: one way, half the round
//!   trip);
//! - `camera-sent T FRAMES ELAPSED_NS MAX_LATE_NS` for each, then `done` (`a`);
//! - `camera-received T RECEIVED MISSING DISORDERED ELAPSED_NS P50_NS P99_NS MAX_NS` (`b`:
//!   from the first to the last frame; latencies from send to receipt).
//!
//! Either role runs until its stdin closes (the benchmark's end), so that `a`'s sessions
//! are still up while `b` receives the last frames.

use std::io::{Read as _, Write as _};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use lewis_bridge::routes::{Route, Routes};
use lewis_bridge::{ForwardOptions, Forwarder, Heard, Schemas};
use lewis_runtime::ipc::{Ipc, Namespace, Publisher, Subscriber, WaitSet, WakeMode, Woken};
use lewis_runtime::names;
use zenoh::bytes::ZBytes;
use zenoh::{Config, Session, Wait as _};

type Res<T> = Result<T, Box<dyn std::error::Error + Send + Sync>>;

/// The port `a` listens on for raw Zenoh.
const RAW_PORT: u16 = 7447;
/// The port `a`'s bridge listens on.
const BRIDGE_PORT: u16 = 7448;
/// The payload sizes of the round trips, with how many are measured after the warm-up.
const SIZES: [(usize, usize); 3] = [(64, 1000), (64 << 10, 1000), (1 << 20, 200)];
/// Round trips before the measured ones, at each size.
const WARMUP: usize = 50;
/// A 640x480 rgb8 frame.
const FRAME_BYTES: usize = 640 * 480 * 3;
/// The camera's rate.
const FRAME_PERIOD: Duration = Duration::from_nanos(1_000_000_000 / 30);
/// The longest a round trip may take before it is counted as timed out (and the next sent).
const ROUND_TIMEOUT: Duration = Duration::from_secs(1);
/// The longest the first round trip (the link coming up) may take.
const LINK_TIMEOUT: Duration = Duration::from_secs(20);
/// `b` reports a camera once this long passed without a frame after its first.
const CAMERA_QUIET: Duration = Duration::from_secs(3);

/// The IPC channels of the bridge transport.
const PING: &str = "/bench/ping";
const PONG: &str = "/bench/pong";
const CAMERA: &str = "/camera/ImageSource";
/// The robot's name in the bridge's keys.
const ROBOT: &str = "bench";

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: lewis-bridge-peer a|b ADDRESS [--frames N]";
    let [role, address, rest @ ..] = args.as_slice() else {
        return Err(usage.into());
    };
    let frames = match rest {
        [] => 300,
        [flag, n] if flag == "--frames" => n.parse()?,
        _ => return Err(usage.into()),
    };
    let raw = format!("tcp/{address}:{RAW_PORT}");
    let bridge = format!("tcp/{address}:{BRIDGE_PORT}");
    // Ends with stdin: the benchmark closes it when it has read both sides.
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    std::thread::spawn(move || {
        let _ = std::io::stdin().read_to_end(&mut Vec::new());
        flag.store(true, Ordering::Release);
    });
    match role.as_str() {
        "a" => run_a(
            &mut RawA::open(&raw)?,
            &mut BridgeA::open(&bridge)?,
            frames,
            &stop,
        ),
        "b" => {
            let mut raw = RawB::open(&raw)?;
            let mut bridge = BridgeB::open(&bridge)?;
            say("ready")?;
            // The raw frames on a thread of their own: a wait for one transport must not
            // delay the other's frames. iceoryx2's ports stay on this thread.
            std::thread::scope(|scope| {
                let raw_side = scope.spawn(|| count_camera("raw", &mut raw, frames, &stop));
                let bridged = count_camera("bridge", &mut bridge, frames, &stop);
                raw_side
                    .join()
                    .map_err(|_| "the raw camera's thread panicked")??;
                bridged
            })
        }
        _ => Err(usage.into()),
    }
}

/// Says one line on stdout, at once.
fn say(line: &str) -> Res<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{line}")?;
    out.flush()?;
    Ok(())
}

/// A Zenoh session as the bridge's own (`lewis_bridge::session`): peer mode, listening
/// (`a`) or connecting (`b`) at one endpoint only, retrying, no scouting.
fn session(listen: Option<&str>, connect: Option<&str>) -> Res<Session> {
    let list = |e: Option<&str>| e.map_or_else(|| "[]".to_owned(), |e| format!("[\"{e}\"]"));
    let mut config = Config::default();
    for (key, value) in [
        ("mode", "\"peer\"".to_owned()),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
        ("connect/exit_on_failure", "false".to_owned()),
        (
            "connect/retry",
            "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}".to_owned(),
        ),
        ("scouting/multicast/enabled", "false".to_owned()),
    ] {
        config
            .insert_json5(key, &value)
            .map_err(|e| format!("zenoh config {key}: {e}"))?;
    }
    zenoh::open(config).wait()
}

/// A payload of `size` bytes (at least 16) with `seq` in its first 8.
fn payload(size: usize, seq: u64) -> Vec<u8> {
    let mut buf: Vec<u8> = (0..size).map(|i| (i % 251) as u8).collect();
    stamp(&mut buf, seq);
    buf
}

fn stamp(buf: &mut [u8], seq: u64) {
    buf[..8].copy_from_slice(&seq.to_le_bytes());
}

/// The first 8 bytes as a number.
fn seq_of(bytes: &[u8]) -> u64 {
    bytes
        .get(..8)
        .and_then(|b| b.try_into().ok())
        .map_or(u64::MAX, u64::from_le_bytes)
}

/// The 8 bytes after the sequence number as a number (a frame's send time).
fn sent_ns_of(bytes: &[u8]) -> u64 {
    bytes
        .get(8..16)
        .and_then(|b| b.try_into().ok())
        .map_or(0, u64::from_le_bytes)
}

/// The sequence number and send time of a Zenoh payload, without gathering its slices.
fn head_of(payload: &ZBytes) -> [u64; 2] {
    let mut head = [0u8; 16];
    let _ = payload.reader().read_exact(&mut head);
    [seq_of(&head), sent_ns_of(&head)]
}

fn wall_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_nanos()).unwrap_or(u64::MAX))
}

/// `a`'s side of a transport.
trait SideA {
    /// Sends a ping.
    fn ping(&mut self, bytes: &[u8]) -> Res<()>;
    /// The next pong's sequence number and length, if one comes before `deadline`.
    fn pong(&mut self, deadline: Instant) -> Res<Option<(u64, usize)>>;
    /// Sends a camera frame.
    fn frame(&mut self, bytes: &[u8]) -> Res<()>;
}

/// What `b` takes from its transport.
enum Got {
    /// A frame: its sequence number and send time.
    Frame(u64, u64),
    /// Nothing before the deadline (pings are echoed inside).
    Nothing,
}

/// `b`'s side of a transport: echoes pings, hands frames over.
trait SideB {
    /// Echoes what pings came, and returns the next frame if one comes before `deadline`.
    fn next(&mut self, deadline: Instant) -> Res<Got>;
}

fn run_a(raw: &mut RawA, bridge: &mut BridgeA, frames: u64, stop: &AtomicBool) -> Res<()> {
    say("ready")?;
    let mut seq = 0_u64;
    for side in [raw as &mut dyn SideA, bridge] {
        link_up(side, &mut seq)?;
    }
    for (size, rounds) in SIZES {
        let mut buf = payload(size, 0);
        // Per transport: the one-way times and how many round trips timed out.
        let mut measured: [(Vec<Duration>, u64); 2] = Default::default();
        for i in 0..WARMUP + rounds {
            let sides = [&mut *raw as &mut dyn SideA, &mut *bridge];
            for (side, (one_way, timeouts)) in sides.into_iter().zip(&mut measured) {
                seq += 1;
                stamp(&mut buf, seq);
                match round(side, &buf, seq, ROUND_TIMEOUT)? {
                    Some(rtt) if i >= WARMUP => one_way.push(rtt / 2),
                    Some(_) => {}
                    None => *timeouts += 1,
                }
            }
        }
        for (name, (mut one_way, timeouts)) in ["raw", "bridge"].into_iter().zip(measured) {
            one_way.sort_unstable();
            let pct = |p: usize| {
                one_way
                    .get((one_way.len() * p / 100).min(one_way.len().saturating_sub(1)))
                    .map_or(0, Duration::as_nanos)
            };
            say(&format!(
                "latency {name} {size} {} {timeouts} {} {} {}",
                one_way.len(),
                pct(50),
                pct(99),
                pct(0)
            ))?;
        }
    }
    for (name, side) in [("raw", raw as &mut dyn SideA), ("bridge", bridge)] {
        send_camera(name, side, frames)?;
    }
    say("done")?;
    while !stop.load(Ordering::Acquire) {
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(())
}

/// Round trips of 64 B until one goes through: then the link and every subscription of
/// `side` are up.
fn link_up(side: &mut dyn SideA, seq: &mut u64) -> Res<()> {
    let start = Instant::now();
    loop {
        *seq += 1;
        if round(side, &payload(64, *seq), *seq, Duration::from_millis(200))?.is_some() {
            return Ok(());
        }
        if start.elapsed() > LINK_TIMEOUT {
            return Err(format!("no pong within {LINK_TIMEOUT:?}").into());
        }
    }
}

/// `frames` camera frames at the camera's rate over `side`.
fn send_camera(name: &str, side: &mut dyn SideA, frames: u64) -> Res<()> {
    let mut frame = payload(FRAME_BYTES, 0);
    let start = Instant::now();
    let mut max_late = Duration::ZERO;
    for n in 0..frames {
        let due = start + FRAME_PERIOD * u32::try_from(n)?;
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        max_late = max_late.max(Instant::now().saturating_duration_since(due));
        stamp(&mut frame, n);
        frame[8..16].copy_from_slice(&wall_ns().to_le_bytes());
        side.frame(&frame)?;
    }
    say(&format!(
        "camera-sent {name} {frames} {} {}",
        start.elapsed().as_nanos(),
        max_late.as_nanos()
    ))
}

/// One round trip of `bytes` (numbered `seq`): its time, or `None` when its pong did not
/// come within `timeout`. Pongs of earlier pings (late ones) are skipped.
fn round(side: &mut dyn SideA, bytes: &[u8], seq: u64, timeout: Duration) -> Res<Option<Duration>> {
    let sent = Instant::now();
    side.ping(bytes)?;
    let deadline = sent + timeout;
    while let Some((got, len)) = side.pong(deadline)? {
        if got == seq {
            if len != bytes.len() {
                return Err(format!("pong {seq} has {len} bytes, not {}", bytes.len()).into());
            }
            return Ok(Some(sent.elapsed()));
        }
    }
    Ok(None)
}

/// Echoes `side`'s pings and counts its camera frames, then says what came: once the last
/// frame came, or nothing came for a while after the first, or the benchmark ends.
fn count_camera(name: &str, side: &mut dyn SideB, frames: u64, stop: &AtomicBool) -> Res<()> {
    let mut received = 0_u64;
    let mut disordered = 0_u64;
    let mut last: Option<u64> = None;
    let mut seen = vec![false; usize::try_from(frames)?];
    let mut latencies = Vec::new();
    let mut first_at = None;
    let mut last_at = Instant::now();
    let mut reported = false;
    loop {
        let deadline = Instant::now() + Duration::from_millis(50);
        if let Got::Frame(seq, sent_ns) = side.next(deadline)? {
            let now = Instant::now();
            latencies.push(wall_ns().saturating_sub(sent_ns));
            first_at.get_or_insert(now);
            last_at = now;
            received += 1;
            if last.is_some_and(|l| seq <= l) {
                disordered += 1;
            }
            last = Some(seq);
            if let Some(slot) = usize::try_from(seq).ok().and_then(|s| seen.get_mut(s)) {
                *slot = true;
            }
        }
        let complete = last == Some(frames.saturating_sub(1));
        let quiet = first_at.is_some() && last_at.elapsed() > CAMERA_QUIET;
        let ending = stop.load(Ordering::Acquire);
        if !reported && (complete || quiet || ending) {
            reported = true;
            latencies.sort_unstable();
            let pct = |p: usize| {
                latencies
                    .get((latencies.len() * p / 100).min(latencies.len().saturating_sub(1)))
                    .copied()
                    .unwrap_or(0)
            };
            let missing = seen.iter().filter(|s| !**s).count();
            let elapsed = first_at.map_or(Duration::ZERO, |f| last_at.duration_since(f));
            say(&format!(
                "camera-received {name} {received} {missing} {disordered} {} {} {} {}",
                elapsed.as_nanos(),
                pct(50),
                pct(99),
                latencies.last().copied().unwrap_or(0)
            ))?;
        }
        if ending {
            return Ok(());
        }
    }
}

/// `a` on plain Zenoh.
struct RawA {
    ping: zenoh::pubsub::Publisher<'static>,
    camera: zenoh::pubsub::Publisher<'static>,
    pongs: Receiver<(u64, usize)>,
    _pong: zenoh::pubsub::Subscriber<()>,
    _session: Session,
}

impl RawA {
    fn open(endpoint: &str) -> Res<Self> {
        let session = session(Some(endpoint), None)?;
        let (tx, pongs) = channel();
        let pong = session
            .declare_subscriber("bench/pong")
            .callback(move |sample| {
                let payload = sample.payload();
                let _ = tx.send((head_of(payload)[0], payload.len()));
            })
            .wait()?;
        Ok(Self {
            ping: session.declare_publisher("bench/ping").wait()?,
            camera: session.declare_publisher("bench/camera").wait()?,
            pongs,
            _pong: pong,
            _session: session,
        })
    }
}

impl SideA for RawA {
    fn ping(&mut self, bytes: &[u8]) -> Res<()> {
        // One copy, as the IPC publication's into shared memory.
        self.ping.put(bytes.to_vec()).wait()
    }

    fn pong(&mut self, deadline: Instant) -> Res<Option<(u64, usize)>> {
        let left = deadline.saturating_duration_since(Instant::now());
        match self.pongs.recv_timeout(left) {
            Ok(pong) => Ok(Some(pong)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err("the pong subscriber is gone".into()),
        }
    }

    fn frame(&mut self, bytes: &[u8]) -> Res<()> {
        self.camera.put(bytes.to_vec()).wait()
    }
}

/// `b` on plain Zenoh: the pong is put from the ping subscriber's callback.
struct RawB {
    frames: Receiver<([u64; 2], usize)>,
    _ping: zenoh::pubsub::Subscriber<()>,
    _camera: zenoh::pubsub::Subscriber<()>,
    _session: Session,
}

impl RawB {
    fn open(endpoint: &str) -> Res<Self> {
        let session = session(None, Some(endpoint))?;
        let pong = session.declare_publisher("bench/pong").wait()?;
        let ping = session
            .declare_subscriber("bench/ping")
            .callback(move |sample| {
                let _ = pong.put(sample.payload().clone()).wait();
            })
            .wait()?;
        let (tx, frames): (Sender<([u64; 2], usize)>, _) = channel();
        let camera = session
            .declare_subscriber("bench/camera")
            .callback(move |sample| {
                let payload = sample.payload();
                let _ = tx.send((head_of(payload), payload.len()));
            })
            .wait()?;
        Ok(Self {
            frames,
            _ping: ping,
            _camera: camera,
            _session: session,
        })
    }
}

impl SideB for RawB {
    fn next(&mut self, deadline: Instant) -> Res<Got> {
        let left = deadline.saturating_duration_since(Instant::now());
        match self.frames.recv_timeout(left) {
            Ok((_, len)) if len != FRAME_BYTES => Err(format!("a frame of {len} bytes").into()),
            Ok(([seq, sent], _)) => Ok(Got::Frame(seq, sent)),
            Err(RecvTimeoutError::Timeout) => Ok(Got::Nothing),
            Err(RecvTimeoutError::Disconnected) => Err("the camera subscriber is gone".into()),
        }
    }
}

/// A host's bridge: its session and forwarder, with `routes`.
fn bridge(host: &str, session: &Session, routes: Routes) -> Res<Forwarder> {
    let options = ForwardOptions {
        robot: ROBOT.to_owned(),
        host: host.to_owned(),
        routes,
        namespace: namespace()?,
        // As a robot's bridge beats (every 10 ms, the shipped heartbeat period).
        beat_period: Duration::from_millis(10),
        schemas: Schemas::default(),
    };
    Ok(Forwarder::start(session, options, Heard::default())?)
}

/// The IPC namespace of the benchmark on either host (each host has its own memory).
fn namespace() -> Res<Namespace> {
    Ok(Namespace::new("bridge-bench")?)
}

fn route(channel: &str, host: &str) -> Route {
    Route {
        channel: channel.to_owned(),
        host: host.to_owned(),
    }
}

/// `a` through Lewis: IPC publishers and subscriber, its host's bridge between them and
/// Zenoh.
struct BridgeA {
    ping: Publisher,
    camera: Publisher,
    pong: Subscriber,
    waits: WaitSet,
    // Dropped in this order: the ports, the IPC node, the bridge, the session.
    _ipc: Ipc,
    _forwarder: Forwarder,
    _session: Session,
}

impl BridgeA {
    fn open(endpoint: &str) -> Res<Self> {
        let session = session(Some(endpoint), None)?;
        let ipc = Ipc::open(&namespace()?, "bench-a")?;
        let ping = ipc.publisher(PING, &names::channel_config(PING))?;
        let camera = ipc.publisher(CAMERA, &names::channel_config(CAMERA))?;
        let pong = ipc.subscriber(PONG, &names::channel_config(PONG))?;
        let routes = Routes {
            exports: vec![PING.to_owned(), CAMERA.to_owned()],
            imports: vec![route(PONG, "b")],
            ..Routes::default()
        };
        let forwarder = bridge("a", &session, routes)?;
        Ok(Self {
            ping,
            camera,
            pong,
            waits: WaitSet::new(WakeMode::Event),
            _ipc: ipc,
            _forwarder: forwarder,
            _session: session,
        })
    }
}

impl SideA for BridgeA {
    fn ping(&mut self, bytes: &[u8]) -> Res<()> {
        self.ping.publish(bytes)?;
        Ok(())
    }

    fn pong(&mut self, deadline: Instant) -> Res<Option<(u64, usize)>> {
        loop {
            if let Some(sample) = self.pong.receive()? {
                return Ok(Some((seq_of(sample.bytes()), sample.bytes().len())));
            }
            if let Woken::DeadlineReached = self.waits.wait(&[&self.pong], Some(deadline))? {
                return Ok(None);
            }
        }
    }

    fn frame(&mut self, bytes: &[u8]) -> Res<()> {
        self.camera.publish(bytes)?;
        Ok(())
    }
}

/// `b` through Lewis: the pings it receives from IPC it publishes again as pongs.
struct BridgeB {
    ping: Subscriber,
    pong: Publisher,
    camera: Subscriber,
    waits: WaitSet,
    _ipc: Ipc,
    _forwarder: Forwarder,
    _session: Session,
}

impl BridgeB {
    fn open(endpoint: &str) -> Res<Self> {
        let session = session(None, Some(endpoint))?;
        let ipc = Ipc::open(&namespace()?, "bench-b")?;
        let ping = ipc.subscriber(PING, &names::channel_config(PING))?;
        let pong = ipc.publisher(PONG, &names::channel_config(PONG))?;
        let camera = ipc.subscriber(CAMERA, &names::channel_config(CAMERA))?;
        let routes = Routes {
            exports: vec![PONG.to_owned()],
            imports: vec![route(PING, "a"), route(CAMERA, "a")],
            ..Routes::default()
        };
        let forwarder = bridge("b", &session, routes)?;
        Ok(Self {
            ping,
            pong,
            camera,
            waits: WaitSet::new(WakeMode::Event),
            _ipc: ipc,
            _forwarder: forwarder,
            _session: session,
        })
    }
}

impl SideB for BridgeB {
    fn next(&mut self, deadline: Instant) -> Res<Got> {
        loop {
            while let Some(sample) = self.ping.receive()? {
                self.pong.publish(sample.bytes())?;
            }
            if let Some(sample) = self.camera.receive()? {
                let bytes = sample.bytes();
                if bytes.len() != FRAME_BYTES {
                    return Err(format!("a frame of {} bytes", bytes.len()).into());
                }
                return Ok(Got::Frame(seq_of(bytes), sent_ns_of(bytes)));
            }
            if let Woken::DeadlineReached = self
                .waits
                .wait(&[&self.ping, &self.camera], Some(deadline))?
            {
                return Ok(Got::Nothing);
            }
        }
    }
}
