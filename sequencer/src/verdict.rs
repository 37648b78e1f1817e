//! Whether a mission succeeded, judged from its records alone: the states it visited and
//! when, how often it restarted and recovered, and one reason for people.
//!
//! `stop` alone proves nothing: unattended, the recovery state's own `action 0 trans stop`
//! ends the mission as `finished` too. A mission succeeds only when it reaches `stop` on a
//! listed exit code of a state that is not the recovery state (in the Robot Challenge:
//! `register` exiting 0). Reaching `stop` through recovery, the supervisor choosing to
//! stop, an abort, or records that end before the mission does are failures.
//!
//! Pure: no clock and no I/O, so the live run (`lewis seq run`, `lewis up --script`), a
//! recording and an events file are judged the same way.

use std::fmt;

use crate::fsm::Decision;
use crate::record::{Entry, Record};

/// One visit of a state: from the run that entered it to the decision that left it.
/// Restarts stay in the visit (see [`Visit::attempts`]); a transition into the same state
/// starts a new one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Visit {
    /// The state.
    pub state: String,
    /// When its first program was started (the run decision's record time, ns since the
    /// Unix epoch).
    pub started_ns: i64,
    /// When the mission left it; `None` while it still ran when the records end.
    pub ended_ns: Option<i64>,
    /// How many times its program was run in this visit (1 without restarts).
    pub attempts: u32,
    /// The decision that left it, on one line (`transition door -> sign on 0`,
    /// `recover from queue`); `None` while it still ran.
    pub left_by: Option<String>,
}

impl Visit {
    /// How long the visit lasted, if it ended.
    #[must_use]
    pub fn duration_ns(&self) -> Option<i64> {
        self.ended_ns.map(|end| end - self.started_ns)
    }
}

/// The verdict on one mission.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Verdict {
    /// Whether it reached `stop` from a state that is not the recovery state.
    pub succeeded: bool,
    /// The visits, in order, the recovery state's included.
    pub states_visited: Vec<Visit>,
    /// How many times the recovery state was entered.
    pub recoveries: u32,
    /// How many times a program was restarted after a crash.
    pub restarts: u32,
    /// Why it succeeded or failed, for people.
    pub reason: String,
}

impl Verdict {
    /// Judges the mission that `records` hold, in order. When they hold several missions
    /// (an events file written twice), the last one is judged.
    #[must_use]
    pub fn of(records: &[Record]) -> Self {
        let last_start = records
            .iter()
            .rposition(|r| matches!(r.entry, Entry::MissionStarted { .. }))
            .unwrap_or(0);
        let mut judge = Judge::default();
        for record in &records[last_start..] {
            if let Entry::Decided { decision } = &record.entry {
                judge.decided(record.time_ns, decision);
            }
        }
        judge.verdict()
    }

    /// The visits of `state`, in order.
    pub fn visits_of<'v>(&'v self, state: &'v str) -> impl Iterator<Item = &'v Visit> + 'v {
        self.states_visited.iter().filter(move |v| v.state == state)
    }
}

impl fmt::Display for Verdict {
    /// `mission succeeded: ... (door, sign, sign, queue, register; 0 restarts, 0
    /// recoveries)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let word = if self.succeeded {
            "succeeded"
        } else {
            "failed"
        };
        write!(f, "mission {word}: {} (", self.reason)?;
        if self.states_visited.is_empty() {
            f.write_str("no state visited")?;
        }
        for (i, visit) in self.states_visited.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            f.write_str(&visit.state)?;
            if let Some(ns) = visit.duration_ns() {
                write!(f, " {}", rounded(ns))?;
            }
        }
        let plural = |n: u32| if n == 1 { "" } else { "s" };
        write!(
            f,
            "; {} restart{}, {} recover{})",
            self.restarts,
            plural(self.restarts),
            self.recoveries,
            if self.recoveries == 1 { "y" } else { "ies" }
        )
    }
}

/// A visit's length for people: tenths of seconds from a second on (`12.5s`), else whole
/// milliseconds (`40ms`).
fn rounded(ns: i64) -> String {
    if ns >= 1_000_000_000 {
        #[allow(clippy::cast_precision_loss)] // Display only.
        let secs = ns as f64 / 1e9;
        format!("{secs:.1}s")
    } else {
        format!("{}ms", ns / 1_000_000)
    }
}

/// The fold over one mission's decisions.
#[derive(Debug, Default)]
struct Judge {
    visits: Vec<Visit>,
    recoveries: u32,
    restarts: u32,
    /// The recovery state, known once it has been entered: the run that follows
    /// [`Decision::EnterRecovery`] is the recovery state's (a transition from the recovery
    /// state happens only unattended, so only after it was entered that way).
    recovery: Option<String>,
    /// The decision before the current one.
    previous: Option<Decision>,
    /// How the mission ended: `Some((succeeded, reason))`.
    end: Option<(bool, String)>,
}

impl Judge {
    fn decided(&mut self, time_ns: i64, decision: &Decision) {
        match decision {
            Decision::Run { state, attempt, .. } => {
                if matches!(self.previous, Some(Decision::EnterRecovery { .. })) {
                    self.recovery = Some(state.clone());
                }
                match self.visits.last_mut() {
                    Some(visit) if *attempt > 1 && visit.state == *state => {
                        visit.attempts = *attempt;
                    }
                    _ => self.visits.push(Visit {
                        state: state.clone(),
                        started_ns: time_ns,
                        ended_ns: None,
                        attempts: *attempt,
                        left_by: None,
                    }),
                }
            }
            Decision::Restart { .. } => self.restarts += 1,
            Decision::EnterRecovery { .. } => {
                self.recoveries += 1;
                self.leave(time_ns, decision);
            }
            Decision::AskSupervisor { .. } | Decision::Transition { .. } => {
                self.leave(time_ns, decision);
            }
            Decision::Resume { .. } => {}
            Decision::Finished { reason } => {
                let end = match &self.previous {
                    Some(Decision::Transition { from, to, code, .. }) if to == "stop" => {
                        if self.recovery.as_ref() == Some(from) {
                            (
                                false,
                                format!(
                                    "it reached `stop` through the recovery state `{from}` \
                                     (exit code {code}), not by finishing its task"
                                ),
                            )
                        } else {
                            (
                                true,
                                format!("`{from}` exited with code {code}, which leads to `stop`"),
                            )
                        }
                    }
                    _ => (
                        false,
                        format!("it ended without a state leading to `stop` ({reason})"),
                    ),
                };
                self.leave(time_ns, decision);
                self.end = Some(end);
            }
            Decision::Aborted { reason } => {
                self.leave(time_ns, decision);
                self.end = Some((false, format!("it aborted: {reason}")));
            }
        }
        self.previous = Some(decision.clone());
    }

    /// The current visit, if still open, ends here.
    fn leave(&mut self, time_ns: i64, decision: &Decision) {
        if let Some(visit) = self.visits.last_mut()
            && visit.ended_ns.is_none()
        {
            visit.ended_ns = Some(time_ns);
            visit.left_by = Some(decision.summary());
        }
    }

    fn verdict(self) -> Verdict {
        let (succeeded, reason) = self.end.unwrap_or_else(|| {
            let reason = match self.visits.last() {
                None => "it did not start".to_owned(),
                Some(visit) if visit.ended_ns.is_none() => {
                    format!("the records end while `{}` runs", visit.state)
                }
                Some(_) => "the records end before the mission does".to_owned(),
            };
            (false, reason)
        });
        Verdict {
            succeeded,
            states_visited: self.visits,
            recoveries: self.recoveries,
            restarts: self.restarts,
            reason,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use expect_test::{Expect, expect};

    use super::*;
    use crate::fsm::{Event, Sequencer, Supervision};

    /// Runs the script's FSM on `events` (one exit code, signal or choice each), records
    /// its decisions one second apart, and shows the verdict.
    fn check(script: &str, supervision: Supervision, events: &[Event], expected: &Expect) {
        let sources = crate::MemorySources::new().with("m.seq", script);
        let mission = crate::check_with(
            std::path::Path::new("m.seq"),
            &sources,
            &crate::TrustingResolver,
        )
        .unwrap_or_else(|d| panic!("{d}"))
        .mission;
        let mut records = Vec::new();
        let mut push = |entry: Entry| {
            let seq = records.len() as u64;
            records.push(Record {
                seq,
                time_ns: i64::try_from(seq).unwrap() * 1_000_000_000,
                entry,
            });
        };
        push(Entry::MissionStarted {
            script: PathBuf::from("m.seq"),
            states: mission.states().iter().map(|s| s.name.clone()).collect(),
            use_gui: false,
            supervision: Some(supervision),
        });
        let (mut fsm, decisions) = Sequencer::start(mission, supervision);
        for decision in decisions {
            push(Entry::Decided { decision });
        }
        for event in events {
            let decisions = fsm.handle(event).unwrap();
            push(Entry::Observed {
                event: event.clone(),
            });
            for decision in decisions {
                push(Entry::Decided { decision });
            }
        }
        let verdict = Verdict::of(&records);
        let mut shown = format!("{verdict}\n");
        for visit in &verdict.states_visited {
            shown.push_str(&format!(
                "  {} x{} {}..{:?} {:?}\n",
                visit.state,
                visit.attempts,
                visit.started_ns / 1_000_000_000,
                visit.ended_ns.map(|ns| ns / 1_000_000_000),
                visit.left_by
            ));
        }
        expected.assert_eq(&shown);
    }

    const CHALLENGE: &str = "start door\nrestart 3\nrecovery oops\n\
        state door ./d\n  action 0 trans sign\n\
        state sign ./s\n  action 0 trans sign\n  action 1 trans queue\n\
        state queue ./q\n  action 0 trans register\n\
        state register ./r\n  action 0 trans stop\n\
        state oops ./o\n  action 0 trans stop\n";

    fn exit(code: i32) -> Event {
        Event::Exited { code }
    }

    #[test]
    fn register_exiting_0_is_a_success() {
        check(
            CHALLENGE,
            Supervision::Unattended,
            &[exit(0), exit(0), exit(1), exit(0), exit(0)],
            &expect![[r#"
                mission succeeded: `register` exited with code 0, which leads to `stop` (door 2.0s, sign 2.0s, sign 2.0s, queue 2.0s, register 2.0s; 0 restarts, 0 recoveries)
                  door x1 1..Some(3) Some("transition door -> sign on 0")
                  sign x1 4..Some(6) Some("transition sign -> sign on 0")
                  sign x1 7..Some(9) Some("transition sign -> queue on 1")
                  queue x1 10..Some(12) Some("transition queue -> register on 0")
                  register x1 13..Some(15) Some("transition register -> stop on 0")
            "#]],
        );
    }

    #[test]
    fn reaching_stop_through_recovery_is_a_failure() {
        let segv = Event::Signalled { signal: 11 };
        check(
            CHALLENGE,
            Supervision::Unattended,
            &[
                exit(0),
                segv.clone(),
                segv.clone(),
                segv.clone(),
                segv,
                exit(0),
            ],
            &expect![[r#"
                mission failed: it reached `stop` through the recovery state `oops` (exit code 0), not by finishing its task (door 2.0s, sign 11.0s, oops 2.0s; 3 restarts, 1 recovery)
                  door x1 1..Some(3) Some("transition door -> sign on 0")
                  sign x4 4..Some(15) Some("recover from sign")
                  oops x1 16..Some(18) Some("transition oops -> stop on 0")
            "#]],
        );
    }

    #[test]
    fn a_supervisor_resuming_after_recovery_can_still_succeed() {
        check(
            "start a\nrecovery r\nstate a ./a\n  action 0 trans stop\nstate r ./r\n  action 0 trans stop\n",
            Supervision::Page,
            &[
                exit(3),
                exit(0),
                Event::SupervisorChose { state: "a".into() },
                exit(0),
            ],
            &expect![[r#"
                mission succeeded: `a` exited with code 0, which leads to `stop` (a 2.0s, r 2.0s, a 2.0s; 0 restarts, 1 recovery)
                  a x1 1..Some(3) Some("recover from a")
                  r x1 4..Some(6) Some("ask the supervisor: a, r or stop (suggested stop)")
                  a x1 9..Some(11) Some("transition a -> stop on 0")
            "#]],
        );
    }

    #[test]
    fn the_supervisor_choosing_stop_is_not_a_success() {
        check(
            "start a\nrecovery r\nstate a ./a\n  action 0 trans stop\nstate r ./r\n  action 0 trans stop\n",
            Supervision::Page,
            &[
                exit(3),
                exit(0),
                Event::SupervisorChose {
                    state: "stop".into(),
                },
            ],
            &expect![[r#"
                mission failed: it ended without a state leading to `stop` (the supervisor chose to stop) (a 2.0s, r 2.0s; 0 restarts, 1 recovery)
                  a x1 1..Some(3) Some("recover from a")
                  r x1 4..Some(6) Some("ask the supervisor: a, r or stop (suggested stop)")
            "#]],
        );
    }

    #[test]
    fn an_abort_and_records_cut_short_are_failures() {
        check(
            "start a\nstate a ./a\n  action 0 trans stop\n",
            Supervision::Unattended,
            &[exit(5)],
            &expect![[r#"
                mission failed: it aborted: `a` exited with code 5, which the script does not list, and the script has no recovery state; nobody can be asked where to resume (unattended) (a 2.0s; 0 restarts, 0 recoveries)
                  a x1 1..Some(3) Some("aborted")
            "#]],
        );
        check(
            "start a\nstate a ./a\n  action 0 trans a\n",
            Supervision::Unattended,
            &[exit(0)],
            &expect![[r#"
                mission failed: the records end while `a` runs (a 2.0s, a; 0 restarts, 0 recoveries)
                  a x1 1..Some(3) Some("transition a -> a on 0")
                  a x1 4..None None
            "#]],
        );
        assert_eq!(Verdict::of(&[]).reason, "it did not start");
    }
}
