//! A fault sweep of real replays: the same sweep on one thread and on two, to the byte.
//!
//! The open-loop replay of the reference recording stands in for the closed loop (which
//! `lewis replay --all` adds): a point "succeeds" when the broker moved a client to
//! another provider, and has no time to finish. What is checked is the sweep's machinery
//! with replays that really run side by side: the fault times printed in the table read
//! back as fault SPECs, each job writes its own output, and the order of the results does
//! not depend on which replay ends first.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use lewis_replay::fault::{FaultKind, FaultSpec, format_seconds};
use lewis_replay::report::Report;
use lewis_replay::resim::{ReplayOptions, replay};
use lewis_replay::sweep::{FailedPoint, Sweep, SweepPoint, fault_times, run_jobs};

use crate::same_bytes::robot_with_absolute_world;

fn recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/reference/sim-goal.mcap")
}

fn replay_with(faults: &[String], output: PathBuf, robot: &Path) -> Result<Report, String> {
    let mut options = ReplayOptions::new(vec![recording()]);
    options.output = Some(output);
    options.robot = Some(robot.to_path_buf());
    options.faults = faults
        .iter()
        .map(|f| f.parse::<FaultSpec>())
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    replay(&options, &lewis_kinds::registry(), &mut |_| {}).map_err(|e| e.to_string())
}

fn sweep(jobs: usize, duration_ns: i64, dir: &Path, robot: &Path) -> Sweep {
    let times = fault_times(0, duration_ns, 3);
    assert_eq!(times.len(), 3);
    let results = run_jobs(&times, jobs, |index, at_ns| {
        // As a person would type the time printed in the table.
        let spec = format!("laser@{}:crash", format_seconds(at_ns));
        let output = dir.join(format!("jobs{jobs}-{index}.mcap"));
        replay_with(&[spec], output, robot).map(|report| {
            let fault = &report.faults[0];
            assert_eq!(fault.at_ns, at_ns, "{}", fault.spec);
            SweepPoint {
                fault_at_ns: at_ns,
                succeeded: !fault.takeovers.is_empty(),
                time_to_finish_ns: None,
                longest_blind_ns: report.longest_gap.as_ref().map(|g| g.gap_ns),
                longest_blind: report
                    .longest_gap
                    .as_ref()
                    .map(|g| format!("{} had no {}", g.client, g.interface)),
                state_at_fault: None,
                reason: fault
                    .reactions
                    .iter()
                    .map(|r| r.action.clone())
                    .collect::<Vec<_>>()
                    .join(", "),
                answer_sources: Vec::new(),
            }
        })
    });
    let mut points = Vec::new();
    let mut failed_points = Vec::new();
    for (result, &at_ns) in results.into_iter().zip(&times) {
        match result {
            Ok(point) => points.push(point),
            Err(error) => failed_points.push(FailedPoint {
                fault_at_ns: at_ns,
                error,
            }),
        }
    }
    Sweep {
        recording: "tests/data/reference/sim-goal.mcap".to_owned(),
        providers: vec!["laser".to_owned()],
        kind: FaultKind::Crash,
        steps: 3,
        duration_ns,
        recorded_succeeded: None,
        recorded_time_to_finish_ns: None,
        points,
        failed_points,
    }
}

#[test]
fn a_sweep_of_real_replays_is_the_same_on_one_thread_and_on_two() {
    let dir = tempfile::tempdir().unwrap();
    let robot = robot_with_absolute_world(dir.path());
    let baseline = replay_with(&[], dir.path().join("baseline.mcap"), &robot).unwrap();
    let alone = sweep(1, baseline.duration_ns, dir.path(), &robot);
    assert!(alone.failed_points.is_empty(), "{alone}");
    assert_eq!(alone.points.len(), 3, "{alone}");
    assert!(alone.points.iter().any(|p| p.succeeded), "{alone}");
    let two = sweep(2, baseline.duration_ns, dir.path(), &robot);
    assert_eq!(alone.to_json(), two.to_json());
    assert_eq!(alone.to_string(), two.to_string());

    let (png_alone, png_two) = (dir.path().join("alone.png"), dir.path().join("two.png"));
    alone.write_png(&png_alone).unwrap();
    two.write_png(&png_two).unwrap();
    let bytes = std::fs::read(&png_alone).unwrap();
    assert!(bytes == std::fs::read(&png_two).unwrap(), "the PNGs differ");
    assert!(bytes.len() < 200_000, "{} bytes", bytes.len());
}
