//! Speed of CMVision on 640x480 RGB photos with 6 colour classes, one thread, against the
//! time to read a frame once from memory (the physical floor).
//!
//! Run: `cargo bench -p lewis-services --bench cmvision`. Criterion prints the throughput in
//! elements per second, one element being one frame: frames per second.
//! bench/opencv/bench_cmvision_opencv.py times OpenCV on the same frames and classes.
#![allow(clippy::print_stdout, reason = "a benchmark reports on its terminal")]

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use lewis_services::perception::cmvision::{CmVision, ColorConfig, RgbFrame};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 480;

fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(relative)
}

/// A photo of ../shared/data/images as 640x480 RGB8 (resized with a triangle filter when it
/// has another size: fruits.jpg is 512x480).
fn load_frame(name: &str) -> Vec<u8> {
    let path = repository_path("../shared/data/images").join(name);
    let photo = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (the benchmark reads the shared data)",
                path.display()
            )
        })
        .to_rgb8();
    if photo.dimensions() == (WIDTH, HEIGHT) {
        return photo.into_raw();
    }
    image::imageops::resize(&photo, WIDTH, HEIGHT, image::imageops::FilterType::Triangle).into_raw()
}

/// Where the frames are written as PNG for bench/opencv/bench_cmvision_opencv.py, so that
/// OpenCV is timed on exactly the same pixels.
fn frames_dir() -> PathBuf {
    std::env::temp_dir().join("lewis-cmvision-bench")
}

fn bench(c: &mut Criterion) {
    let colors = repository_path("robots/colors/bench6.txt");
    let config = ColorConfig::load(&colors).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        config.colors.len(),
        6,
        "the benchmark needs 6 colour classes"
    );
    let mut cmv = CmVision::new(&config).unwrap_or_else(|e| panic!("{e}"));
    let frames = [
        ("fruits", load_frame("fruits.jpg")),
        ("stuff", load_frame("stuff.jpg")),
    ];
    let dir = frames_dir();
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for (name, data) in &frames {
        let path = dir.join(format!("{name}.png"));
        image::save_buffer(&path, data, WIDTH, HEIGHT, image::ExtendedColorType::Rgb8)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    println!(
        "frames written to {} for the OpenCV comparison",
        dir.display()
    );

    let mut group = c.benchmark_group("cmvision_640x480_6_colours");
    group.throughput(Throughput::Elements(1));
    for (name, data) in &frames {
        let frame = RgbFrame::new(WIDTH, HEIGHT, data).unwrap_or_else(|e| panic!("{e}"));
        let regions = cmv.process(frame).len();
        println!("{name}: {regions} regions, {} runs", cmv.run_count());
        group.bench_function(*name, |b| b.iter(|| cmv.process(black_box(frame)).len()));
    }
    group.finish();

    let mut floor = c.benchmark_group("read_frame_once_640x480");
    floor.throughput(Throughput::Elements(1));
    let data = &frames[0].1;
    // Every byte read once, eight at a time (a checksum the compiler vectorises).
    floor.bench_function("sum_words", |b| {
        b.iter(|| {
            let (words, _) = black_box(data.as_slice()).as_chunks::<8>();
            words.iter().fold(0u64, |sum, word| {
                sum.wrapping_add(u64::from_ne_bytes(*word))
            })
        });
    });
    let mut copy = vec![0u8; data.len()];
    floor.bench_function("memcpy", |b| {
        b.iter(|| {
            copy.copy_from_slice(black_box(data));
            black_box(&copy);
        });
    });
    floor.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
