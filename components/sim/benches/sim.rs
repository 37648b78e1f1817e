//! Speed of the simulated B21r in the conference world, one thread: a laser scan (361
//! beams), a sonar ring scan (48 transducers x 7 rays), a camera frame (640x480), a base
//! step, and every device at its real rate for two simulated seconds.
//!
//! Run: `cargo bench -p lewis-kinds --bench sim`.
//!
//! Real rates: base 50 Hz (20 ms steps); laser 37.5 Hz (a SICK LMS200 at 0.5 degree in mm
//! mode streaming at 500 kbaud, limited by the scanner's interlaced 75 Hz sweeps; at 38400
//! baud it would be about 5 Hz); sonar ring 10 Hz; camera 30 Hz; Distance from the laser and
//! the sonar at their rates. The `all_devices` group reports elements per second with one
//! element per simulated second: that is how many times faster than real time one core runs
//! the whole robot; its inverse is the share of one core the robot needs at real time.
#![allow(
    clippy::unwrap_used,
    reason = "the benchmark's fixed parameters are valid; a failure should stop it loudly"
)]

use std::f64::consts::PI;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use lewis_geometry::Pose2;
use lewis_sim::{
    BaseConfig, CameraConfig, LaserConfig, SimBase, SimCamera, SimLaser, SimSonar, SonarConfig,
    World,
};

fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(relative)
}

fn world() -> World {
    let dir = repository_path("robots/worlds/conference");
    World::load(&dir).unwrap_or_else(|e| panic!("{e}"))
}

/// A pose in the corridor, looking along it: long rays, many cells crossed.
const CORRIDOR: Pose2 = Pose2::new(10.0, 12.5, 0.0);

fn per_frame(c: &mut Criterion) {
    let world = world();
    let mut group = c.benchmark_group("sim_frame");
    group.throughput(Throughput::Elements(1));
    let mut laser = SimLaser::new(LaserConfig::default(), 1).unwrap();
    group.bench_function("laser_361_beams", |b| {
        b.iter(|| black_box(laser.scan(&world, black_box(CORRIDOR))));
    });
    let mut sonar = SimSonar::new(SonarConfig::default(), 1).unwrap();
    group.bench_function("sonar_48_transducers", |b| {
        b.iter(|| black_box(sonar.scan(&world, black_box(CORRIDOR))));
    });
    let mut camera = SimCamera::new(CameraConfig::default(), 1).unwrap();
    let mut rgb = vec![0; camera.frame_len()];
    group.bench_function("camera_640x480", |b| {
        b.iter(|| {
            camera.render_into(&world, black_box(CORRIDOR), &mut rgb);
            black_box(&rgb);
        });
    });
    let mut base = SimBase::new(BaseConfig::default(), CORRIDOR, 1).unwrap();
    base.set_velocity(0.0, 0.5);
    group.bench_function("base_step_20ms", |b| {
        b.iter(|| {
            base.step(&world, 20_000_000);
            black_box(base.egomotion());
        });
    });
    group.finish();
}

/// The simulated robot: every device, at the corridor's west end.
struct Robot {
    base: SimBase,
    laser: SimLaser,
    sonar: SimSonar,
    camera: SimCamera,
}

fn robot(seed: u64) -> Robot {
    Robot {
        base: SimBase::new(BaseConfig::default(), Pose2::new(9.0, 12.5, 0.0), seed).unwrap(),
        laser: SimLaser::new(LaserConfig::default(), seed).unwrap(),
        sonar: SimSonar::new(SonarConfig::default(), seed).unwrap(),
        camera: SimCamera::new(CameraConfig::default(), seed).unwrap(),
    }
}

/// Every device at its real rate for `seconds` simulated seconds, the robot driving down the
/// corridor and weaving.
fn simulate(world: &World, seconds: i64, robot: &mut Robot, rgb: &mut [u8]) {
    const NS: i64 = 1_000_000_000;
    let Robot {
        base,
        laser,
        sonar,
        camera,
    } = robot;
    // Periods in ns: base 50 Hz, laser 37.5 Hz, sonar 10 Hz, camera 30 Hz.
    let periods = [NS / 50, NS * 2 / 75, NS / 10, NS / 30];
    let mut next = [0i64; 4];
    let end = seconds * NS;
    let mut now = 0;
    while now < end {
        if now >= next[0] {
            let t = now as f64 * 1e-9;
            base.set_velocity(0.8, 0.3 * (t * PI / 2.0).sin());
            base.step(world, periods[0]);
            black_box(base.egomotion());
            black_box(base.synchrodrive());
            black_box(base.power());
            next[0] += periods[0];
        }
        let pose = base.true_pose();
        if now >= next[1] {
            let scan = laser.scan(world, pose);
            black_box(laser.distance(&scan, 36));
            next[1] += periods[1];
        }
        if now >= next[2] {
            let scan = sonar.scan(world, pose);
            black_box(SimSonar::distance(&scan, 36));
            next[2] += periods[2];
        }
        if now >= next[3] {
            camera.render_into(world, pose, rgb);
            black_box(&rgb);
            next[3] += periods[3];
        }
        now = *next.iter().min().unwrap_or(&end);
    }
}

fn all_devices(c: &mut Criterion) {
    let world = world();
    let mut rgb = vec![0; robot(1).camera.frame_len()];
    let mut group = c.benchmark_group("sim_all_devices");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    // One element is one simulated second: elements per second is the real-time factor.
    group.throughput(Throughput::Elements(2));
    group.bench_function("two_simulated_seconds_at_real_rates", |b| {
        b.iter_batched(
            || robot(1),
            |mut robot| simulate(&world, 2, &mut robot, &mut rgb),
            BatchSize::LargeInput,
        );
    });
    group.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .sample_size(30)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
}

criterion_group! {
    name = benches;
    config = config();
    targets = per_frame, all_devices
}
criterion_main!(benches);
