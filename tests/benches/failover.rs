//! Failover latency, end to end with real processes: the time from the last laser sample
//! to the first sonar sample at an application bound to RangeFinder, when the laser
//! stalls (missed heartbeats, 50 ms deadline) and when it crashes beyond its restart limit
//! (it aborts at once after each restart). Both with the sonar started on demand and as a
//! hot standby.
//!
//! `cargo bench -p lewis-tests --bench failover` (`-- --trials N`, default 10).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

use std::time::{Duration, Instant};

use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::client::Client;
use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{Up, open_ipc};

/// How long a trial may take before it is reported as failed.
const WATCHDOG: Duration = Duration::from_secs(20);

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let trials = args
        .iter()
        .position(|a| a == "--trials")
        .and_then(|i| args.get(i + 1))
        .and_then(|n| n.parse().ok())
        .unwrap_or(10_usize);
    println!("failover latency, last laser sample -> first sonar sample, {trials} trials each");
    println!(
        "{:<10} {:<10} {:>9} {:>9} {:>9}",
        "fault", "sonar", "p50 ms", "p90 ms", "max ms"
    );
    for fault in ["stall", "crash"] {
        for sonar_start in ["on-demand", "standby"] {
            let mut samples: Vec<f64> = (0..trials)
                .map(|i| trial(fault, sonar_start, i).as_secs_f64() * 1e3)
                .collect();
            samples.sort_by(f64::total_cmp);
            println!(
                "{fault:<10} {sonar_start:<10} {:>9.1} {:>9.1} {:>9.1}",
                percentile(&samples, 0.5),
                percentile(&samples, 0.9),
                samples.last().copied().unwrap_or(f64::NAN),
            );
        }
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    // Nearest rank.
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// One `lewis up`, one application; the fault is injected once the application receives
/// laser data, and the gap is measured at the application.
fn trial(fault: &str, sonar_start: &str, index: usize) -> Duration {
    let dir = tempfile::tempdir().unwrap();
    let fault_file = dir.path().join("laser.fault");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault_file),
        sonar_start,
        heartbeat_deadline_ms: 50,
        rate_hz: 100.0,
        ..TestRobot::default()
    });
    let namespace =
        lewis_runtime::ipc::Namespace::unique(&format!("bench-{fault}-{sonar_start}-{index}"));
    let mut up = Up::start_in(dir, namespace, &robot);
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "bench-app");
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    let deadline = Instant::now() + WATCHDOG;
    let mut laser_samples = 0;
    let mut last_laser = None;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(
            !left.is_zero(),
            "{fault}/{sonar_start}: no failover in time"
        );
        let Some(sample) = client.recv_timeout(left).unwrap() else {
            continue;
        };
        let now = Instant::now();
        match sample.message.header.provider.as_str() {
            "laser" => {
                laser_samples += 1;
                last_laser = Some(now);
                // Some samples first, so the system is in its steady state.
                if laser_samples == 20 {
                    set_fault(&fault_file, fault);
                }
            }
            "sonar" if laser_samples >= 20 => {
                let gap = now - last_laser.expect("laser samples came first");
                up.stop();
                return gap;
            }
            _ => {}
        }
    }
}
