//! The fault sweep (`lewis replay RUN.mcap --all --sweep-fault laser --steps 20`): the
//! same fault injected at many times across a run, one closed-loop replay per time, and
//! what became of the mission at each.
//!
//! This module owns the sweep's arithmetic ([`fault_times`]), its jobs ([`run_jobs`]: the
//! replays on worker threads, results in the order of the times) and its outputs: the
//! [`Sweep`] as a table for people (`Display`), as JSON ([`Sweep::to_json`]) and as a PNG
//! plot ([`Sweep::write_png`]). It does not run a replay: the caller's closure does, and
//! turns each replay's mission verdict into a [`SweepPoint`]. Times are in nanoseconds
//! from the start of the recording.

mod jobs;
mod plot;
mod run;
mod table;

use std::path::PathBuf;

use serde::Serialize;

use crate::fault::FaultKind;

pub use jobs::run_jobs;
pub use run::{SweepRunError, SweepSpec, sweep, sweep_point};

/// A fault time is a whole number of these from the start when the run is long enough,
/// so that the time printed in the table (to the millisecond) can be typed back as
/// `--inject-fault laser@T` and gives the same replay.
const QUANTUM_NS: i64 = 1_000_000;

/// `steps` fault times spread evenly across the run from `start_ns` to `end_ns`: the
/// middles of `steps` equal slices of it, in order, none at its very start or end.
///
/// Each time is rounded to a whole millisecond from `start_ns` when every slice is at
/// least 2 ms long (the rounded middle stays inside its slice), so the times print exactly
/// as [`format_seconds`](crate::fault::format_seconds) writes them. On a run shorter than
/// that the times are whole nanoseconds, and only a run shorter than `2 × steps` ns can
/// give fewer than `steps` times (never two the same).
///
/// Returns an empty list for 0 steps or an empty run (`end_ns <= start_ns`): the caller
/// refuses `--steps 0` when it parses it, and a sweep of nothing has no point.
#[must_use]
pub fn fault_times(start_ns: i64, end_ns: i64, steps: u32) -> Vec<i64> {
    if steps == 0 || end_ns <= start_ns {
        return Vec::new();
    }
    // i128: (2 i + 1) * length overflows i64 for long runs and many steps.
    let length = i128::from(end_ns) - i128::from(start_ns);
    let slices = 2 * i128::from(steps);
    let quantum = if length >= slices * i128::from(QUANTUM_NS) {
        i128::from(QUANTUM_NS)
    } else {
        1
    };
    let mut times: Vec<i64> = (0..i128::from(steps))
        .map(|i| {
            let middle = (2 * i + 1) * length / slices;
            let rounded = (middle + quantum / 2) / quantum * quantum;
            i128::from(start_ns) + rounded
        })
        .filter(|&t| t > i128::from(start_ns) && t < i128::from(end_ns))
        .filter_map(|t| i64::try_from(t).ok())
        .collect();
    times.dedup();
    times
}

/// What became of the mission when the fault struck at one time (read back by `lewis test`
/// from a job's result file).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct SweepPoint {
    /// When the fault struck, from the start of the recording.
    pub fault_at_ns: i64,
    /// Whether the replayed mission succeeded.
    pub succeeded: bool,
    /// How long the replayed mission took, from its first record to its end (`None`: it
    /// did not end).
    pub time_to_finish_ns: Option<i64>,
    /// The longest time a client went without data of an interface it had received.
    pub longest_blind_ns: Option<i64>,
    /// Who went without what for that longest time, for people
    /// (`obstacle_avoider had no RangeFinder from 12.3s`).
    pub longest_blind: Option<String>,
    /// The state the mission was in when the fault struck (`None`: none had started).
    pub state_at_fault: Option<String>,
    /// Why the mission succeeded or failed, for people.
    pub reason: String,
    /// Where each of the supervisor's answers in the replayed mission came from, in order
    /// (`recorded`: the recorded choice; `script`: the script's suggestion).
    pub answer_sources: Vec<String>,
}

/// A fault time whose replay could not run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FailedPoint {
    /// When the fault was to strike, from the start of the recording.
    pub fault_at_ns: i64,
    /// Why the replay could not run (the error's chain).
    pub error: String,
}

/// A whole sweep: the recorded mission and, for each fault time, the replayed one.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Sweep {
    /// The recording swept (as the user named it).
    pub recording: String,
    /// The providers failed together at each time.
    pub providers: Vec<String>,
    /// How they fail.
    pub kind: FaultKind,
    /// The fault times asked for (`--steps`).
    pub steps: u32,
    /// The length of the run the times are spread across (the plot's x axis).
    pub duration_ns: i64,
    /// Whether the recorded mission succeeded (`None`: the recording has no mission).
    pub recorded_succeeded: Option<bool>,
    /// How long the recorded mission took.
    pub recorded_time_to_finish_ns: Option<i64>,
    /// The replays that ran, in the order of their fault times.
    pub points: Vec<SweepPoint>,
    /// The fault times whose replay could not run, in order.
    pub failed_points: Vec<FailedPoint>,
}

impl Sweep {
    /// The sweep as pretty JSON ending with a newline: the same sweep gives the same
    /// bytes (fields in declaration order, lists in the order held).
    #[must_use]
    #[expect(
        clippy::expect_used,
        reason = "a sweep is strings, integers, booleans and lists: serde_json cannot fail on it"
    )]
    pub fn to_json(&self) -> String {
        let mut text = serde_json::to_string_pretty(self).expect("a sweep serializes to JSON");
        text.push('\n');
        text
    }
}

/// Why a sweep's output could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The plot could not be drawn (the drawing library refused, or the bundled font).
    #[error("cannot draw the sweep's plot {path}: {reason}")]
    Draw {
        /// The PNG file to be written.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// The drawn plot could not be encoded as PNG.
    #[error("cannot encode the sweep's plot {path} as PNG: {source}")]
    Encode {
        /// The PNG file to be written.
        path: PathBuf,
        /// What the encoder said.
        source: image::ImageError,
    },
    /// The file could not be written.
    #[error("cannot write the sweep's plot {path}: {source}")]
    Write {
        /// The PNG file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
}

/// Sweeps for the tests of every file of this module.
#[cfg(test)]
mod tests_support {
    use super::*;

    /// A second.
    pub(super) const S: i64 = 1_000_000_000;

    /// A point with the fields that do not matter to a test filled in from its time.
    pub(super) fn point(fault_at_ns: i64, succeeded: bool, state: Option<&str>) -> SweepPoint {
        SweepPoint {
            fault_at_ns,
            succeeded,
            time_to_finish_ns: succeeded.then_some(53 * S),
            longest_blind_ns: Some(S),
            longest_blind: Some(format!(
                "obstacle_avoider had no RangeFinder from {}",
                crate::fault::format_seconds(fault_at_ns)
            )),
            state_at_fault: state.map(str::to_owned),
            reason: if succeeded {
                "register exited 0".to_owned()
            } else {
                "stopped through recovery".to_owned()
            },
            answer_sources: Vec::new(),
        }
    }

    /// A laser crash swept at 6 times over a 60 s run: successes, two failures in a row,
    /// a replay that could not run and a last failure.
    pub(super) fn sweep() -> Sweep {
        let mut points = vec![
            point(5 * S, true, Some("go_to_door")),
            point(15 * S, false, Some("door")),
            point(25 * S, false, Some("door")),
            point(35 * S, true, Some("register")),
            point(55 * S, false, Some("sign")),
        ];
        points[0].time_to_finish_ns = Some(53_100_000_000);
        points[0].longest_blind_ns = Some(1_200_000_000);
        points[1].longest_blind_ns = Some(45 * S);
        points[2].longest_blind_ns = Some(45 * S);
        points[2].time_to_finish_ns = Some(40_250_000_000);
        points[3].time_to_finish_ns = Some(54_002_000_000);
        points[3].longest_blind_ns = Some(250_000_000);
        points[3].answer_sources = vec!["recorded".to_owned(), "script".to_owned()];
        points[4].longest_blind_ns = Some(5 * S);
        points[4].reason = "the laser and the sonar are gone".to_owned();
        Sweep {
            recording: "logs/demo.mcap".to_owned(),
            providers: vec!["laser".to_owned()],
            kind: FaultKind::Crash,
            steps: 6,
            duration_ns: 60 * S,
            recorded_succeeded: Some(true),
            recorded_time_to_finish_ns: Some(52_500_000_000),
            points,
            failed_points: vec![FailedPoint {
                fault_at_ns: 45 * S,
                error: "cannot read logs/demo.mcap: gone".to_owned(),
            }],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::tests_support::S;
    use super::*;

    fn check_times(start_ns: i64, end_ns: i64, steps: u32, expected: &[i64]) {
        assert_eq!(
            fault_times(start_ns, end_ns, steps),
            expected,
            "fault_times({start_ns}, {end_ns}, {steps})"
        );
    }

    #[test]
    fn fault_times_are_the_middles_of_equal_slices() {
        check_times(0, 10 * S, 5, &[S, 3 * S, 5 * S, 7 * S, 9 * S]);
        check_times(0, 10 * S, 1, &[5 * S]);
        check_times(2 * S, 6 * S, 2, &[3 * S, 5 * S]);
    }

    #[test]
    fn fault_times_are_whole_milliseconds_from_the_start() {
        // 93.4 s in 20 slices: the middles are 2.335 s apart by 4.67 s, already whole ms;
        // 10 s in 3 slices: 1.6666.. s rounds to 1.667 s.
        check_times(0, 10 * S, 3, &[1_667_000_000, 5 * S, 8_333_000_000]);
        // From a start that is not a whole millisecond: rounded from the start.
        check_times(
            7,
            7 + 10 * S,
            3,
            &[7 + 1_667_000_000, 7 + 5 * S, 7 + 8_333_000_000],
        );
    }

    #[test]
    fn fault_times_on_a_run_shorter_than_two_ms_a_slice_are_whole_nanoseconds() {
        check_times(0, 3_000_000, 2, &[750_000, 2_250_000]);
    }

    #[test]
    fn fault_times_are_never_at_the_very_start_or_end() {
        for (length, steps) in [(1, 1), (2, 1), (3, 5), (10, 9), (11, 10), (1000, 7)] {
            let times = fault_times(100, 100 + length, steps);
            assert!(
                times.iter().all(|&t| t > 100 && t < 100 + length),
                "{length} ns, {steps} steps: {times:?}"
            );
            assert!(times.windows(2).all(|w| w[0] < w[1]), "{times:?}");
        }
        // Too short for the steps asked: fewer times, all distinct.
        check_times(0, 3, 5, &[1, 2]);
        check_times(0, 1, 1, &[]);
    }

    #[test]
    fn fault_times_of_no_steps_or_an_empty_run_are_empty() {
        check_times(0, 10 * S, 0, &[]);
        check_times(5 * S, 5 * S, 20, &[]);
        check_times(6 * S, 5 * S, 20, &[]);
    }

    proptest::proptest! {
        #[test]
        fn fault_times_are_steps_distinct_times_inside_the_run(
            start_ns in -1_000_000_000_000_i64..1_000_000_000_000,
            length_ns in 0_i64..100_000_000_000,
            steps in 1_u32..200,
        ) {
            let length_ns = length_ns + 2 * i64::from(steps);
            let times = fault_times(start_ns, start_ns + length_ns, steps);
            proptest::prop_assert_eq!(times.len(), steps as usize);
            proptest::prop_assert!(times.windows(2).all(|w| w[0] < w[1]));
            proptest::prop_assert!(
                times.iter().all(|&t| t > start_ns && t < start_ns + length_ns)
            );
        }
    }

    #[test]
    fn fault_times_of_the_longest_run_do_not_overflow() {
        let times = fault_times(i64::MIN, i64::MAX, 1000);
        assert_eq!(times.len(), 1000);
        assert!(times.windows(2).all(|w| w[0] < w[1]));
    }
}

#[cfg(test)]
mod json_tests {
    use expect_test::expect;

    use super::tests_support::{S, point, sweep};

    #[test]
    fn the_json_is_pretty_ends_with_a_newline_and_is_the_same_every_time() {
        let mut s = sweep();
        s.points = vec![point(5 * S, true, Some("go_to_door"))];
        s.points[0].answer_sources = vec!["recorded".to_owned()];
        let json = s.to_json();
        assert_eq!(json, s.clone().to_json());
        assert!(json.ends_with("}\n"), "{json}");
        expect![[r#"
            {
              "recording": "logs/demo.mcap",
              "providers": [
                "laser"
              ],
              "kind": "crash",
              "steps": 6,
              "duration_ns": 60000000000,
              "recorded_succeeded": true,
              "recorded_time_to_finish_ns": 52500000000,
              "points": [
                {
                  "fault_at_ns": 5000000000,
                  "succeeded": true,
                  "time_to_finish_ns": 53000000000,
                  "longest_blind_ns": 1000000000,
                  "longest_blind": "obstacle_avoider had no RangeFinder from 5s",
                  "state_at_fault": "go_to_door",
                  "reason": "register exited 0",
                  "answer_sources": [
                    "recorded"
                  ]
                }
              ],
              "failed_points": [
                {
                  "fault_at_ns": 45000000000,
                  "error": "cannot read logs/demo.mcap: gone"
                }
              ]
            }
        "#]]
        .assert_eq(&json);
    }
}
