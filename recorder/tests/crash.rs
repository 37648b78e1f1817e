//! A recorder killed with SIGKILL mid-run leaves a file that `recover` repairs, keeping
//! every message up to the last complete chunk.
//!
//! This test runs itself as the child (`crash --child FILE COMPRESSION`): the child
//! records the stress mix as fast as it can and prints `durable N` whenever N messages
//! are in closed chunks, and `mid-chunk` when it is well into the next one; the parent
//! kills it with SIGKILL there after a few chunks, recovers
//! the file, and checks with the independent Python readers that the recovered messages
//! are exactly the first ones generated, at least N of them, and that
//! `pymcap-cli doctor` accepts the file.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};

use common::traffic;
use common::{Digests, options, python_read, sample};
use lewis_recorder::{Compression, Recorder, recover};
use lewis_testkit::doctor;
use nix::sys::signal::{Signal, kill};
use nix::unistd::Pid;

/// The parent kills the child once this many messages are durable, in the middle of the
/// next chunk.
const KILL_AFTER_DURABLE: u64 = 40_000;
/// Chunks close at 8 MiB: large enough that a camera frame (0.9 MB) is not a message of
/// its own chunk (a quarter of one), so chunks hold frames and small messages mixed and
/// take long enough to fill to be killed in the middle of.
const CHUNK_BYTES: u64 = 8 * 1024 * 1024;
/// Message bytes into a chunk that count as its middle.
const MID_CHUNK_BYTES: usize = 6 * 1024 * 1024;

fn child(path: &Path, compression: &str) {
    let mut options = options(path);
    options.compression = compression.parse().unwrap();
    options.chunk_size_bytes = CHUNK_BYTES;
    let mut recorder = Recorder::create(options).unwrap();
    let channels = traffic::stress_channels();
    let ids: Vec<_> = channels
        .iter()
        .map(|c| recorder.add_channel(c.clone()).unwrap())
        .collect();
    let mut stdout = std::io::stdout().lock();
    let mut durable = 0;
    let mut pending_bytes = 0;
    // An hour of simulated time: the parent kills it long before.
    for m in traffic::stress_mix(3600 * lewis_recorder::SECOND_NS) {
        recorder.write(&sample(ids[m.channel], &m)).unwrap();
        pending_bytes += m.data.len();
        if recorder.durable_messages() != durable {
            durable = recorder.durable_messages();
            pending_bytes = 0;
            writeln!(stdout, "durable {durable}").unwrap();
            stdout.flush().unwrap();
        } else if pending_bytes >= MID_CHUNK_BYTES && pending_bytes - m.data.len() < MID_CHUNK_BYTES
        {
            // Well into a chunk: part of it has left the writer's buffers for the file.
            writeln!(stdout, "mid-chunk").unwrap();
            stdout.flush().unwrap();
        }
    }
}

fn sigkill_mid_run_then_recover(compression: Compression) {
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("killed.mcap");
    let fixed = dir.path().join("fixed.mcap");
    let mut child = Command::new(std::env::current_exe().unwrap())
        .arg("--child")
        .arg(&broken)
        .arg(compression.name())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut durable = 0_u64;
    for line in BufReader::new(child.stdout.take().unwrap()).lines() {
        let line = line.unwrap();
        if line == "mid-chunk" {
            if durable >= KILL_AFTER_DURABLE {
                break;
            }
        } else {
            durable = line.strip_prefix("durable ").unwrap().parse().unwrap();
        }
    }
    kill(Pid::from_raw(child.id() as i32), Signal::SIGKILL).unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "the child ended before it was killed");
    assert!(durable >= KILL_AFTER_DURABLE, "the child stopped early");

    let report = recover(&broken, &fixed).unwrap();
    assert!(!report.input_complete);
    assert!(report.chunks > 0);
    doctor(&fixed);
    let view = python_read(std::slice::from_ref(&fixed));
    let got = view.digests();
    let recovered: u64 = got.values().map(|d| d.count).sum();
    assert!(
        recovered >= durable,
        "{compression}: {recovered} messages recovered, but {durable} were in complete chunks"
    );
    let channels = traffic::stress_channels();
    let mut expected = Digests::default();
    for m in traffic::stress_mix(3600 * lewis_recorder::SECOND_NS).take(recovered as usize) {
        expected.add(&channels[m.channel].topic, m.seq, &m.data);
    }
    assert_eq!(
        got,
        expected.finish(),
        "{compression}: the recovered messages are not the first ones written"
    );
    println!(
        "{compression}: killed with {durable} durable; recovered {recovered} messages in {} chunks, {} bytes discarded ({})",
        report.chunks,
        report.discarded_bytes,
        report.damage.unwrap_or_default()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--child") {
        child(Path::new(&args[2]), &args[3]);
        return;
    }
    let name = "a_recorder_killed_with_sigkill_leaves_a_file_that_recover_repairs";
    // Honour a test-name filter as libtest does.
    if let Some(filter) = args.iter().skip(1).find(|a| !a.starts_with('-'))
        && !name.contains(filter.as_str())
    {
        return;
    }
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        sigkill_mid_run_then_recover(compression);
    }
    println!("test {name} ... ok");
}
