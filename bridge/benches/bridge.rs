//! The bridge between hosts (`lewis-bridge`) against plain Zenoh, across a real link: two
//! hosts of [`lewis_testkit::hosts`] (`a` at 10.0.0.1, `b` at 10.0.0.2, each in its own
//! network, IPC and mount namespaces, joined by a veth cable through a switch), each
//! running `lewis-bridge-peer` (`bridge/src/bin/lewis-bridge-peer.rs`, where the protocol is
//! described).
//!
//! - **Latency**: ping-pong of 64 B, 64 KiB and 1 MiB (50 round trips of warm-up, then
//!   1000, 1000 and 200), one way = half the round trip, p50 and p99. `raw`: Zenoh
//!   publisher to subscriber, `b` putting the pong from its subscriber's callback.
//!   `bridge`: IPC publisher on `a` -> `a`'s bridge -> Zenoh -> `b`'s bridge -> IPC
//!   subscriber on `b`, which publishes the pong the same way back: the difference is what
//!   Lewis adds. The two take turns, a raw round trip then a bridge one: measured one
//!   after the other, they saw different machines (this one's latency drifts by more
//!   than their difference within a minute, and the ratio moved from 1.3x to 2.2x between
//!   runs). Goal: the bridge's p50 within 1.3x raw Zenoh's.
//! - **Camera**: 640x480 rgb8 frames (921,600 B) at 30 Hz for 10 s from `a` to `b`, raw and
//!   through the bridge (`/camera/ImageSource`): frames received, lost, MB/s, and the
//!   frames' one-way latency (both hosts read the same kernel clock). Goal: none lost.
//!
//! Both transports run in the same peers, each on its own Zenoh session and port.
//!
//! `cargo bench -p lewis-bridge --bench bridge` (`-- --frames N`: another camera length,
//! default 300; `-- --keep-cores-awake`: idle cores poll rather than sleep for the whole
//! run, `/dev/cpu_dma_latency` held at 0, so that no wake-up waits for a sleeping core).
//! Needs root for the network namespaces; skipped with the reason where they are forbidden.
//! The peer is the `lewis-bridge-peer` binary of this package, which cargo builds before it
//! runs a benchmark (`CARGO_BIN_EXE_lewis-bridge-peer`);
//! `LEWIS_BRIDGE_PEER` names another.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stdout,
    clippy::print_stderr,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "a benchmark: it reports on stdout, and its statistics are floating point"
)]

use std::io::{BufRead as _, BufReader};
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use lewis_testkit::hosts::{Host, Hosts};

/// How long a peer may take to say its next line before the benchmark gives up on it.
const WATCHDOG: Duration = Duration::from_secs(60);
/// A camera frame, as the peer sends it.
const FRAME_BYTES: f64 = 921_600.0;
const CAMERA_HZ: f64 = 30.0;

/// What one transport measured.
#[derive(Default)]
struct Measured {
    /// Per payload size: (size, rounds, timeouts, p50 ns, p99 ns).
    latency: Vec<(usize, u64, u64, f64, f64)>,
    /// Frames sent, and how long sending took (ns).
    sent: (u64, f64),
    /// Frames received, missing, out of order, first to last (ns), latency p50, p99, max (ns).
    received: (u64, u64, u64, f64, f64, f64, f64),
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let frames: u64 = args
        .iter()
        .position(|a| a == "--frames")
        .and_then(|i| args.get(i + 1))
        .map_or(300, |n| n.parse().expect("--frames N"));
    let peer = std::env::var_os("LEWIS_BRIDGE_PEER").map_or_else(
        || PathBuf::from(env!("CARGO_BIN_EXE_lewis-bridge-peer")),
        PathBuf::from,
    );
    let hosts = match Hosts::new(&["a", "b"]) {
        Ok(hosts) => hosts,
        Err(why) => {
            println!("bridge benchmark skipped: {why}");
            return;
        }
    };
    println!(
        "lewis-bridge vs raw Zenoh between two hosts (veth through a switch, network \
         namespaces), {} CPUs",
        std::thread::available_parallelism().map_or(0, usize::from)
    );
    // Held until the end of `main`: the kernel drops the request when the file closes.
    let _awake = if args.iter().any(|a| a == "--keep-cores-awake") {
        match lewis_runtime::supervise::keep_cores_awake() {
            Ok(held) => {
                println!("idle cores kept polling (/dev/cpu_dma_latency held at 0)");
                Some(held)
            }
            Err(e) => {
                println!("{e}: idle cores as the machine has them");
                None
            }
        }
    } else {
        None
    };
    let started = Instant::now();
    let [raw, bridge] = measure(&hosts, &peer, frames);
    for host in ["a", "b"] {
        let left = hosts.host(host).processes();
        assert!(
            left.is_empty(),
            "processes {left:?} are left in host {host}"
        );
    }
    drop(hosts);

    println!();
    println!("one-way latency (half the round trip), microseconds");
    println!(
        "{:<10}{:>10}{:>10}{:>13}{:>13}{:>11}{:>11}",
        "payload", "raw p50", "raw p99", "bridge p50", "bridge p99", "ratio p50", "ratio p99"
    );
    for (r, b) in raw.latency.iter().zip(&bridge.latency) {
        assert_eq!(r.0, b.0, "the same sizes in both runs");
        println!(
            "{:<10}{:>10.1}{:>10.1}{:>13.1}{:>13.1}{:>10.2}x{:>10.2}x",
            size_name(r.0),
            r.3 / 1e3,
            r.4 / 1e3,
            b.3 / 1e3,
            b.4 / 1e3,
            b.3 / r.3,
            b.4 / r.4
        );
        for (name, m) in [("raw", r), ("bridge", b)] {
            if m.2 > 0 {
                println!(
                    "  ({name} {}: {} round trips timed out)",
                    size_name(m.0),
                    m.2
                );
            }
        }
    }
    println!();
    println!(
        "camera 640x480 rgb8 ({FRAME_BYTES} B) at {CAMERA_HZ} Hz, {frames} frames: \
         received, lost, MB/s, one-way latency p50/p99/max ms"
    );
    for (name, m) in [("raw", &raw), ("bridge", &bridge)] {
        let (received, missing, disordered, span, p50, p99, max) = m.received;
        let rate = if span > 0.0 {
            // Frames after the first over the time from the first to the last.
            (received.saturating_sub(1)) as f64 * FRAME_BYTES / (span / 1e9) / 1e6
        } else {
            0.0
        };
        println!(
            "{name:<8}sent {:>4} received {received:>4} lost {missing:>3}{}  {rate:6.1} MB/s  \
             {:6.2} {:6.2} {:6.2}{}",
            m.sent.0,
            if disordered > 0 {
                format!(" ({disordered} out of order)")
            } else {
                String::new()
            },
            p50 / 1e6,
            p99 / 1e6,
            max / 1e6,
            if missing == 0 { "" } else { "  LOSS" }
        );
    }
    println!("({:.1} s in all)", started.elapsed().as_secs_f64());
}

fn size_name(size: usize) -> String {
    match size {
        s if s >= 1 << 20 && s % (1 << 20) == 0 => format!("{} MiB", s >> 20),
        s if s >= 1 << 10 && s % (1 << 10) == 0 => format!("{} KiB", s >> 10),
        s => format!("{s} B"),
    }
}

/// A peer running in a host: its lines come through `lines`; closing its stdin ends it.
struct Peer {
    name: String,
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
}

impl Peer {
    fn start(host: &Host, peer: &PathBuf, address: &str, frames: u64) -> Self {
        let mut child = host
            .command(peer)
            .args([host.name(), address, "--frames", &frames.to_string()])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", peer.display()));
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            name: format!("peer in {}", host.name()),
            stdin: child.stdin.take(),
            child,
            lines,
        }
    }

    /// The next line it says.
    fn line(&mut self) -> String {
        match self.lines.recv_timeout(WATCHDOG) {
            Ok(line) => line,
            Err(_) => {
                let status = self.child.try_wait();
                panic!(
                    "the {} said nothing more within {WATCHDOG:?} ({status:?})",
                    self.name
                )
            }
        }
    }

    /// The next line, which must start with `words`: its other words as numbers.
    fn expect(&mut self, words: &str) -> Vec<f64> {
        self.expect_one_of(&[words.to_owned()]).1
    }

    /// The next line, which must start with one of `starts`: which, and its other words as
    /// numbers.
    fn expect_one_of(&mut self, starts: &[String]) -> (String, Vec<f64>) {
        let line = self.line();
        let Some(start) = starts.iter().find(|s| {
            line.strip_prefix(s.as_str())
                .is_some_and(|r| r.is_empty() || r.starts_with(' '))
        }) else {
            panic!("the {} said {line:?}, not one of {starts:?}", self.name);
        };
        let numbers = line[start.len()..]
            .split_whitespace()
            .map(|w| w.parse().unwrap_or_else(|_| panic!("{line:?}")))
            .collect();
        (start.clone(), numbers)
    }

    /// Closes its stdin and waits for it to end (killed after a while).
    fn finish(mut self) {
        drop(self.stdin.take());
        let deadline = Instant::now() + Duration::from_secs(10);
        while self.child.try_wait().ok().flatten().is_none() {
            if Instant::now() > deadline {
                eprintln!("the {} does not end: killed", self.name);
                let _ = self.child.kill();
                let _ = self.child.wait();
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

/// Runs the peers: `b` first (it connects to `a`, retrying), then `a`. What each
/// transport measured: raw, then the bridge.
fn measure(hosts: &Hosts, peer: &PathBuf, frames: u64) -> [Measured; 2] {
    const TRANSPORTS: [&str; 2] = ["raw", "bridge"];
    let address = hosts.host("a").address().to_string();
    let mut b = Peer::start(hosts.host("b"), peer, &address, frames);
    b.expect("ready");
    let mut a = Peer::start(hosts.host("a"), peer, &address, frames);
    a.expect("ready");
    let mut measured = [Measured::default(), Measured::default()];
    for _ in 0..3 {
        for transport in TRANSPORTS {
            let v = a.expect(&format!("latency {transport}"));
            measured[index(transport)].latency.push((
                v[0] as usize,
                v[1] as u64,
                v[2] as u64,
                v[3],
                v[4],
            ));
        }
    }
    for transport in TRANSPORTS {
        let v = a.expect(&format!("camera-sent {transport}"));
        measured[index(transport)].sent = (v[0] as u64, v[1]);
    }
    a.expect("done");
    // Each transport's frames are counted on their own thread: in either order.
    for _ in TRANSPORTS {
        let (transport, v) = b.expect_one_of(&TRANSPORTS.map(|t| format!("camera-received {t}")));
        measured[index(&transport)].received = (
            v[0] as u64,
            v[1] as u64,
            v[2] as u64,
            v[3],
            v[4],
            v[5],
            v[6],
        );
    }
    b.finish();
    a.finish();
    measured
}

/// Where a transport's figures go.
fn index(transport: &str) -> usize {
    usize::from(transport.ends_with("bridge"))
}
