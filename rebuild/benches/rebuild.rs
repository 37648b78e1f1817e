//! Map building's pace and memory: `cargo bench -p lewis-rebuild --bench rebuild`.
//!
//! 1. A ten-minute run at a SICK's 37.5 scans a second (361 beams, 8.2 m) through a
//!    100 m x 100 m building of 10 m rooms, made by the simulator's laser with its noise,
//!    the odometry counting 1% too far and turning a degree a minute too much, built at 5 cm: the pace as a multiple of
//!    the run's time, and the process's peak resident memory.
//! 2. The real logs of `../shared/data/`, read and built as `lewis world from` does.
//!
//! Figures, not assertions: README.md has them.

#![allow(
    missing_docs,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stdout
)]

use std::path::Path;
use std::time::Instant;

use lewis_geometry::{Pose2, Vec2};
use lewis_rebuild::build::between;
use lewis_rebuild::run::{PoseSource, Run, RunFormat, Scan};
use lewis_rebuild::{BuildOptions, build, read_run};
use lewis_sim::laser::{LaserConfig, SimLaser};
use lewis_sim::world::{OccupancyGrid, World, WorldLook};

const SIDE_M: f64 = 100.0;
const CELL_M: f64 = 0.05;
const RUN_S: f64 = 600.0;
const RATE_HZ: f64 = 37.5;

/// Walls every 10 m both ways, each with a 2 m door in the middle of every room's side.
fn building() -> World {
    let cells = (SIDE_M / CELL_M) as usize;
    let grid = OccupancyGrid::from_fn(cells, cells, CELL_M, Vec2::new(0.0, 0.0), |c, r| {
        let (x, y) = ((c as f64 + 0.5) * CELL_M, (r as f64 + 0.5) * CELL_M);
        let on_wall = |v: f64| v % 10.0 < 0.15 || v > SIDE_M - 0.15;
        let in_door = |v: f64| (v % 10.0 - 5.0).abs() < 1.0;
        (on_wall(x) && !in_door(y)) || (on_wall(y) && !in_door(x))
    });
    let look = WorldLook {
        wall_height_m: 2.5,
        wall_colour: lewis_sim::world::Rgb::new(200, 200, 200),
        floor_colour: lewis_sim::world::Rgb::new(90, 90, 90),
        ceiling_colour: lewis_sim::world::Rgb::new(170, 170, 170),
    };
    World::new("bench".to_owned(), grid, look, Vec::new())
}

/// Along each row of rooms through their doors, up through a door at the end, and back.
fn pose_at(t_s: f64) -> Pose2 {
    let rows = 10_u32;
    let leg = 90.0;
    let length = f64::from(rows) * leg + f64::from(rows - 1) * 10.0;
    let speed = length / RUN_S;
    let mut s = (t_s * speed).min(length - 1e-6);
    for row in 0..rows {
        let y = 10.0 * f64::from(row) + 5.0;
        let east = row % 2 == 0;
        if s < leg {
            let x = if east { 5.0 + s } else { 95.0 - s };
            return Pose2::new(x, y, if east { 0.0 } else { std::f64::consts::PI });
        }
        s -= leg;
        if s < 10.0 {
            let x = if east { 95.0 } else { 5.0 };
            return Pose2::new(x, y + s, std::f64::consts::FRAC_PI_2);
        }
        s -= 10.0;
    }
    Pose2::new(5.0, 95.0, 0.0)
}

fn synthetic_run() -> Run {
    let world = building();
    let config = LaserConfig::default();
    let mut laser = SimLaser::new(config, 7).unwrap();
    let count = (RUN_S * RATE_HZ) as usize;
    let mut scans = Vec::with_capacity(count);
    let mut odometry = pose_at(0.0);
    let mut previous = odometry;
    for i in 0..count {
        let t = i as f64 / RATE_HZ;
        let truth = pose_at(t);
        let reading = laser.scan(&world, truth);
        // Odometry that counts 1% too far and turns a degree a minute too much.
        let step = between(previous, truth);
        let bias = (1.0 / 60.0 / RATE_HZ).to_radians();
        odometry = odometry.compose(Pose2::new(
            step.x_m * 1.01,
            step.y_m * 1.01,
            step.heading_rad + bias,
        ));
        previous = truth;
        scans.push(Scan {
            time_ns: (t * 1e9) as i64,
            ranges_m: reading.ranges.iter().map(|r| *r as f32).collect(),
            first_bearing_rad: reading.theta_offset,
            step_rad: reading.theta_separation,
            mount_m: Vec2::new(reading.x_offset, reading.y_offset),
            max_range_m: reading.max_range,
            recorded_pose: Some(odometry),
        });
    }
    Run {
        path: "synthetic".into(),
        format: RunFormat::Lewis,
        laser: "/laser/RangeFinder".to_owned(),
        poses: PoseSource::Odometry("drifting".to_owned()),
        scans,
        non_uniform: 0,
    }
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` runs this too, so keep that
    // cheap: the figures only under `cargo bench`.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let run = synthetic_run();
    let started = Instant::now();
    let built = build(&run, &BuildOptions::default(), &mut |_| {}).unwrap();
    let seconds = started.elapsed().as_secs_f64();
    let worst = built
        .placed
        .iter()
        .map(|p| (p.pose.position() - pose_at(p.time_ns as f64 / 1e9).position()).norm())
        .fold(0.0_f64, f64::max);
    println!(
        "synthetic: {} scans of 361 beams over {RUN_S} s in a {SIDE_M} m x {SIDE_M} m building at {CELL_M} m: built in {seconds:.2} s, {:.1}x real time; {} of {} scans matched, worst {:.2} m from the truth; grid {:.1} MiB; peak resident memory {} MiB",
        run.scans.len(),
        RUN_S / seconds,
        built.report.matched,
        run.scans.len() - 1,
        worst,
        built.report.grid_bytes as f64 / 1048576.0,
        lewis_stdx::peak_resident_kib().map_or(0, |k| k / 1024)
    );
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    for log in [
        "carmen/seattle-corrected.log.gz",
        "carmen/edmonton-corrected.log.gz",
        "ros2/hokuyo-scan-matcher-demo.mcap",
    ] {
        let path = data.join(log);
        let started = Instant::now();
        let run = read_run(&path).unwrap();
        let read_s = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let built = build(&run, &BuildOptions::default(), &mut |_| {}).unwrap();
        let build_s = started.elapsed().as_secs_f64();
        println!(
            "{log}: {} scans over {:.0} s: read in {read_s:.2} s, built in {build_s:.3} s ({:.0}x real time, {:.0}x with reading)",
            run.scans.len(),
            run.duration_s(),
            run.duration_s() / build_s,
            run.duration_s() / (build_s + read_s),
        );
        drop(built);
    }
}
