//! One-way publication latency, two or more processes, side by side in one run:
//!
//! - **raw**: raw iceoryx2 publish-subscribe of a byte slice (the baseline), its publisher
//!   filling the loan with a constant byte (a memset) or copying in a message it holds;
//! - **bytes**: our byte layer (`ipc::Publisher`, `ipc::Subscriber`, `WaitSet`);
//! - **client**: through everything an application and a service use: a source service
//!   under the live harness publishing a `RangeFinder` with `Context::publish` (CDR encode
//!   of the scan it holds into the loan: compare with raw copying in) or computing its
//!   arrays straight into the loan with `Context::publish_in_place` (compare with raw
//!   filling), a real broker binding a `Client<RangeFinder>` to it in another process,
//!   which decodes each scan or reads it in place (its view).
//!
//! - **side by side**: the client and the raw baseline in the same processes, taking
//!   turns: the source service also holds a raw iceoryx2 publisher (its twin) and publishes
//!   on every other tick through it, the application also holds a raw subscriber. Both
//!   paths then wake the same way (the live harness's wait, the same receiver) and meet the
//!   same machine at the same moment, so their ratio, taken within each run, does not
//!   depend on which second of a virtual machine's shifting speed each was measured in.
//!
//! Every row of a table carries the same payload: the bytes of a CDR `RangeFinder` of
//! about 64 B (the smallest scan, no beams), 64 KiB or 1 MiB. The send time is stamped
//! with `CLOCK_MONOTONIC` just before the publication; the receiver reads the clock once
//! the sample (decoded or viewed, for the client) is in hand. Messages are spaced by 500 µs, so the
//! receiver is idle (blocked or spinning) when each arrives. The receiver also measures
//! its own CPU time over the run. The publisher's time in its publish call (loan, encode,
//! send, notify) is given too: it shows what a notification costs.
//!
//! Run: `cargo bench --workspace --bench ipc_latency` (`LEWIS_BENCH_COUNT` messages per
//! row, default 2000, the first 300 dropped as warm-up; `LEWIS_BENCH_GAP_US` the time
//! between two messages, default 500; `LEWIS_BENCH_REPEAT` runs of each
//! row, default 3, of which the median is shown, the layers taking turns;
//! `LEWIS_BENCH_ROWS` a comma-separated list of the rows to run, each a substring of a
//! row's name such as `busy-poll 64 B`, `event 1 MiB` or `periodic`, default all).

#![allow(
    clippy::print_stdout,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss,
    reason = "a benchmark reports on stdout, and its statistics are floating point"
)]

mod bytes;
mod client;
mod common;
mod raw;

use client::{Publish, Read, Setup};
use common::{Mode, ROLE_ENV, Res, RoleChild, Row, median, print_result, var};
use lewis_runtime::ipc::Namespace;
use raw::Fill;

const SIZES: [(&str, usize); 3] = [("64 B", 64), ("64 KiB", 64 << 10), ("1 MiB", 1 << 20)];

/// How the client's columns of both latency tables publish and read: encoded and decoded,
/// encoded and viewed, written in place and viewed.
const CLIENT_ROWS: [(Publish, Read); 3] = [
    (Publish::Encode, Read::Decode),
    (Publish::Encode, Read::View),
    (Publish::InPlace, Read::View),
];

/// The period of the stream in the last table: a fast sensor (200 Hz), slow enough that a
/// predictable beat is not lost in the scheduling jitter of a loaded machine.
const PERIODIC: std::time::Duration = std::time::Duration::from_millis(5);

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("service") {
        return client::service_role(&args);
    }
    if let Ok(role) = std::env::var(ROLE_ENV) {
        return match role.as_str() {
            "up" => client::up_role(),
            "client" => client::receive_role(),
            _ => pair_receiver(&role),
        };
    }
    let count: usize = std::env::var("LEWIS_BENCH_COUNT")
        .ok()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(2000);
    let repeat: usize = std::env::var("LEWIS_BENCH_REPEAT")
        .ok()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(3)
        .max(1);
    let rows_filter = RowFilter::from_env();
    println!(
        "one-way latency, {count} messages per row ({} warm-up dropped), one every {:?}, \
         median of {repeat} runs; times in microseconds, p50 / p99; cpu: the receiver's, \
         share of one core; send: the publisher's p50 time in its publish call",
        common::WARMUP,
        common::gap()
    );
    for mode in [Mode::Event, Mode::BusyPoll] {
        println!();
        println!("{}:", mode.label());
        println!(
            "{:<7} {:>8} | {:>15} {:>15} {:>15} {:>15} {:>15} {:>15} | {:>6} {:>6} | {:<35} | {:<35}",
            "payload",
            "bytes",
            "raw (fill)",
            "raw (copy in)",
            "bytes layer",
            "client (decode)",
            "client (view)",
            "client (in place)",
            "x fill",
            "x copy",
            "cpu",
            "send",
        );
        for (label, target) in SIZES {
            if !rows_filter.runs(&format!("{} {label}", mode.label())) {
                continue;
            }
            let beams = client::beams_for(target);
            let len = client::payload_len(beams);
            let mut runs: [Vec<Row>; 6] = Default::default();
            for _ in 0..repeat {
                runs[0].push(pair(Layer::Raw(Fill::Pattern), mode, len, count)?);
                runs[1].push(pair(Layer::Raw(Fill::CopyIn), mode, len, count)?);
                runs[2].push(pair(Layer::Bytes, mode, len, count)?);
                for (i, how) in CLIENT_ROWS.into_iter().enumerate() {
                    runs[3 + i].push(client::run(Setup::spaced(mode, how, beams, count))?);
                }
            }
            let [raw, copied, ours, decoded, viewed, in_place] = runs.each_ref().map(|r| median(r));
            warn_short(
                count,
                &[
                    ("raw", &raw),
                    ("raw copy", &copied),
                    ("bytes", &ours),
                    ("client decode", &decoded),
                    ("client view", &viewed),
                    ("client in place", &in_place),
                ],
            );
            let rows = [&raw, &copied, &ours, &decoded, &viewed, &in_place];
            println!(
                "{label:<7} {len:>8} | {} | {:>6.2} {:>6.2} | {} | {}",
                rows.map(p50_p99).join(" "),
                in_place.p50_ns as f64 / raw.p50_ns.max(1) as f64,
                viewed.p50_ns as f64 / copied.p50_ns.max(1) as f64,
                rows.map(cpu).join(" "),
                rows.map(|r| us(r.send_p50_ns)).join(" "),
            );
        }
    }
    paired_table(&rows_filter, count, repeat)?;
    if !rows_filter.runs("periodic") {
        return Ok(());
    }
    println!();
    println!(
        "client, waiting to beat the event wake-up: a scan every {PERIODIC:?} ({} per row); \
         latency p50 / p99 and the receiver's CPU",
        count / 2
    );
    println!(
        "{:<18} | {:>15} {:>5} | {:>15} {:>5} | {:>15} {:>5}",
        "mode", "64 B", "", "64 KiB", "", "1 MiB", ""
    );
    for mode in [
        Mode::Event,
        Mode::Predictive { margin_us: 100 },
        Mode::Predictive { margin_us: 250 },
        Mode::Adaptive { spin_us: 250 },
        Mode::BusyPoll,
    ] {
        let mut line = format!("{:<18}", mode.label());
        for (_, target) in SIZES {
            let rows = (0..repeat)
                .map(|_| {
                    client::run(Setup {
                        mode,
                        publish: Publish::Encode,
                        read: Read::View,
                        beams: client::beams_for(target),
                        period: PERIODIC,
                        count: count / 2,
                    })
                })
                .collect::<Res<Vec<Row>>>()?;
            let row = median(&rows);
            warn_short(count / 2, &[("client", &row)]);
            line.push_str(&format!(" | {} {}", p50_p99(&row), cpu(&row)));
        }
        println!("{line}");
    }
    Ok(())
}

/// The client and the raw baseline taking turns in the same processes, so that both meet
/// the same machine: where the tables above run each layer on its own, one after the
/// other, a host whose speed shifts from one second to the next (a virtual machine's) can
/// favour one layer over another. Each ratio is taken within one run, then the median of
/// the runs is shown.
fn paired_table(rows_filter: &RowFilter, count: usize, repeat: usize) -> Res<()> {
    let mut header_printed = false;
    for mode in [Mode::Event, Mode::BusyPoll] {
        for (label, target) in SIZES {
            let row_name = format!("paired {} {label}", mode.label());
            if !rows_filter.runs(&row_name) {
                continue;
            }
            if !header_printed {
                println!();
                println!(
                    "side by side in the same processes: the source and a raw iceoryx2 twin take \
                     turns (the same bytes, one publication each every {:?}), one application \
                     reads both; p50 / p99 and ours over raw at p50 (median of the runs' ratios)",
                    common::gap()
                );
                println!(
                    "{:<9} {:<7} {:>8} | {:>15} {:>15} {:>6} | {:>15} {:>15} {:>6} | {:>15} {:>17} {:>6}",
                    "mode",
                    "payload",
                    "bytes",
                    "raw (copy in)",
                    "client (decode)",
                    "x",
                    "raw (copy in)",
                    "client (view)",
                    "x",
                    "raw (fill)",
                    "client (in place)",
                    "x",
                );
                header_printed = true;
            }
            let beams = client::beams_for(target);
            let mut runs: [Vec<(Row, Row)>; 3] = Default::default();
            for _ in 0..repeat {
                for (i, how) in CLIENT_ROWS.into_iter().enumerate() {
                    runs[i].push(client::run_paired(Setup::spaced(mode, how, beams, count))?);
                }
            }
            let mut line = format!(
                "{:<9} {label:<7} {:>8}",
                mode.label(),
                client::payload_len(beams)
            );
            for (i, pairs) in runs.iter().enumerate() {
                let raw_rows: Vec<Row> = pairs.iter().map(|(raw, _)| *raw).collect();
                let our_rows: Vec<Row> = pairs.iter().map(|(_, ours)| *ours).collect();
                let (raw, ours) = (median(&raw_rows), median(&our_rows));
                warn_short(count, &[("raw twin", &raw), ("client", &ours)]);
                let mut ratios: Vec<f64> = pairs
                    .iter()
                    .map(|(raw, ours)| ours.p50_ns as f64 / raw.p50_ns.max(1) as f64)
                    .collect();
                ratios.sort_by(f64::total_cmp);
                let ratio = ratios.get(ratios.len() / 2).copied().unwrap_or(0.0);
                let width = if i == 2 { 17 } else { 15 };
                line.push_str(&format!(
                    " | {} {:>width$} {ratio:>6.2}",
                    p50_p99(&raw),
                    p50_p99(&ours).trim(),
                ));
            }
            println!("{line}");
        }
    }
    Ok(())
}

/// The rows chosen with `LEWIS_BENCH_ROWS`.
struct RowFilter(Option<Vec<String>>);

impl RowFilter {
    fn from_env() -> Self {
        Self(
            std::env::var("LEWIS_BENCH_ROWS")
                .ok()
                .map(|s| s.split(',').map(|p| p.trim().to_owned()).collect()),
        )
    }

    fn runs(&self, row: &str) -> bool {
        self.0
            .as_ref()
            .is_none_or(|parts| parts.iter().any(|p| row.contains(p.as_str())))
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Layer {
    Raw(Fill),
    Bytes,
}

/// A publisher here and a receiver in a child process, for the raw and byte layers.
fn pair(layer: Layer, mode: Mode, len: usize, count: usize) -> Res<Row> {
    let namespace = Namespace::unique("bench");
    let role = match layer {
        Layer::Raw(_) => "raw",
        Layer::Bytes => "bytes",
    };
    let mut receiver = RoleChild::spawn(
        role,
        &[
            ("BENCH_MODE", mode.encode()),
            ("BENCH_SIZE", len.to_string()),
            ("BENCH_COUNT", count.to_string()),
            ("BENCH_NAMESPACE", namespace.to_string()),
        ],
    )?;
    receiver.expect_ready()?;
    let mut sends = match layer {
        Layer::Raw(fill) => raw::publish(&namespace, mode, fill, len, count)?,
        Layer::Bytes => bytes::publish(&namespace, len, count)?,
    };
    receiver.result(&mut sends)
}

fn pair_receiver(role: &str) -> Res<()> {
    let mode = Mode::decode(&var("BENCH_MODE")?)?;
    let len: usize = var("BENCH_SIZE")?.parse()?;
    let count: usize = var("BENCH_COUNT")?.parse()?;
    let namespace = Namespace::new(&var("BENCH_NAMESPACE")?)?;
    let stats = match role {
        "raw" => raw::receive(&namespace, mode, len, count)?,
        "bytes" => bytes::receive(&namespace, mode, len, count)?,
        other => return Err(format!("unknown role {other}").into()),
    };
    print_result(stats, Vec::new());
    Ok(())
}

fn warn_short(count: usize, rows: &[(&str, &Row)]) {
    for (who, row) in rows {
        if row.received < count {
            println!("  ({who}: received {} of {count})", row.received);
        }
    }
}

fn us(ns: u64) -> String {
    format!("{:>5.1}", ns as f64 / 1000.0)
}

fn p50_p99(row: &Row) -> String {
    format!(
        "{:>15}",
        format!("{} / {}", us(row.p50_ns).trim(), us(row.p99_ns).trim())
    )
}

fn cpu(row: &Row) -> String {
    format!("{:>4.0}%", row.cpu_percent)
}
