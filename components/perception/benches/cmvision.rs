//! CMVision against OpenCV, side by side in one run: the same 640x480 RGB frames, the same six
//! colour classes (robots/colors/bench6.txt), one thread each, each side timed the same way
//! (the median of single-frame runs). Also the frame time as a multiple of the time to read
//! the frame once from memory (the physical floor), and a check that both sides find the same
//! regions: per colour, CMVision's region count (minimum area 1, no density merging) must
//! equal the number of 4-connected components OpenCV finds in the colour's mask.
//!
//! Run: `scripts/bench-cmvision.sh` (it makes the Python environment with OpenCV, then runs
//! `cargo bench --bench cmvision`). The OpenCV side is tools/opencv/bench_cmvision_opencv.py,
//! run with the Python of `LEWIS_OPENCV_PYTHON` (default `.venv-bench/bin/python`) on the
//! frames this benchmark writes. Exits 1 when the region counts differ or OpenCV cannot run.
#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a benchmark reports on its terminal"
)]

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use lewis_perception::cmvision::{CmVision, ColorConfig, RgbFrame};

mod common;
use common::{HEIGHT, WIDTH, load_frame, repository_path};

/// Timed single-frame runs per frame and side.
const REPETITIONS: usize = 500;

/// The median and the minimum of `REPETITIONS` timed runs of `run`, after a warm-up.
fn time(mut run: impl FnMut()) -> (Duration, Duration) {
    for _ in 0..20 {
        run();
    }
    let mut times: Vec<Duration> = (0..REPETITIONS)
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed()
        })
        .collect();
    times.sort_unstable();
    (times[times.len() / 2], times[0])
}

/// One frame's figures on the CMVision side.
struct Measured {
    name: &'static str,
    median: Duration,
    min: Duration,
    read_once: Duration,
    regions_per_colour: Vec<(String, usize)>,
}

fn measure(cmv: &mut CmVision, name: &'static str, data: &[u8]) -> Result<Measured, String> {
    let frame = RgbFrame::new(WIDTH, HEIGHT, data).map_err(|e| e.to_string())?;
    cmv.process(frame);
    let regions_per_colour = (0..=u8::MAX)
        .zip(cmv.colors())
        .map(|(id, class)| (class.name.clone(), cmv.regions_of_color(id).len()))
        .collect();
    let (median, min) = time(|| {
        black_box(cmv.process(black_box(frame)).len());
    });
    // Every byte read once, eight at a time (a checksum the compiler vectorises).
    let (read_once, _) = time(|| {
        let (words, _) = black_box(data).as_chunks::<8>();
        black_box(words.iter().fold(0u64, |sum, word| {
            sum.wrapping_add(u64::from_ne_bytes(*word))
        }));
    });
    Ok(Measured {
        name,
        median,
        min,
        read_once,
        regions_per_colour,
    })
}

/// Runs the OpenCV side on the frames in `dir`; its JSON report.
fn opencv(dir: &Path, names: &[&str]) -> Result<serde_json::Value, String> {
    let python = std::env::var_os("LEWIS_OPENCV_PYTHON")
        .map_or_else(|| repository_path(".venv-bench/bin/python"), PathBuf::from);
    let script = repository_path("tools/opencv/bench_cmvision_opencv.py");
    let output = Command::new(&python)
        .arg(&script)
        .arg("--json")
        .arg("--frames-dir")
        .arg(dir)
        .arg("--frames")
        .args(names)
        .args(["--repetitions", &REPETITIONS.to_string()])
        .arg("--colors")
        .arg(repository_path("robots/colors/bench6.txt"))
        .output()
        .map_err(|e| {
            format!(
                "cannot run {}: {e}: run scripts/bench-cmvision.sh, which makes it, or set LEWIS_OPENCV_PYTHON",
                python.display()
            )
        })?;
    if !output.status.success() {
        return Err(format!(
            "{} {} failed ({}): {}",
            python.display(),
            script.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    serde_json::from_slice(&output.stdout)
        .map_err(|e| format!("the OpenCV report is not JSON: {e}"))
}

fn fps(time: Duration) -> f64 {
    1.0 / time.as_secs_f64()
}

fn run() -> Result<bool, String> {
    let config = ColorConfig::load(&repository_path("robots/colors/bench6.txt"))
        .map_err(|e| e.to_string())?;
    if config.colors.len() != 6 || config.min_area_px != 1 {
        return Err("robots/colors/bench6.txt must have 6 classes and no minimum area".into());
    }
    let mut cmv = CmVision::new(&config).map_err(|e| e.to_string())?;
    let dir = std::env::temp_dir().join(format!("lewis-cmvision-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut measured = Vec::new();
    for (name, file) in [("fruits", "fruits.jpg"), ("stuff", "stuff.jpg")] {
        let data = load_frame(file)?;
        let path = dir.join(format!("{name}.png"));
        image::save_buffer(&path, &data, WIDTH, HEIGHT, image::ExtendedColorType::Rgb8)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        measured.push(measure(&mut cmv, name, &data)?);
    }
    let names: Vec<&str> = measured.iter().map(|m| m.name).collect();
    let report = opencv(&dir, &names);
    let _ = std::fs::remove_dir_all(&dir);
    let report = report?;

    println!(
        "CMVision vs OpenCV {} ({} thread), 640x480 RGB, 6 colour classes, median of {REPETITIONS} single frames",
        report["opencv_version"].as_str().unwrap_or("?"),
        report["threads"]
    );
    println!(
        "| frame | regions | CMVision | OpenCV | CMVision / OpenCV | frame time / one read of the frame |"
    );
    println!("|---|---|---|---|---|---|");
    let mut same = true;
    for m in &measured {
        let theirs = &report["frames"][m.name];
        let their_fps = theirs["fps_median"].as_f64().unwrap_or(f64::NAN);
        let mut differences = Vec::new();
        for (colour, count) in &m.regions_per_colour {
            let their_count = theirs["regions_per_colour"][colour.as_str()].as_u64();
            if their_count != Some(*count as u64) {
                differences.push(format!("{colour}: {count} vs {their_count:?}"));
            }
        }
        let off = theirs["pixels_classified_differently_from_exact_formula"]
            .as_u64()
            .unwrap_or(u64::MAX);
        if off != 0 {
            differences.push(format!("{off} pixels classified differently"));
        }
        let total: usize = m.regions_per_colour.iter().map(|(_, n)| n).sum();
        let regions = if differences.is_empty() {
            format!("{total}, the same per colour")
        } else {
            same = false;
            format!("DIFFERENT: {}", differences.join(", "))
        };
        println!(
            "| {} | {regions} | {:.0} frames/s ({:.3} ms, min {:.3} ms) | {:.0} frames/s ({:.3} ms) | {:.1}x | {:.0}x ({:.1} µs) |",
            m.name,
            fps(m.median),
            m.median.as_secs_f64() * 1e3,
            m.min.as_secs_f64() * 1e3,
            their_fps,
            1e3 / their_fps,
            fps(m.median) / their_fps,
            m.median.as_secs_f64() / m.read_once.as_secs_f64(),
            m.read_once.as_secs_f64() * 1e6,
        );
        let goals = [
            (fps(m.median) >= 1000.0, "at least 1000 frames/s"),
            (fps(m.median) >= 3.0 * their_fps, "at least 3x OpenCV"),
        ];
        for (met, goal) in goals {
            if !met {
                println!("  {}: goal not met: {goal}", m.name);
            }
        }
    }
    Ok(same)
}

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => {
            eprintln!("CMVision and OpenCV found different regions");
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
