//! `lewis import ros2` throughput against the bare `mcap` crate reading the same bag, side
//! by side in one run, in MB/s of the bag's size (run by hand):
//!
//! `cargo bench -p lewis-formats --bench import_ros2 [-- BAG.mcap] [--runs N]`
//!
//! Default bag: `../shared/data/ros2/husky-outdoor-imu-odom-gps.mcap` (7.6 MB). The bare
//! read is `mcap::MessageStream` over the file's bytes, every message touched once: the
//! floor of any reader. The import is its three passes (topics, checks, writing through
//! the recorder, zstd) into a temporary folder. A plain `main`, like the replay bench:
//! one import is long enough to time, and the figure wanted is a rate.
#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a benchmark reports on stdout, and its errors on stderr"
)]

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use lewis_formats::import::record::write_ros2;
use lewis_formats::import::ros2::{ImportOptions, Ros2Import};
use lewis_recorder::Compression;

fn default_bag() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/ros2/husky-outdoor-imu-odom-gps.mcap")
}

/// Seconds of the bare read: the file's bytes read and every message's bytes summed.
fn bare(bag: &Path) -> Result<(f64, u64), String> {
    let start = Instant::now();
    let bytes = std::fs::read(bag).map_err(|e| format!("{}: {e}", bag.display()))?;
    let mut total = 0u64;
    for message in mcap::MessageStream::new(&bytes).map_err(|e| e.to_string())? {
        let message = message.map_err(|e| e.to_string())?;
        total += message.data.iter().map(|b| u64::from(*b)).sum::<u64>() & 1;
    }
    Ok((start.elapsed().as_secs_f64(), total))
}

/// Seconds of one import into `dir`.
fn import(bag: &Path, dir: &Path, run: usize) -> Result<f64, String> {
    let start = Instant::now();
    let import = Ros2Import::open(bag, &ImportOptions::default()).map_err(|e| e.to_string())?;
    let output = dir.join(format!("import-{run}.mcap"));
    write_ros2(&import, &output, Compression::Zstd, &mut |_| {}).map_err(|e| e.to_string())?;
    let seconds = start.elapsed().as_secs_f64();
    std::fs::remove_file(&output).map_err(|e| e.to_string())?;
    Ok(seconds)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

fn run() -> Result<(), String> {
    let mut bag = default_bag();
    let mut runs = 3usize;
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--bench" => {}
            "--runs" => {
                runs = args
                    .next()
                    .and_then(|n| n.parse().ok())
                    .filter(|n| *n > 0)
                    .ok_or("--runs needs a number above 0")?;
            }
            other => bag = PathBuf::from(other),
        }
    }
    let size_mb = std::fs::metadata(&bag)
        .map_err(|e| format!("{}: {e}", bag.display()))?
        .len() as f64
        / 1e6;
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let (mut bare_s, mut import_s) = (Vec::new(), Vec::new());
    for run in 0..runs {
        bare_s.push(bare(&bag)?.0);
        import_s.push(import(&bag, dir.path(), run)?);
    }
    let (b, i) = (median(bare_s), median(import_s));
    println!(
        "{} ({size_mb:.1} MB), median of {runs} runs:",
        bag.display()
    );
    println!(
        "  mcap crate, messages read:  {:>8.1} MB/s ({b:.3} s)",
        size_mb / b
    );
    println!(
        "  lewis import ros2:          {:>8.1} MB/s ({i:.3} s), {:.1}x the bare read's time",
        size_mb / i,
        i / b
    );
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
