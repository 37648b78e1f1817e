//! The mission in a replay's report: the recorded verdict, and beside it the verdict of the
//! mission lived again in the closed loop, or the label that says the replay could not
//! predict one.
//!
//! Both are judged by [`Verdict::of`] from the sequencer's records (the recorded ones from
//! `/lewis/sequencer`, the replayed ones from the harness), so the live run, the recording
//! and the replay are judged the same way. Times are from the start of the recording.

use std::fmt;

use lewis_interfaces::msg::GroundTruth;
use lewis_sequencer::{Record, Verdict};
use serde::Serialize;

use crate::fault::format_seconds;
use crate::lockstep::{Answer, AnswerSource, Gap};

/// Whether the replay lived the mission again.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case", tag = "loop")]
pub enum LoopKind {
    /// Everything re-ran: the simulated world, the services, the broker core, the
    /// sequencer and its programs. The replayed verdict is a prediction.
    Closed,
    /// The recorded sources were fed as they were: the recorded robot moves as it did, so
    /// the recorded verdict is all there is ("open loop: not a prediction").
    Open {
        /// Why the loop could not be closed, when `--all` asked for it.
        because: Option<String>,
    },
}

/// One visit of a state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Visited {
    /// The state.
    pub state: String,
    /// When its first program started.
    pub started_ns: i64,
    /// When the mission left it, if it did.
    pub ended_ns: Option<i64>,
    /// Runs of its program in this visit (1 without restarts).
    pub attempts: u32,
    /// The decision that left it (`transition door -> sign on 0`).
    pub left_by: Option<String>,
}

/// How one mission went.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MissionOutcome {
    /// Whether it succeeded (see [`Verdict`]).
    pub succeeded: bool,
    /// Why, for people.
    pub reason: String,
    /// The states visited, in order.
    pub states: Vec<Visited>,
    /// Programs restarted after a crash.
    pub restarts: u32,
    /// Times the recovery state was entered.
    pub recoveries: u32,
    /// How long the mission took, from its first record to its end (`None`: it did not
    /// end).
    pub time_to_finish_ns: Option<i64>,
    /// The simulator's count of contacts with walls or objects at the end.
    pub collisions: Option<i32>,
    /// The true pose at the end: x and y in m, heading in rad.
    pub final_pose: Option<[f64; 3]>,
    /// The longest time a client went without data of an interface it had received
    /// (replayed only: a recording does not say when a client missed a sample).
    pub longest_blind: Option<Gap>,
}

impl MissionOutcome {
    /// The outcome of the mission `records` hold; `start_ns` is the recording's start,
    /// `truth` the simulator's last GroundTruth, `end_ns` when the run ended.
    #[must_use]
    pub fn of(
        records: &[Record],
        start_ns: i64,
        truth: Option<&GroundTruth>,
        longest_blind: Option<Gap>,
    ) -> Self {
        let verdict = Verdict::of(records);
        let first = records.first().map(|r| r.time_ns);
        let over = records.iter().rev().find_map(|r| match &r.entry {
            lewis_sequencer::Entry::Decided {
                decision:
                    lewis_sequencer::Decision::Finished { .. }
                    | lewis_sequencer::Decision::Aborted { .. },
            } => Some(r.time_ns),
            _ => None,
        });
        Self {
            succeeded: verdict.succeeded,
            reason: verdict.reason.clone(),
            states: verdict
                .states_visited
                .iter()
                .map(|v| Visited {
                    state: v.state.clone(),
                    started_ns: v.started_ns - start_ns,
                    ended_ns: v.ended_ns.map(|e| e - start_ns),
                    attempts: v.attempts,
                    left_by: v.left_by.clone(),
                })
                .collect(),
            restarts: verdict.restarts,
            recoveries: verdict.recoveries,
            time_to_finish_ns: over.zip(first).map(|(end, begin)| end - begin),
            collisions: truth.map(|t| t.collisions),
            final_pose: truth.map(|t| [t.pose.x, t.pose.y, t.pose.theta]),
            longest_blind,
        }
    }

    /// The states visited, in order.
    #[must_use]
    pub fn course(&self) -> Vec<&str> {
        self.states.iter().map(|v| v.state.as_str()).collect()
    }
}

/// The mission in a replay's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MissionReport {
    /// Whether the mission was lived again.
    #[serde(flatten)]
    pub loop_kind: LoopKind,
    /// The recorded mission.
    pub recorded: Option<MissionOutcome>,
    /// The mission lived again (closed loop only).
    pub replayed: Option<MissionOutcome>,
    /// The supervisor's answers in the replayed mission, and where each came from.
    pub answers: Vec<Answer>,
    /// The live run's process deaths applied again at their recorded times (the demo kills
    /// the laser after each of its restarts), as fault SPECs.
    pub recorded_faults: Vec<String>,
    /// The distance between the recorded and the replayed final poses, in m.
    pub final_pose_distance_m: Option<f64>,
}

impl MissionReport {
    /// Whether the replayed mission went as the recorded one: the same success and the
    /// same states in the same order. `None` when there is nothing to compare.
    #[must_use]
    pub fn same_course(&self) -> Option<Result<(), String>> {
        let (recorded, replayed) = (self.recorded.as_ref()?, self.replayed.as_ref()?);
        if recorded.succeeded != replayed.succeeded {
            return Some(Err(format!(
                "the mission {} live but {} in the replay",
                outcome_word(recorded.succeeded),
                outcome_word(replayed.succeeded)
            )));
        }
        if recorded.course() != replayed.course() {
            return Some(Err(format!(
                "the states visited differ: {} live, {} in the replay",
                recorded.course().join(", "),
                replayed.course().join(", ")
            )));
        }
        Some(Ok(()))
    }
}

fn outcome_word(succeeded: bool) -> &'static str {
    if succeeded { "succeeded" } else { "failed" }
}

impl fmt::Display for MissionOutcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} ({} restarts, {} recoveries",
            if self.succeeded {
                "succeeded"
            } else {
                "FAILED"
            },
            self.reason,
            self.restarts,
            self.recoveries
        )?;
        if let Some(t) = self.time_to_finish_ns {
            write!(f, ", finished in {}", format_seconds(t))?;
        }
        if let Some(c) = self.collisions {
            write!(f, ", {c} collisions")?;
        }
        if let Some([x, y, heading]) = self.final_pose {
            write!(
                f,
                ", ended at ({x:.2}, {y:.2}) heading {:.0} deg",
                heading.to_degrees()
            )?;
        }
        writeln!(f, ")")?;
        for v in &self.states {
            let left = v.left_by.as_deref().unwrap_or("still running at the end");
            let attempts = if v.attempts > 1 {
                format!(", {} attempts", v.attempts)
            } else {
                String::new()
            };
            writeln!(
                f,
                "    {} at {}{attempts}: {left}",
                v.state,
                format_seconds(v.started_ns)
            )?;
        }
        if let Some(gap) = &self.longest_blind {
            writeln!(
                f,
                "    longest blind: {} had no {} for {} (from {})",
                gap.client,
                gap.interface,
                format_seconds(gap.gap_ns),
                format_seconds(gap.from_ns)
            )?;
        }
        Ok(())
    }
}

impl fmt::Display for MissionReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.recorded_faults.is_empty() {
            writeln!(
                f,
                "the live run's process deaths, applied again at their times: {}",
                self.recorded_faults.join(", ")
            )?;
        }
        if let Some(recorded) = &self.recorded {
            write!(f, "mission, recorded: {recorded}")?;
        }
        match (&self.loop_kind, &self.replayed) {
            (LoopKind::Closed, Some(replayed)) => {
                write!(f, "mission, replayed (closed loop): {replayed}")?;
            }
            (LoopKind::Closed, None) => writeln!(f, "mission, replayed: no mission recorded")?,
            (LoopKind::Open { because }, _) => {
                write!(f, "mission, replayed: open loop: not a prediction")?;
                match because {
                    Some(why) => writeln!(f, " ({why})")?,
                    None => writeln!(f)?,
                }
            }
        }
        for answer in &self.answers {
            let source = match answer.source {
                AnswerSource::Recorded => "the recorded answer",
                AnswerSource::Suggested => "the script's suggestion (none recorded there)",
                AnswerSource::Stop => "stop (nothing recorded, nothing suggested)",
            };
            writeln!(
                f,
                "    the supervisor was asked at {}: `{}`, {source}",
                format_seconds(answer.time_ns),
                answer.answer
            )?;
        }
        if let Some(d) = self.final_pose_distance_m {
            writeln!(f, "    the final poses are {d:.2} m apart")?;
        }
        Ok(())
    }
}
