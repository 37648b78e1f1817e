//! CDR encode and decode against a plain `memcpy` of the same number of bytes, for a
//! 361-beam RangeFinder scan and a 640x480 RGB ImageSource frame.
//!
//! `cargo bench -p lewis-interfaces --bench cdr`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Header, ImageSource, InputRef, Pose3D, RangeFinder};

fn header() -> Header {
    Header {
        provider: "laser".to_owned(),
        seq: 1234,
        publish_time_ns: 1_700_000_000_000_000_000,
        inputs: vec![InputRef {
            channel: "/laser/RangeFinder".to_owned(),
            seq: 1233,
        }],
    }
}

fn scan() -> RangeFinder {
    let n = 361;
    RangeFinder {
        header: header(),
        range_count: n,
        ranges: (0..n).map(|i| 0.5 + f64::from(i) * 0.01).collect(),
        max_range: 8.191,
        uniform: true,
        sensor_positions: vec![Pose3D::default(); n as usize],
        theta_offset: -std::f64::consts::FRAC_PI_2,
        theta_separation: std::f64::consts::PI / 360.0,
        ..Default::default()
    }
}

fn frame() -> ImageSource {
    let (width, height) = (640, 480);
    ImageSource {
        header: header(),
        width,
        height,
        encoding: "rgb8".to_owned(),
        step: width * 3,
        data: (0..width * height * 3).map(|i| (i % 251) as u8).collect(),
        focal_length_x: 525.0,
        focal_length_y: 525.0,
        principal_point_x: 320.0,
        principal_point_y: 240.0,
    }
}

fn bench_message<T>(c: &mut Criterion, name: &str, message: &T)
where
    T: lewis_interfaces::Struct,
{
    let bytes = cdr::to_vec(message);
    let len = bytes.len();
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Bytes(len as u64));

    let source = bytes.clone();
    let mut target = vec![0u8; len];
    group.bench_function(BenchmarkId::new("memcpy (baseline)", len), |b| {
        b.iter(|| {
            target.copy_from_slice(black_box(&source));
            black_box(&target);
        });
    });

    let mut slice = vec![0u8; len];
    group.bench_function(BenchmarkId::new("encode_into slice", len), |b| {
        b.iter(|| {
            let n = cdr::encode_into(black_box(message), &mut slice).unwrap_or(0);
            black_box(n);
        });
    });

    let mut reused = Vec::with_capacity(len);
    group.bench_function(BenchmarkId::new("encode_to_vec (reused)", len), |b| {
        b.iter(|| {
            cdr::encode_to_vec(black_box(message), &mut reused);
            black_box(&reused);
        });
    });

    group.bench_function(BenchmarkId::new("decode", len), |b| {
        b.iter(|| {
            let decoded: Result<T, _> = cdr::from_bytes(black_box(&bytes));
            black_box(decoded.ok());
        });
    });

    group.bench_function(BenchmarkId::new("view (read in place)", len), |b| {
        b.iter(|| {
            let view = T::view(black_box(&bytes));
            black_box(view.is_ok());
        });
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_message(c, "cdr/RangeFinder 361 beams", &scan());
    bench_message(c, "cdr/ImageSource 640x480 rgb8", &frame());
}

criterion_group!(cdr_benches, benches);
criterion_main!(cdr_benches);
