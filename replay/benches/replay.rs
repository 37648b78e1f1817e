//! Replay speed and memory, run by hand (figures in the README's Speed section).
//!
//! - `cargo bench -p lewis-replay --bench replay [-- RUN.mcap] [--runs N]`: the speed of a
//!   replay of RUN.mcap (default: the reference recording `tests/data/reference/sim-goal.mcap`)
//!   as a multiple of real time, beside the lockstep harness alone and the same services
//!   called directly in a loop with the same inputs ([`lewis_replay::bench::speed`]).
//! - `... --bench replay -- --once LONG.mcap -o OUT.mcap`: one replay, as `lewis replay
//!   LONG.mcap -o OUT.mcap` runs it, to measure its peak memory from outside
//!   (`/usr/bin/time -v` on the benchmark's executable). `lewis bench long-recording`
//!   makes a long recording.
//!
//! This is a plain `main` rather than criterion: one replay of the reference already takes
//! long enough to time, and the figures wanted are multiples of real time.
#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a benchmark reports on stdout, and its errors on stderr"
)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use lewis_replay::bench::speed::{SpeedOptions, measure};
use lewis_replay::resim::{ReplayOptions, replay};

/// The repository's root: where `lewis replay` runs, so that a simulated device a replay
/// builds finds its world (`robots/worlds/...`) as it does there.
fn repository() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The reference recording.
fn reference() -> PathBuf {
    repository().join("tests/data/reference/sim-goal.mcap")
}

/// What the command line asks for.
struct Args {
    input: PathBuf,
    output: Option<PathBuf>,
    runs: usize,
    once: bool,
}

fn parse(args: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut parsed = Args {
        input: reference(),
        output: None,
        runs: 5,
        once: false,
    };
    let mut args = args.skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            // What `cargo bench` passes to every benchmark.
            "--bench" => {}
            "--once" => parsed.once = true,
            "--runs" => {
                let value = args.next().ok_or("--runs needs a number")?;
                parsed.runs = value
                    .parse()
                    .map_err(|_| format!("--runs {value}: not a number"))?;
            }
            "-o" => parsed.output = Some(args.next().ok_or("-o needs a file")?.into()),
            other if other.starts_with('-') => {
                return Err(format!(
                    "unknown option {other}: expected [RUN.mcap] [--runs N] [--once [-o OUT.mcap]]"
                ));
            }
            other => parsed.input = other.into(),
        }
    }
    Ok(parsed)
}

fn options(args: &Args) -> ReplayOptions {
    let mut options = ReplayOptions::new(vec![args.input.clone()]);
    options.output.clone_from(&args.output);
    options
}

fn main() -> ExitCode {
    // `cargo bench` runs a benchmark in its package's directory; paths given on the command
    // line are taken from there, before moving to the repository's root.
    let here = std::env::current_dir().unwrap_or_default();
    let args = match parse(std::env::args()) {
        Ok(args) => args,
        Err(error) => {
            eprintln!("{error}");
            return ExitCode::from(2);
        }
    };
    let mut args = args;
    args.input = here.join(&args.input);
    args.output = args.output.map(|o| here.join(o));
    if let Err(error) = std::env::set_current_dir(repository()) {
        eprintln!("cannot move to the repository's root: {error}");
        return ExitCode::from(2);
    }
    let registry = lewis_kinds::registry();
    if args.once {
        let started = Instant::now();
        match replay(&options(&args), &registry, &mut |_| {}) {
            Ok(report) => {
                println!(
                    "replayed {} ({} messages read, {} written) into {} in {:.1} s",
                    args.input.display(),
                    report.messages_read,
                    report.messages_written,
                    report.output,
                    started.elapsed().as_secs_f64()
                );
                ExitCode::SUCCESS
            }
            Err(error) => {
                eprintln!("{error}");
                ExitCode::FAILURE
            }
        }
    } else {
        // The speed measure writes each replay's output to a scratch file, removed after.
        let scratch =
            std::env::temp_dir().join(format!("lewis-bench-replay-{}.mcap", std::process::id()));
        let mut replay = options(&args);
        replay.output = Some(scratch.clone());
        let report = measure(
            &SpeedOptions {
                replay,
                runs: args.runs,
            },
            &registry,
        );
        let _ = std::fs::remove_file(&scratch);
        match report {
            Ok(report) => {
                println!("{report}");
                ExitCode::SUCCESS
            }
            Err(error) => {
                eprintln!("{error}");
                ExitCode::FAILURE
            }
        }
    }
}
