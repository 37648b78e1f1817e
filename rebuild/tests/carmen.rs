//! A world rebuilt from a real CARMEN log (the corrected seattle log of the Radish data
//! sets, in `../shared/data/carmen/`) and checked on the scans it was not built from.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use lewis_rebuild::{BuildOptions, build, check, read_run, world_dir};

fn log(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/carmen")
        .join(name);
    assert!(
        path.is_file(),
        "{} is missing: the real CARMEN logs live in ../shared/data/carmen (see its README)",
        path.display()
    );
    path
}

#[test]
fn a_world_rebuilt_from_the_seattle_log_makes_held_out_scans_again_within_the_goal() {
    let run = read_run(&log("seattle-corrected.log.gz")).unwrap();
    assert_eq!(run.scans.len(), 241);
    let options = BuildOptions {
        hold_out: true,
        ..BuildOptions::default()
    };
    let built = build(&run, &options, &mut |_| {}).unwrap();
    assert!(
        built.report.matched * 10 >= built.report.scans * 9,
        "{:?}",
        built.report
    );
    let dir = tempfile::tempdir().unwrap();
    let world = dir.path().join("seattle");
    world_dir::write(&world, &run, &built).unwrap();
    // The simulator loads it as any world, and the stdx header agrees on it.
    lewis_sim::world::World::load(&world).unwrap();
    let header = lewis_stdx::world::read_world_header(&world).unwrap();
    assert!((header.metres_per_pixel - 0.05).abs() < 1e-12);
    let (report, _) = check(&run, &world, 10).unwrap();
    let held_out = report.held_out.expect("held-out scans");
    assert!(held_out.meets_goal(), "{held_out:?}");
    assert!(held_out.beams > 30_000, "{held_out:?}");
    assert!(report.used.meets_goal(), "{:?}", report.used);
}

#[test]
fn a_log_too_short_to_map_is_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let short = dir.path().join("short.log");
    let line = |x: f64| {
        format!(
            "FLASER 181 {} {x} 0 0 {x} 0 0 {} host {}\n",
            vec!["2.0"; 181].join(" "),
            x + 1.0,
            x + 1.0
        )
    };
    let text: String = (0..3).map(|i| line(f64::from(i))).collect();
    std::fs::write(&short, text).unwrap();
    let error = read_run(&short).unwrap_err().to_string();
    assert!(error.contains("short.log"), "{error}");
    assert!(error.contains("too few to map"), "{error}");
}

#[test]
fn a_recording_without_a_laser_is_refused_naming_the_file() {
    let bag = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/ros2/husky-outdoor-imu-odom-gps.mcap");
    assert!(bag.is_file(), "{} is missing", bag.display());
    let error = read_run(&bag).unwrap_err().to_string();
    assert!(error.contains("husky-outdoor-imu-odom-gps.mcap"), "{error}");
    assert!(error.contains("no laser"), "{error}");
}

#[test]
fn a_run_whose_odometry_disagrees_with_its_scans_is_refused_rather_than_mapped() {
    let mut run = read_run(&log("seattle-corrected.log.gz")).unwrap();
    // Odometry that jumps metres and turns a radian between scans: nothing the scans saw.
    for (i, scan) in run.scans.iter_mut().enumerate() {
        let i = i as f64;
        scan.recorded_pose = Some(lewis_geometry::Pose2::new(
            (i * 7.3) % 50.0,
            (i * 3.1) % 40.0,
            (i * 1.3) % 6.0,
        ));
    }
    let error = build(&run, &BuildOptions::default(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(error.contains("seattle-corrected.log.gz"), "{error}");
    assert!(error.contains("does not agree with the scans"), "{error}");
    assert!(error.contains("none is written"), "{error}");
}

#[test]
fn a_run_whose_poses_span_kilometres_is_refused_rather_than_filling_the_memory() {
    let mut run = read_run(&log("seattle-corrected.log.gz")).unwrap();
    if let Some(last) = run.scans.last_mut() {
        last.recorded_pose = Some(lewis_geometry::Pose2::new(5000.0, -3000.0, 0.0));
    }
    let options = BuildOptions {
        match_scans: false,
        ..BuildOptions::default()
    };
    let error = build(&run, &options, &mut |_| {}).unwrap_err().to_string();
    assert!(
        error.contains("seattle-corrected.log.gz: at scan 240"),
        "{error}"
    );
    assert!(error.contains("--metres-per-pixel"), "{error}");
}
