//! What every layer of the benchmark shares: wake-up modes, clocks, the receiver's result
//! line, child processes.

use std::error::Error;
use std::io::{BufRead, BufReader, Lines, Write};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use lewis_runtime::ipc::WakeMode;
use nix::time::{ClockId, clock_gettime};

pub type Res<T> = Result<T, Box<dyn Error>>;

/// Selects the role of a child process of the benchmark.
pub const ROLE_ENV: &str = "LEWIS_BENCH_ROLE";
/// Samples dropped at the start of every row (connections, page faults, caches).
pub const WARMUP: usize = 300;
/// Time between two publications (`LEWIS_BENCH_GAP_US`, default 500 µs): the receiver is
/// idle (blocked or spinning) when each arrives.
pub fn gap() -> Duration {
    let us = std::env::var("LEWIS_BENCH_GAP_US")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(500);
    Duration::from_micros(us)
}
/// A receiver that sees nothing for this long gives up (a publisher that died).
pub const IDLE_LIMIT: Duration = Duration::from_secs(5);

/// How the receiver waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Event,
    BusyPoll,
    Adaptive { spin_us: u64 },
    Predictive { margin_us: u64 },
}

impl Mode {
    pub fn encode(self) -> String {
        match self {
            Mode::Event => "event".into(),
            Mode::BusyPoll => "busy".into(),
            Mode::Adaptive { spin_us } => format!("adaptive:{spin_us}"),
            Mode::Predictive { margin_us } => format!("predictive:{margin_us}"),
        }
    }

    pub fn decode(s: &str) -> Res<Self> {
        let number = |rest: &str| -> Res<u64> { Ok(rest.parse()?) };
        Ok(match s.split_once(':') {
            None if s == "event" => Mode::Event,
            None if s == "busy" => Mode::BusyPoll,
            Some(("adaptive", n)) => Mode::Adaptive {
                spin_us: number(n)?,
            },
            Some(("predictive", n)) => Mode::Predictive {
                margin_us: number(n)?,
            },
            _ => return Err(format!("bad mode {s}").into()),
        })
    }

    pub fn label(self) -> String {
        match self {
            Mode::Event => "event".into(),
            Mode::BusyPoll => "busy-poll".into(),
            Mode::Adaptive { spin_us } => format!("adaptive {spin_us}us"),
            Mode::Predictive { margin_us } => format!("predictive {margin_us}us"),
        }
    }

    pub fn wake_mode(self) -> WakeMode {
        match self {
            Mode::Event => WakeMode::Event,
            Mode::BusyPoll => WakeMode::BusyPoll,
            Mode::Adaptive { spin_us } => WakeMode::Adaptive {
                spin: Duration::from_micros(spin_us),
            },
            Mode::Predictive { margin_us } => WakeMode::Predictive {
                margin: Duration::from_micros(margin_us),
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

/// `CLOCK_MONOTONIC`, the same in every process of the machine.
pub fn mono_ns() -> u64 {
    now_ns(ClockId::CLOCK_MONOTONIC)
}

/// What a receiver measured: one-way latencies and its own CPU time over the run.
pub struct Stats {
    pub latencies_ns: Vec<u64>,
    pub cpu_ns: u64,
    pub wall_ns: u64,
}

/// Measures the CPU time of this process against the wall clock.
pub struct CpuMeter {
    cpu0: u64,
    wall0: u64,
}

impl CpuMeter {
    pub fn start() -> Self {
        Self {
            cpu0: now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID),
            wall0: mono_ns(),
        }
    }

    pub fn stop(self, latencies_ns: Vec<u64>) -> Stats {
        Stats {
            latencies_ns,
            cpu_ns: now_ns(ClockId::CLOCK_PROCESS_CPUTIME_ID).saturating_sub(self.cpu0),
            wall_ns: mono_ns().saturating_sub(self.wall0),
        }
    }
}

/// The p-th percentile (0-100) of sorted values, nearest rank below.
pub fn percentile(sorted: &[u64], p: usize) -> u64 {
    sorted.get(sorted.len() * p / 100).copied().unwrap_or(0)
}

/// The receiver's last line: `result P50 P99 CPU_NS WALL_NS RECEIVED SEND_P50`, warm-up
/// dropped (`SEND_P50` when the receiver learnt the sender's times, else 0).
pub fn print_result(stats: Stats, mut sends_ns: Vec<u64>) {
    sends_ns.sort_unstable();
    let send_p50 = percentile(&sends_ns, 50);
    let mut l = stats.latencies_ns;
    let received = l.len();
    let l = if received > WARMUP {
        &mut l[WARMUP..]
    } else {
        &mut l[..]
    };
    l.sort_unstable();
    println!(
        "result {} {} {} {} {received} {send_p50}",
        percentile(l, 50),
        percentile(l, 99),
        stats.cpu_ns,
        stats.wall_ns,
    );
}

/// Tells the parent that the receiver is subscribed.
pub fn ready() -> Res<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "ready")?;
    out.flush()?;
    Ok(())
}

/// One row of results.
#[derive(Debug, Clone, Copy)]
pub struct Row {
    pub p50_ns: u64,
    pub p99_ns: u64,
    pub cpu_percent: f64,
    pub received: usize,
    /// The publisher's p50 time in its publish call (loan, encode, send, notify).
    pub send_p50_ns: u64,
}

/// A child process of the benchmark in `role`, its stdout piped.
pub struct RoleChild {
    pub child: Child,
    pub lines: Lines<BufReader<ChildStdout>>,
}

impl RoleChild {
    pub fn spawn(role: &str, env: &[(&str, String)]) -> Res<Self> {
        let mut command = Command::new(std::env::current_exe()?);
        command.env(ROLE_ENV, role).stdout(Stdio::piped());
        for (key, value) in env {
            command.env(key, value);
        }
        let mut child = command.spawn()?;
        let stdout = child.stdout.take().ok_or("no child stdout")?;
        Ok(Self {
            child,
            lines: BufReader::new(stdout).lines(),
        })
    }

    pub fn expect_ready(&mut self) -> Res<()> {
        match self.lines.next() {
            Some(Ok(line)) if line == "ready" => Ok(()),
            Some(Ok(line)) => Err(format!("receiver said {line}").into()),
            _ => Err("receiver ended early".into()),
        }
    }

    /// Reads the result line and reaps the child.
    pub fn result(mut self, send_ns: &mut [u64]) -> Res<Row> {
        let row = self.row(send_ns);
        self.child.wait()?;
        row
    }

    /// Reads the next result line.
    pub fn row(&mut self, send_ns: &mut [u64]) -> Res<Row> {
        let line = self.lines.next().ok_or("receiver gave no result")??;
        let fields: Vec<u64> = line
            .split_whitespace()
            .skip(1)
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        let [p50_ns, p99_ns, cpu_ns, wall_ns, received, receiver_send_p50] = fields[..] else {
            return Err(format!("bad result line {line}").into());
        };
        send_ns.sort_unstable();
        let send_p50_ns = if send_ns.is_empty() {
            receiver_send_p50
        } else {
            percentile(send_ns, 50)
        };
        Ok(Row {
            p50_ns,
            p99_ns,
            cpu_percent: 100.0 * cpu_ns as f64 / wall_ns.max(1) as f64,
            received: usize::try_from(received)?,
            send_p50_ns,
        })
    }
}

/// Sleeps until one gap after the previous publication.
pub fn pace(next: &mut Instant) {
    *next += gap();
    let now = Instant::now();
    if *next > now {
        std::thread::sleep(*next - now);
    } else {
        *next = now;
    }
}

/// An environment variable the parent set for this role.
pub fn var(key: &str) -> Res<String> {
    std::env::var(key).map_err(|_| format!("{key} missing").into())
}

/// The median, field by field, of rows measured again and again (a loaded machine makes
/// single runs noisy); `received` is the smallest.
pub fn median(rows: &[Row]) -> Row {
    fn mid(mut v: Vec<u64>) -> u64 {
        v.sort_unstable();
        v.get(v.len() / 2).copied().unwrap_or(0)
    }
    let mut cpu: Vec<f64> = rows.iter().map(|r| r.cpu_percent).collect();
    cpu.sort_by(f64::total_cmp);
    Row {
        p50_ns: mid(rows.iter().map(|r| r.p50_ns).collect()),
        p99_ns: mid(rows.iter().map(|r| r.p99_ns).collect()),
        cpu_percent: cpu.get(cpu.len() / 2).copied().unwrap_or(0.0),
        received: rows.iter().map(|r| r.received).min().unwrap_or(0),
        send_p50_ns: mid(rows.iter().map(|r| r.send_p50_ns).collect()),
    }
}
