//! What one wake-up of a sleeping thread costs on this machine, by where the two threads
//! run: the floor under every hop between processes that do not spin, and so under the
//! bridge between hosts (one and a half such hops per one way beyond raw Zenoh).
//!
//! Two threads play ping-pong, one way = half the round trip, the pinger sleeping 200 µs
//! between rounds so that the other side is asleep when each ping comes (as a service
//! waiting for its next sensor message is). Each wake-up mechanism is measured with both
//! threads pinned to the same core, pinned to two different cores, and left where the
//! scheduler puts them:
//!
//! - **futex**: `std::thread::park`/`unpark`, the cheapest way to wake a thread;
//! - **eventfd**: a blocking `read` of an eventfd;
//! - **unix datagram**: a blocking `recv` on a socket pair, the kernel path of an iceoryx2
//!   notification;
//! - **iceoryx2**: our byte layer (`ipc::Publisher`, `ipc::Subscriber`, `WaitSet` in
//!   event mode), a 64-byte sample each way: what a hop between two services costs.
//!
//! The cells are measured twice: with the machine's idle states as they are, then (where
//! `/dev/cpu_dma_latency` can be written, as root) with every idle core polling instead of
//! sleeping, which is what a wake-up across cores costs when no core has to be woken.
//!
//! Run: `cargo bench -p lewis-runtime --bench wake` (`LEWIS_BENCH_COUNT` rounds per cell,
//! default 3000, the first 300 dropped as warm-up).

#![allow(
    clippy::unwrap_used,
    clippy::print_stdout,
    clippy::cast_precision_loss,
    reason = "a benchmark fails loudly on a broken setup and reports on stdout"
)]

use std::os::unix::net::UnixDatagram;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use lewis_runtime::ipc::{ChannelConfig, Ipc, Namespace, WaitSet, WakeMode};
use rustix::event::{EventfdFlags, eventfd};
use rustix::fd::OwnedFd;
use rustix::thread::{CpuSet, sched_getaffinity, sched_setaffinity};

/// The pinger's sleep between two rounds.
const GAP: Duration = Duration::from_micros(200);
const WARMUP: usize = 300;
const PAYLOAD: usize = 64;

/// Where the two threads run.
#[derive(Clone, Copy)]
enum Placement {
    SameCore,
    OtherCores,
    Free,
}

impl Placement {
    /// The cores of the pinger and of the ponger, if pinned.
    fn cores(self) -> Option<(usize, usize)> {
        match self {
            Self::SameCore => Some((0, 0)),
            Self::OtherCores => Some((0, 1)),
            Self::Free => None,
        }
    }
}

fn pin(core: Option<usize>) {
    if let Some(core) = core {
        let mut set = CpuSet::new();
        set.set(core);
        sched_setaffinity(None, &set).unwrap();
    }
}

/// One side of a ping-pong: sends a ping or pong and waits for the other's.
trait End {
    fn send(&mut self);
    fn wait(&mut self);
}

/// Makes one end on the thread that uses it (iceoryx2's ports stay on their thread).
type Builder = Box<dyn FnOnce() -> Box<dyn End> + Send>;

/// The builders of a pair of ends, made for each cell.
type Make = fn() -> (Builder, Builder);

fn built(end: impl End + Send + 'static) -> Builder {
    Box::new(move || Box::new(end))
}

/// Park and unpark, with a flag so that a wake-up is never lost or taken twice.
struct Futex {
    mine: Arc<AtomicU32>,
    theirs: Arc<AtomicU32>,
    peer: Arc<std::sync::OnceLock<thread::Thread>>,
    me: Arc<std::sync::OnceLock<thread::Thread>>,
}

impl End for Futex {
    fn send(&mut self) {
        self.theirs.store(1, Ordering::Release);
        self.peer.wait().unpark();
    }
    fn wait(&mut self) {
        let _ = self.me.set(thread::current());
        while self.mine.swap(0, Ordering::Acquire) == 0 {
            thread::park();
        }
    }
}

fn futex() -> (Builder, Builder) {
    let (a, b) = (Arc::new(AtomicU32::new(0)), Arc::new(AtomicU32::new(0)));
    let (ta, tb) = (
        Arc::new(std::sync::OnceLock::new()),
        Arc::new(std::sync::OnceLock::new()),
    );
    (
        built(Futex {
            mine: a.clone(),
            theirs: b.clone(),
            peer: tb.clone(),
            me: ta.clone(),
        }),
        built(Futex {
            mine: b,
            theirs: a,
            peer: ta,
            me: tb,
        }),
    )
}

struct EventFd {
    mine: Arc<OwnedFd>,
    theirs: Arc<OwnedFd>,
}

impl End for EventFd {
    fn send(&mut self) {
        rustix::io::write(&*self.theirs, &1u64.to_ne_bytes()).unwrap();
    }
    fn wait(&mut self) {
        let mut buf = [0u8; 8];
        rustix::io::read(&*self.mine, &mut buf).unwrap();
    }
}

fn event_fd() -> (Builder, Builder) {
    let a = Arc::new(eventfd(0, EventfdFlags::CLOEXEC).unwrap());
    let b = Arc::new(eventfd(0, EventfdFlags::CLOEXEC).unwrap());
    (
        built(EventFd {
            mine: a.clone(),
            theirs: b.clone(),
        }),
        built(EventFd { mine: b, theirs: a }),
    )
}

struct Datagram(UnixDatagram);

impl End for Datagram {
    fn send(&mut self) {
        self.0.send(&[1]).unwrap();
    }
    fn wait(&mut self) {
        let mut buf = [0u8; 1];
        self.0.recv(&mut buf).unwrap();
    }
}

fn datagram() -> (Builder, Builder) {
    let (a, b) = UnixDatagram::pair().unwrap();
    (built(Datagram(a)), built(Datagram(b)))
}

/// A byte-layer publisher and subscriber on two channels, one each way.
struct Iceoryx {
    publisher: lewis_runtime::ipc::Publisher,
    subscriber: lewis_runtime::ipc::Subscriber,
    waits: WaitSet,
    _ipc: Ipc,
}

impl End for Iceoryx {
    fn send(&mut self) {
        self.publisher.publish(&[7u8; PAYLOAD]).unwrap();
    }
    fn wait(&mut self) {
        loop {
            if self.subscriber.receive().unwrap().is_some() {
                return;
            }
            self.waits.wait(&[&self.subscriber], None).unwrap();
        }
    }
}

fn iceoryx() -> (Builder, Builder) {
    let namespace = Namespace::unique("wake-bench");
    let end = move |name: &'static str, out: &'static str, inn: &'static str| -> Builder {
        let namespace = namespace.clone();
        Box::new(move || {
            let config = ChannelConfig {
                buffer: 8,
                history: 0,
                max_held: 2,
                max_subscribers: 8,
                max_publishers: 2,
                ..ChannelConfig::sensor(PAYLOAD)
            };
            let ipc = Ipc::open(&namespace, name).unwrap();
            let publisher = ipc.publisher(out, &config).unwrap();
            let subscriber = ipc.subscriber(inn, &config).unwrap();
            Box::new(Iceoryx {
                publisher,
                subscriber,
                waits: WaitSet::new(WakeMode::Event),
                _ipc: ipc,
            })
        })
    };
    (
        end("pinger", "/wake/ping", "/wake/pong"),
        end("ponger", "/wake/pong", "/wake/ping"),
    )
}

/// One-way p50 and p99 in µs over `count` rounds.
fn measure(make: Make, placement: Placement, count: usize) -> (f64, f64) {
    let (ping, pong) = make();
    let cores = placement.cores();
    let allowed = sched_getaffinity(None).unwrap();
    pin(cores.map(|c| c.0));
    let mut ping = ping();
    let (ready_tx, ready_rx) = mpsc::channel::<()>();
    let ponger = thread::spawn(move || {
        pin(cores.map(|c| c.1));
        let mut pong = pong();
        ready_tx.send(()).unwrap();
        for _ in 0..count {
            pong.wait();
            pong.send();
        }
    });
    ready_rx.recv().unwrap();
    let mut one_way: Vec<f64> = Vec::with_capacity(count);
    for _ in 0..count {
        thread::sleep(GAP);
        let start = Instant::now();
        ping.send();
        ping.wait();
        one_way.push(start.elapsed().as_secs_f64() * 1e6 / 2.0);
    }
    ponger.join().unwrap();
    drop(ping);
    // The main thread runs where it was allowed to again after a pinned cell.
    sched_setaffinity(None, &allowed).unwrap();
    let mut kept = one_way.split_off(WARMUP.min(one_way.len()));
    kept.sort_by(f64::total_cmp);
    let at = |q: f64| kept[((kept.len() - 1) as f64 * q) as usize];
    (at(0.5), at(0.99))
}

fn cores() -> usize {
    thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

fn table(placements: &[(&str, Placement)], count: usize) {
    let rows: [(&str, Make); 4] = [
        ("futex (park/unpark)", futex),
        ("eventfd", event_fd),
        ("unix datagram", datagram),
        ("iceoryx2 (byte layer, event wait)", iceoryx),
    ];
    let header: Vec<&str> = placements.iter().map(|(name, _)| *name).collect();
    println!("| mechanism | {} |", header.join(" | "));
    println!("|---|{}", "---|".repeat(placements.len()));
    for (name, make) in rows {
        let cells: Vec<String> = placements
            .iter()
            .map(|(_, placement)| {
                let (p50, p99) = measure(make, *placement, count);
                format!("{p50:.1} / {p99:.1}")
            })
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}

fn main() {
    let count: usize = std::env::var("LEWIS_BENCH_COUNT")
        .ok()
        .and_then(|n| n.parse().ok())
        .unwrap_or(3000)
        .max(WARMUP + 100);
    let placements: Vec<(&str, Placement)> = if cores() >= 2 {
        vec![
            ("same core", Placement::SameCore),
            ("two cores", Placement::OtherCores),
            ("free", Placement::Free),
        ]
    } else {
        println!("one core only: the two-core column is left out");
        vec![
            ("same core", Placement::SameCore),
            ("free", Placement::Free),
        ]
    };
    println!(
        "one-way wake-up, p50 / p99 in µs, {} rounds per cell, {} µs between rounds",
        count - WARMUP,
        GAP.as_micros()
    );
    println!("\nidle cores as the machine has them:");
    table(&placements, count);
    match lewis_runtime::supervise::keep_cores_awake() {
        Ok(held) => {
            println!("\nidle cores kept polling (/dev/cpu_dma_latency held at 0):");
            table(&placements, count);
            drop(held);
        }
        Err(e) => println!("\n{e}: no table with idle cores kept polling"),
    }
}
