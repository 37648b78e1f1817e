//! Failover latency, end to end with real processes: the time from the last laser sample
//! to the first sonar sample at an application bound to RangeFinder, measured at the
//! application, with the sonar started on demand and as a hot standby:
//!
//! - **stall**: the laser stops (no data, no heartbeat; the shipped robots' 100 ms
//!   heartbeat deadline, with heartbeats every 10 ms);
//! - **crash**: the laser aborts with no restart left (the crash beyond its limit);
//! - **crash loop**: the laser aborts, and again at once after each of its 2 restarts
//!   (backoff 20 ms then 40 ms), until it is beyond its limit: the whole episode;
//! - **garbage**, **frozen**, **slow**: the laser keeps running but publishes NaN ranges,
//!   the same scan again and again, or at a third of its rate; the broker's data checks
//!   (on for these) fail it; the gap runs from the last good sample.
//!
//! Each trial also splits the gap in two: until the broker's rebind decision (detection and
//! decision), and from it to the first sonar sample (starting the sonar if needed, the
//! client's switch of subscription, the sonar's first scan). Times across processes are
//! each process's clock; the split is good to a fraction of a millisecond.
//!
//! `cargo bench --workspace --bench failover` (`-- --trials N`, default 10; `-- --stress`
//! runs `stress-ng --cpu 2` beside it all, so that every core is busy with other work;
//! `-- --deadline-ms N` sets another heartbeat deadline).

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::print_stdout,
    clippy::cast_precision_loss,
    clippy::cast_possible_truncation,
    clippy::cast_sign_loss
)]

use std::time::{Duration, Instant};

use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::client::Client;
use lewis_runtime::clock::LiveClock;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{Up, open_ipc};

/// How long a trial may take before it is reported as failed.
const WATCHDOG: Duration = Duration::from_secs(20);

/// How long the application waits for a sample before it looks at the broker's decisions.
const SLICE: Duration = Duration::from_millis(100);

/// One kind of failure.
#[derive(Clone, Copy)]
struct Scenario {
    name: &'static str,
    fault: &'static str,
    laser_max_restarts: u32,
    /// Whether the broker checks the data (`[broker] data_checks`).
    data_checks: bool,
}

const SCENARIOS: [Scenario; 6] = [
    Scenario {
        name: "stall",
        fault: "stall",
        laser_max_restarts: 2,
        data_checks: false,
    },
    Scenario {
        name: "crash",
        fault: "crash",
        laser_max_restarts: 0,
        data_checks: false,
    },
    Scenario {
        name: "crash loop",
        fault: "crash",
        laser_max_restarts: 2,
        data_checks: false,
    },
    Scenario {
        name: "garbage",
        fault: "garbage",
        laser_max_restarts: 2,
        data_checks: true,
    },
    Scenario {
        name: "frozen",
        fault: "frozen",
        laser_max_restarts: 2,
        data_checks: true,
    },
    Scenario {
        name: "slow",
        fault: "slow",
        laser_max_restarts: 2,
        data_checks: true,
    },
];

/// What one trial measured, in milliseconds.
struct Trial {
    gap_ms: f64,
    to_decision_ms: f64,
    after_decision_ms: f64,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let trials = number_after(&args, "--trials").unwrap_or(10_usize);
    let deadline_ms = number_after(&args, "--deadline-ms").unwrap_or(SHIPPED_DEADLINE_MS);
    let stress = args
        .iter()
        .any(|a| a == "--stress")
        .then(|| lewis_tests::stress::Stress::cpus(2));
    println!(
        "failover latency, last laser sample -> first sonar sample at the application, \
         {trials} trials each, {deadline_ms} ms heartbeat deadline, milliseconds{}",
        if stress.is_some() {
            ", beside stress-ng --cpu 2"
        } else {
            ""
        }
    );
    println!(
        "{:<11} {:<10} | {:>7} {:>7} {:>7} | {:>16} {:>16} | failed",
        "fault", "sonar", "p50", "p90", "max", "to decision p50", "after it p50"
    );
    for scenario in SCENARIOS {
        for sonar_start in ["on-demand", "standby"] {
            let mut runs = Vec::new();
            let mut failed = 0;
            for i in 0..trials {
                match trial(scenario, sonar_start, deadline_ms, i) {
                    Ok(run) => runs.push(run),
                    Err(why) => {
                        failed += 1;
                        println!(
                            "  ({}/{sonar_start} trial {i} failed: {why})",
                            scenario.name
                        );
                    }
                }
            }
            let column = |f: fn(&Trial) -> f64| {
                let mut v: Vec<f64> = runs.iter().map(f).collect();
                v.sort_by(f64::total_cmp);
                v
            };
            let gaps = column(|t| t.gap_ms);
            println!(
                "{:<11} {sonar_start:<10} | {:>7.1} {:>7.1} {:>7.1} | {:>16.1} {:>16.1} | {failed}",
                scenario.name,
                percentile(&gaps, 0.5),
                percentile(&gaps, 0.9),
                gaps.last().copied().unwrap_or(f64::NAN),
                percentile(&column(|t| t.to_decision_ms), 0.5),
                percentile(&column(|t| t.after_decision_ms), 0.5),
            );
        }
    }
}

/// The number given after `flag` on the command line, if any.
fn number_after<T: std::str::FromStr>(args: &[String], flag: &str) -> Option<T> {
    args.iter()
        .position(|a| a == flag)
        .and_then(|i| args.get(i + 1))
        .and_then(|n| n.parse().ok())
}

/// The heartbeat deadline of the shipped robots (`robots/sim.toml`, `robots/b21r.toml`).
const SHIPPED_DEADLINE_MS: u64 = 100;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    // Nearest rank.
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// One `lewis up`, one application; the fault is injected once the application receives
/// laser data, and the gap is measured at the application. A trial fails (and is counted,
/// not measured) when no sonar sample comes in time, or when the broker gives up the sonar
/// too: on a loaded machine a fresh sonar could miss a short heartbeat deadline.
fn trial(
    scenario: Scenario,
    sonar_start: &str,
    deadline_ms: u64,
    index: usize,
) -> Result<Trial, String> {
    let dir = tempfile::tempdir().unwrap();
    let fault_file = dir.path().join("laser.fault");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault_file),
        sonar_start,
        heartbeat_deadline_ms: deadline_ms,
        laser_max_restarts: scenario.laser_max_restarts,
        rate_hz: 100.0,
        data_checks: scenario.data_checks,
        declare_rate: scenario.data_checks,
        ..TestRobot::default()
    });
    let namespace = lewis_runtime::ipc::Namespace::unique(&format!(
        "bench-{}-{sonar_start}-{index}",
        scenario.fault
    ));
    let mut up = Up::start_with(dir, namespace, &robot, &["--no-record".as_ref()]);
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "bench-app");
    let clock = LiveClock::new();
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    let deadline = Instant::now() + WATCHDOG;
    let mut laser_samples = 0;
    let mut last_laser = None;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            up.stop();
            return Err(format!("no sonar sample within {WATCHDOG:?}"));
        }
        // In slices, to look at the broker's decisions between them: a trial whose sonar
        // is given up too ends at once.
        let Some(sample) = client.recv_timeout(left.min(SLICE)).unwrap() else {
            decisions.take();
            if let Some(gone) = decisions
                .seen
                .iter()
                .find(|d| d.action == "service-failed" && d.service == "sonar")
            {
                let why = format!("the sonar failed too: {}", gone.reason);
                up.stop();
                return Err(why);
            }
            continue;
        };
        let now = Instant::now();
        match sample.message.header.provider.as_str() {
            "laser" => {
                laser_samples += 1;
                // Bad data still comes from the laser: the gap runs from its last good
                // sample, the one before the fault.
                if laser_samples <= 20 || !scenario.data_checks {
                    last_laser = Some(now);
                }
                // Some samples first, so the system is in its steady state.
                if laser_samples == 20 {
                    set_fault(&fault_file, scenario.fault);
                }
            }
            "sonar" if laser_samples >= 20 => {
                let last = last_laser.expect("laser samples came first");
                let rebind =
                    decisions.wait_for("the rebind", |d| d.action == "rebind" && d.client == "app");
                let decided = clock.to_instant(rebind.at_ns);
                up.stop();
                let ms = |d: Duration| d.as_secs_f64() * 1e3;
                return Ok(Trial {
                    gap_ms: ms(now - last),
                    to_decision_ms: ms(decided.saturating_duration_since(last)),
                    after_decision_ms: ms(now.saturating_duration_since(decided)),
                });
            }
            _ => {}
        }
    }
}
