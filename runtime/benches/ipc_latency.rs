//! One-way publication latency: our IPC layer against raw iceoryx2 publish-subscribe, same
//! payload, same wake-up mode, two processes.
//!
//! The bench process publishes; it starts itself again as the receiver (selected by
//! `LEWIS_BENCH_ROLE`). Every message carries the publisher's `CLOCK_MONOTONIC` time,
//! read just before the loan; the receiver reads the clock once the sample is in hand, so
//! a latency includes loan, encoding (a fill of the whole payload), send, wake-up and
//! receive. Messages are spaced by a gap so that the receiver is idle (blocked, or
//! spinning) when each arrives. The receiver also measures its own CPU time
//! (`CLOCK_PROCESS_CPUTIME_ID`) over the run.
//!
//! Run: `cargo bench -p lewis-runtime --bench ipc_latency`
//! (`LEWIS_BENCH_COUNT` messages per row, default 2000).

#![allow(clippy::print_stdout, reason = "a benchmark reports on stdout")]

use std::error::Error;
use std::io::{BufRead, BufReader, Write};
use std::mem::MaybeUninit;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use iceoryx2::config::Config;
use iceoryx2::prelude::{
    AllocationStrategy, FileName, NodeBuilder, SemanticString, ServiceName, SignalHandlingMode, ipc,
};
use lewis_runtime::ipc::{ChannelConfig, Ipc, Namespace, WaitSet, WakeMode, Woken};
use nix::time::{ClockId, clock_gettime};

type Res<T> = Result<T, Box<dyn Error>>;

const ROLE_ENV: &str = "LEWIS_BENCH_ROLE";
const SIZES: [usize; 3] = [64, 64 << 10, 1 << 20];
const WARMUP: usize = 300;
const GAP: Duration = Duration::from_micros(500);
const RECEIVER_IDLE_LIMIT: Duration = Duration::from_secs(5);
// The same channel settings for both layers, so that both preallocate the same number of
// chunks (same memory, same page-fault pattern).
const BUFFER: usize = 8;
const MAX_HELD: usize = 2;
const MAX_SUBSCRIBERS: usize = 8;
const MAX_PUBLISHERS: usize = 2;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layer {
    Ours,
    Raw,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Event,
    BusyPoll,
    Adaptive { spin_us: u64 },
}

impl Mode {
    fn encode(self) -> String {
        match self {
            Mode::Event => "event".into(),
            Mode::BusyPoll => "busy".into(),
            Mode::Adaptive { spin_us } => format!("adaptive:{spin_us}"),
        }
    }

    fn decode(s: &str) -> Res<Self> {
        Ok(match s {
            "event" => Mode::Event,
            "busy" => Mode::BusyPoll,
            other => Mode::Adaptive {
                spin_us: other
                    .strip_prefix("adaptive:")
                    .ok_or_else(|| format!("bad mode {other}"))?
                    .parse()?,
            },
        })
    }

    fn label(self) -> String {
        match self {
            Mode::Event => "event".into(),
            Mode::BusyPoll => "busy-poll".into(),
            Mode::Adaptive { spin_us } => format!("adaptive {spin_us}us"),
        }
    }

    fn wake_mode(self) -> WakeMode {
        match self {
            Mode::Event => WakeMode::Event,
            Mode::BusyPoll => WakeMode::BusyPoll,
            Mode::Adaptive { spin_us } => WakeMode::Adaptive {
                spin: Duration::from_micros(spin_us),
            },
        }
    }
}

fn now_ns(clock: ClockId) -> u64 {
    clock_gettime(clock).map_or(0, |t| {
        u64::try_from(t.tv_sec()).unwrap_or(0) * 1_000_000_000
            + u64::try_from(t.tv_nsec()).unwrap_or(0)
    })
}

fn mono_ns() -> u64 {
    now_ns(ClockId::CLOCK_MONOTONIC)
}

/// What every encoder does: fill the whole payload, then stamp the send time.
fn encode(buf: &mut [u8], t0: u64) {
    buf.fill(0x5a);
    buf[..8].copy_from_slice(&t0.to_le_bytes());
}

fn stamp(bytes: &[u8]) -> u64 {
    let mut t = [0u8; 8];
    t.copy_from_slice(&bytes[..8]);
    u64::from_le_bytes(t)
}

fn raw_config(namespace: &Namespace) -> Res<Config> {
    let mut config = Config::default();
    config.global.prefix = FileName::new(format!("bench-raw.{namespace}.").as_bytes())?;
    Ok(config)
}

fn raw_service_name(size: usize) -> Res<ServiceName> {
    Ok(ServiceName::new(&format!("raw/{size}"))?)
}

fn ours_channel(size: usize) -> (String, ChannelConfig) {
    let config = ChannelConfig {
        buffer: BUFFER,
        history: 0,
        max_held: MAX_HELD,
        max_subscribers: MAX_SUBSCRIBERS,
        max_publishers: MAX_PUBLISHERS,
        ..ChannelConfig::sensor(size)
    };
    (format!("bench/{size}"), config)
}

// ---------------------------------------------------------------- receiver process

struct Stats {
    latencies_ns: Vec<u64>,
    cpu_ns: u64,
    wall_ns: u64,
}

fn receiver() -> Res<()> {
    let var = |k: &str| std::env::var(k).map_err(|_| format!("{k} missing"));
    let layer = if var("BENCH_LAYER")? == "ours" {
        Layer::Ours
    } else {
        Layer::Raw
    };
    let mode = Mode::decode(&var("BENCH_MODE")?)?;
    let size: usize = var("BENCH_SIZE")?.parse()?;
    let count: usize = var("BENCH_COUNT")?.parse()?;
    let namespace = Namespace::new(&var("BENCH_NAMESPACE")?)?;
    let stats = match layer {
        Layer::Ours => receive_ours(&namespace, mode, size, count)?,
        Layer::Raw => receive_raw(&namespace, mode, size, count)?,
    };
    let mut l = stats.latencies_ns;
    let received = l.len();
    let l = if received > WARMUP {
        &mut l[WARMUP..]
    } else {
        &mut l[..]
    };
    l.sort_unstable();
    let pct = |p: usize| l.get(l.len() * p / 100).copied().unwrap_or(0);
    println!(
        "result {} {} {} {} {}",
        pct(50),
        pct(99),
        stats.cpu_ns,
        stats.wall_ns,
        received
    );
    Ok(())
}

fn ready() -> Res<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "ready")?;
    out.flush()?;
    Ok(())
}

fn receive_ours(namespace: &Namespace, mode: Mode, size: usize, count: usize) -> Res<Stats> {
    let ipc = Ipc::open(namespace, "bench-receiver")?;
    let (name, config) = ours_channel(size);
    let mut sub = ipc.subscriber(&name, &config)?;
    let waits = WaitSet::new(mode.wake_mode());
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let (cpu0, wall0) = (now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID), mono_ns());
    while latencies_ns.len() < count {
        match waits.wait(&[&sub], Some(Instant::now() + RECEIVER_IDLE_LIMIT))? {
            Woken::DeadlineReached => break,
            Woken::Ready(_) | Woken::Interrupted => {}
        }
        while let Some(sample) = sub.receive()? {
            let t1 = mono_ns();
            latencies_ns.push(t1.saturating_sub(stamp(&sample)));
        }
    }
    Ok(Stats {
        latencies_ns,
        cpu_ns: now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID) - cpu0,
        wall_ns: mono_ns() - wall0,
    })
}

fn receive_raw(namespace: &Namespace, mode: Mode, size: usize, count: usize) -> Res<Stats> {
    let node = NodeBuilder::new()
        .config(&raw_config(namespace)?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()?;
    let name = raw_service_name(size)?;
    let service = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(BUFFER)
        .subscriber_max_borrowed_samples(MAX_HELD)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .history_size(0)
        .open_or_create()?;
    let events = node.service_builder(&name).event().open_or_create()?;
    let listener = events.listener_builder().create()?;
    let sub = service.subscriber_builder().buffer_size(BUFFER).create()?;
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let (cpu0, wall0) = (now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID), mono_ns());
    let mut idle_since = Instant::now();
    while latencies_ns.len() < count {
        let mut got = false;
        while let Some(sample) = sub.receive()? {
            let t1 = mono_ns();
            latencies_ns.push(t1.saturating_sub(stamp(sample.payload())));
            got = true;
        }
        match mode {
            Mode::Event => {
                if listener.timed_wait(|_| {}, RECEIVER_IDLE_LIMIT)? == 0 && !sub.has_samples()? {
                    break;
                }
            }
            Mode::BusyPoll | Mode::Adaptive { .. } => {
                if got {
                    idle_since = Instant::now();
                } else if idle_since.elapsed() > RECEIVER_IDLE_LIMIT {
                    break;
                }
                std::hint::spin_loop();
            }
        }
    }
    Ok(Stats {
        latencies_ns,
        cpu_ns: now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID) - cpu0,
        wall_ns: mono_ns() - wall0,
    })
}

// ---------------------------------------------------------------- publisher side

struct Row {
    p50_ns: u64,
    p99_ns: u64,
    cpu_percent: f64,
    received: usize,
}

fn run(layer: Layer, mode: Mode, size: usize, count: usize) -> Res<Row> {
    let namespace = Namespace::unique("bench");
    let mut child = Command::new(std::env::current_exe()?)
        .env(ROLE_ENV, "receiver")
        .env(
            "BENCH_LAYER",
            if layer == Layer::Ours { "ours" } else { "raw" },
        )
        .env("BENCH_MODE", mode.encode())
        .env("BENCH_SIZE", size.to_string())
        .env("BENCH_COUNT", count.to_string())
        .env("BENCH_NAMESPACE", namespace.as_str())
        .stdout(Stdio::piped())
        .spawn()?;
    let stdout = child.stdout.take().ok_or("no receiver stdout")?;
    let mut lines = BufReader::new(stdout).lines();
    let first = lines.next().ok_or("receiver ended early")??;
    if first != "ready" {
        return Err(format!("receiver said {first}").into());
    }
    match layer {
        Layer::Ours => publish_ours(&namespace, size, count)?,
        Layer::Raw => publish_raw(&namespace, mode, size, count)?,
    }
    let result = lines.next().ok_or("receiver gave no result")??;
    child.wait()?;
    let fields: Vec<u64> = result
        .split_whitespace()
        .skip(1)
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let [p50_ns, p99_ns, cpu_ns, wall_ns, received] = fields[..] else {
        return Err(format!("bad result line {result}").into());
    };
    Ok(Row {
        p50_ns,
        p99_ns,
        cpu_percent: 100.0 * cpu_ns as f64 / wall_ns.max(1) as f64,
        received: usize::try_from(received)?,
    })
}

fn pace(next: &mut Instant) {
    *next += GAP;
    let now = Instant::now();
    if *next > now {
        std::thread::sleep(*next - now);
    } else {
        *next = now;
    }
}

fn publish_ours(namespace: &Namespace, size: usize, count: usize) -> Res<()> {
    let ipc = Ipc::open(namespace, "bench-publisher")?;
    let (name, config) = ours_channel(size);
    let mut publisher = ipc.publisher(&name, &config)?;
    let mut next = Instant::now();
    for _ in 0..count {
        let t0 = mono_ns();
        publisher.publish_with(size, |buf| encode(buf, t0))?;
        pace(&mut next);
    }
    Ok(())
}

fn publish_raw(namespace: &Namespace, mode: Mode, size: usize, count: usize) -> Res<()> {
    let node = NodeBuilder::new()
        .config(&raw_config(namespace)?)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()?;
    let name = raw_service_name(size)?;
    let service = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(BUFFER)
        .subscriber_max_borrowed_samples(MAX_HELD)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .history_size(0)
        .open_or_create()?;
    let events = node.service_builder(&name).event().open_or_create()?;
    let notifier = events.notifier_builder().create()?;
    let publisher = service
        .publisher_builder()
        .initial_max_slice_len(size)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()?;
    let mut next = Instant::now();
    for _ in 0..count {
        let t0 = mono_ns();
        let mut sample = publisher.loan_slice_uninit(size)?;
        sample.payload_mut().fill(MaybeUninit::new(0x5a));
        for (dst, src) in sample.payload_mut()[..8].iter_mut().zip(t0.to_le_bytes()) {
            dst.write(src);
        }
        // SAFETY: every byte was written just above.
        let sample = unsafe { sample.assume_init() };
        sample.send()?;
        if mode == Mode::Event {
            notifier.notify()?;
        }
        pace(&mut next);
    }
    Ok(())
}

fn us(ns: u64) -> String {
    format!("{:.1}", ns as f64 / 1000.0)
}

fn main() -> Res<()> {
    if std::env::var(ROLE_ENV).is_ok() {
        return receiver();
    }
    let count: usize = std::env::var("LEWIS_BENCH_COUNT")
        .ok()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(2000);
    println!(
        "one-way latency, two processes, {count} messages per row ({WARMUP} warm-up dropped), \
         one every {GAP:?}; times in microseconds"
    );
    println!(
        "{:<13} {:>8} | {:>9} {:>9} | {:>9} {:>9} | {:>9} {:>9} | {:>8} {:>8}",
        "mode",
        "size",
        "ours p50",
        "raw p50",
        "ours p99",
        "raw p99",
        "p50 x",
        "p99 x",
        "ours cpu",
        "raw cpu"
    );
    for mode in [Mode::Event, Mode::BusyPoll] {
        for size in SIZES {
            let ours = run(Layer::Ours, mode, size, count)?;
            let raw = run(Layer::Raw, mode, size, count)?;
            for (who, row) in [("ours", &ours), ("raw", &raw)] {
                if row.received < count {
                    println!(
                        "  ({who} {} {size}: received {} of {count})",
                        mode.label(),
                        row.received
                    );
                }
            }
            println!(
                "{:<13} {:>8} | {:>9} {:>9} | {:>9} {:>9} | {:>9.2} {:>9.2} | {:>7.0}% {:>7.0}%",
                mode.label(),
                size,
                us(ours.p50_ns),
                us(raw.p50_ns),
                us(ours.p99_ns),
                us(raw.p99_ns),
                ours.p50_ns as f64 / raw.p50_ns.max(1) as f64,
                ours.p99_ns as f64 / raw.p99_ns.max(1) as f64,
                ours.cpu_percent,
                raw.cpu_percent
            );
        }
    }
    println!();
    println!("ours, adaptive (spin, then block): receiver CPU as a share of one core");
    println!(
        "{:<18} {:>8} | {:>9} {:>9} | {:>8}",
        "mode", "size", "p50", "p99", "cpu"
    );
    for spin_us in [100, 600] {
        for size in SIZES {
            let mode = Mode::Adaptive { spin_us };
            let row = run(Layer::Ours, mode, size, count)?;
            println!(
                "{:<18} {:>8} | {:>9} {:>9} | {:>7.0}%",
                mode.label(),
                size,
                us(row.p50_ns),
                us(row.p99_ns),
                row.cpu_percent
            );
        }
    }
    Ok(())
}
