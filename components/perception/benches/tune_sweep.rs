//! The tuning page's sweep (`lewis tune open`) beside the live CMVision, in one run: how
//! many 640x480 frames of a recording are re-segmented per second, on one core, after a
//! class's range moves (`lewis_perception::sweep::sweep` over the held, 2x2-decimated
//! frames: a new CmVision for the new ranges, then every frame), and the live blob
//! finder's frames per second on the same frames at full size (`CmVision::process`).
//!
//! The frames are the photos of ../shared/data/images at 640x480 (as the CMVision
//! benchmark uses), repeated into a "recording" of 1500 frames (5 minutes at 5 Hz), with
//! robots/colors/bench6.txt. Run: `cargo bench -p lewis-perception --bench tune_sweep`.
#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a benchmark reports on its terminal"
)]

use std::hint::black_box;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use lewis_perception::cmvision::{CmVision, ColorConfig, RgbFrame};
use lewis_perception::sweep::{FrameStore, HeldFrame, sweep};

mod common;
use common::{HEIGHT, WIDTH, load_frame, repository_path};

/// 5 minutes at 5 Hz.
const RECORDING_FRAMES: usize = 1500;
const PHOTOS: [&str; 5] = [
    "apple.jpg",
    "fruits.jpg",
    "orange.jpg",
    "smarties.png",
    "stuff.jpg",
];

/// The median of `runs` timed runs of `run`, after one warm-up.
fn median(runs: usize, mut run: impl FnMut()) -> Duration {
    run();
    let mut times: Vec<Duration> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed()
        })
        .collect();
    times.sort_unstable();
    times[times.len() / 2]
}

fn run() -> Result<(), String> {
    let config = ColorConfig::load(&repository_path("robots/colors/bench6.txt"))
        .map_err(|e| e.to_string())?;
    let photos = PHOTOS
        .iter()
        .map(|name| load_frame(name))
        .collect::<Result<Vec<_>, _>>()?;

    // The live blob finder: one full 640x480 frame at a time.
    let mut live = CmVision::new(&config).map_err(|e| e.to_string())?;
    let frames: Vec<RgbFrame<'_>> = photos
        .iter()
        .map(|p| RgbFrame::new(WIDTH, HEIGHT, p).map_err(|e| e.to_string()))
        .collect::<Result<_, _>>()?;
    let live_frame = median(200, || {
        for frame in &frames {
            black_box(live.process(*frame).len());
        }
    }) / u32::try_from(frames.len()).unwrap_or(1);

    // The page: the recording held as the page holds it, swept after a range moves.
    let held_at = Instant::now();
    let mut store = FrameStore::new(512 << 20);
    for i in 0..RECORDING_FRAMES {
        let photo = &photos[i % photos.len()];
        let name = format!("frame-{i:06}");
        let time_ns = i64::try_from(i).unwrap_or(0) * 200_000_000;
        store.offer(
            HeldFrame::decimate(name, time_ns, WIDTH, HEIGHT, photo).map_err(|e| e.to_string())?,
        );
    }
    let hold = held_at.elapsed();
    let held = store.frames();
    let mut moved = config.clone();
    let mut step = 0u8;
    let recording = median(10, || {
        // Each sweep is for new ranges, as after a slider moves.
        step = step.wrapping_add(1);
        moved.colors[0].y.hi = 200u8.saturating_add(step % 40);
        black_box(sweep(&moved, held).map_or(0, |c| c.len()));
    });

    let fps = |d: Duration, frames: usize| frames as f64 / d.as_secs_f64();
    println!(
        "{RECORDING_FRAMES} frames of {WIDTH}x{HEIGHT} (5 photos), {} held ({} MB, 1 in {}), 6 classes",
        held.len(),
        store.bytes() >> 20,
        store.stride()
    );
    println!(
        "live CMVision, full frame:   {:8.3} ms/frame  {:8.0} frames/s",
        live_frame.as_secs_f64() * 1e3,
        fps(live_frame, 1)
    );
    println!(
        "tune sweep, whole recording: {:8.3} ms/frame  {:8.0} frames/s  ({:.0} ms for the {RECORDING_FRAMES} frames)",
        recording.as_secs_f64() * 1e3 / RECORDING_FRAMES as f64,
        fps(recording, RECORDING_FRAMES),
        recording.as_secs_f64() * 1e3
    );
    println!(
        "holding the recording (decimating {RECORDING_FRAMES} decoded frames): {:.0} ms",
        hold.as_secs_f64() * 1e3
    );
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("tune_sweep: {e}");
            ExitCode::FAILURE
        }
    }
}
