//! The sweep as a table for people: a heading, one line per fault time, and a last line
//! that says when the fault is survived and when not.

use std::fmt;

use super::{FailedPoint, Sweep, SweepPoint};
use crate::fault::{FaultKind, format_seconds};

impl fmt::Display for Sweep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let times = self.points.len() + self.failed_points.len();
        writeln!(
            f,
            "fault sweep of {}: {} at {} {} across {}",
            self.recording,
            fault_name(&self.providers, self.kind),
            times,
            plural(times, "time", "times"),
            format_seconds(self.duration_ns)
        )?;
        writeln!(f, "recorded mission: {}", self.recorded_verdict())?;
        let rows = self.rows();
        let state_width = rows
            .iter()
            .map(|row| row.state.chars().count())
            .chain(["state at fault".len()])
            .max()
            .unwrap_or(0);
        let header = Row {
            at: "fault at".to_owned(),
            mission: "mission",
            finish: "took".to_owned(),
            blind: "longest blind".to_owned(),
            state: "state at fault".to_owned(),
            notes: "notes".to_owned(),
        };
        for row in std::iter::once(&header).chain(&rows) {
            let line = format!(
                "{:>9}  {:<9}  {:>9}  {:>13}  {:<state_width$}  {}",
                row.at, row.mission, row.finish, row.blind, row.state, row.notes
            );
            writeln!(f, "{}", line.trim_end())?;
        }
        writeln!(f, "{}", self.summary())
    }
}

/// One line of the table, as text.
struct Row {
    at: String,
    mission: &'static str,
    finish: String,
    blind: String,
    state: String,
    notes: String,
}

impl Sweep {
    fn recorded_verdict(&self) -> String {
        let finish = self
            .recorded_time_to_finish_ns
            .map(|t| format!(" in {}", format_seconds(t)))
            .unwrap_or_default();
        match self.recorded_succeeded {
            Some(true) => format!("succeeded{finish}"),
            Some(false) => format!("FAILED{finish}"),
            None => "none in the recording".to_owned(),
        }
    }

    /// The points and the failed points, in the order of their times.
    fn rows(&self) -> Vec<Row> {
        let mut rows: Vec<(i64, Row)> = self
            .points
            .iter()
            .map(|p| (p.fault_at_ns, point_row(p)))
            .chain(
                self.failed_points
                    .iter()
                    .map(|p| (p.fault_at_ns, failed_row(p))),
            )
            .collect();
        rows.sort_by_key(|(at, _)| *at);
        rows.into_iter().map(|(_, row)| row).collect()
    }

    /// The last line: at how many times the mission survives, and when it does not.
    fn summary(&self) -> String {
        let fault = fault_sentence(&self.providers, self.kind);
        let total = self.points.len();
        let survived = self.points.iter().filter(|p| p.succeeded).count();
        let mut text = if total == 0 {
            "no replay of the sweep could run".to_owned()
        } else if survived == total {
            format!(
                "the mission succeeds at all {total} fault {}: it survives whenever {fault}",
                plural(total, "time", "times")
            )
        } else {
            let when = failure_spans(self)
                .iter()
                .map(FailureSpan::to_string)
                .collect::<Vec<_>>();
            let lead = if survived == 0 {
                format!(
                    "the mission fails at all {total} fault {}",
                    plural(total, "time", "times")
                )
            } else {
                format!("the mission succeeds at {survived} of the {total} fault times")
            };
            format!("{lead}; it fails when {fault} {}", and_list(&when))
        };
        if !self.failed_points.is_empty() {
            let n = self.failed_points.len();
            text.push_str(&format!(
                "; {n} {} could not be replayed",
                plural(n, "time", "times")
            ));
        }
        text
    }
}

fn point_row(p: &SweepPoint) -> Row {
    let mut notes = Vec::new();
    if !p.succeeded {
        notes.push(p.reason.clone());
    }
    if let Some(who) = &p.longest_blind {
        notes.push(format!("blind: {who}"));
    }
    if !p.answer_sources.is_empty() {
        notes.push(format!("answers: {}", p.answer_sources.join(", ")));
    }
    Row {
        at: format_seconds(p.fault_at_ns),
        mission: if p.succeeded { "succeeded" } else { "FAILED" },
        finish: p
            .time_to_finish_ns
            .map_or_else(|| "-".to_owned(), format_seconds),
        blind: p
            .longest_blind_ns
            .map_or_else(|| "-".to_owned(), format_seconds),
        state: p.state_at_fault.clone().unwrap_or_else(|| "-".to_owned()),
        notes: notes.join("; "),
    }
}

fn failed_row(p: &FailedPoint) -> Row {
    Row {
        at: format_seconds(p.fault_at_ns),
        mission: "not run",
        finish: "-".to_owned(),
        blind: "-".to_owned(),
        state: "-".to_owned(),
        notes: p.error.clone(),
    }
}

/// Consecutive fault times (in the order of the points) at which the mission failed.
pub(super) struct FailureSpan<'a> {
    /// The first fault time of the span.
    pub(super) from_ns: i64,
    /// The last.
    pub(super) to_ns: i64,
    /// The states the fault struck in, each once, in order.
    pub(super) states: Vec<&'a str>,
}

impl fmt::Display for FailureSpan<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.from_ns == self.to_ns {
            write!(f, "at {}", format_seconds(self.from_ns))?;
        } else {
            write!(
                f,
                "from {} to {}",
                format_seconds(self.from_ns),
                format_seconds(self.to_ns)
            )?;
        }
        if !self.states.is_empty() {
            write!(f, " (during {})", self.states.join(", "))?;
        }
        Ok(())
    }
}

/// The runs of consecutive fault times at which the mission failed; a time whose replay
/// could not run ends a run, since nothing is known of it.
pub(super) fn failure_spans(sweep: &Sweep) -> Vec<FailureSpan<'_>> {
    // (time, Some(point) or None for a replay that could not run), in time order.
    let mut events: Vec<(i64, Option<&SweepPoint>)> = sweep
        .points
        .iter()
        .map(|p| (p.fault_at_ns, Some(p)))
        .chain(sweep.failed_points.iter().map(|p| (p.fault_at_ns, None)))
        .collect();
    events.sort_by_key(|(at, _)| *at);
    let mut spans: Vec<FailureSpan<'_>> = Vec::new();
    let mut previous_failed = false;
    for (_, point) in events {
        let Some(p) = point.filter(|p| !p.succeeded) else {
            previous_failed = false;
            continue;
        };
        let state = p.state_at_fault.as_deref();
        match spans.last_mut() {
            Some(span) if previous_failed => {
                span.to_ns = p.fault_at_ns;
                if let Some(state) = state
                    && !span.states.contains(&state)
                {
                    span.states.push(state);
                }
            }
            _ => spans.push(FailureSpan {
                from_ns: p.fault_at_ns,
                to_ns: p.fault_at_ns,
                states: state.into_iter().collect(),
            }),
        }
        previous_failed = true;
    }
    spans
}

/// `the laser crashes`, `the laser and the camera stall`.
fn fault_sentence(providers: &[String], kind: FaultKind) -> String {
    let one = providers.len() == 1;
    let verb = match kind {
        FaultKind::Crash => plural_verb(one, "crashes", "crash"),
        FaultKind::Stall => plural_verb(one, "stalls", "stall"),
        FaultKind::Garbage => plural_verb(one, "sends garbage", "send garbage"),
        FaultKind::Frozen => plural_verb(one, "freezes", "freeze"),
        FaultKind::Slow => plural_verb(one, "slows down", "slow down"),
        FaultKind::OutOfService => plural_verb(one, "goes out of service", "go out of service"),
        FaultKind::Stuck => plural_verb(one, "gets stuck", "get stuck"),
        FaultKind::HostLost => plural_verb(one, "is cut off", "are cut off"),
        FaultKind::Nan => plural_verb(one, "sends NaN readings", "send NaN readings"),
        FaultKind::Degraded => plural_verb(one, "degrades", "degrade"),
    };
    let subjects: Vec<String> = providers.iter().map(|p| format!("the {p}")).collect();
    format!("{} {verb}", and_list(&subjects))
}

/// `laser crash`, `laser+camera stall`, for the heading and the plot's title.
pub(super) fn fault_name(providers: &[String], kind: FaultKind) -> String {
    format!("{} {}", providers.join("+"), kind.word())
}

fn plural_verb(one: bool, singular: &'static str, plural: &'static str) -> &'static str {
    if one { singular } else { plural }
}

fn plural(n: usize, one: &'static str, many: &'static str) -> &'static str {
    if n == 1 { one } else { many }
}

/// `a`, `a and b`, `a, b and c`.
fn and_list(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use expect_test::{Expect, expect};

    use super::*;
    use crate::sweep::tests_support::{S, point, sweep};

    fn check(sweep: &Sweep, expected: &Expect) {
        expected.assert_eq(&sweep.to_string());
    }

    #[test]
    fn a_table_line_per_time_and_the_failures_summed_up() {
        check(
            &sweep(),
            &expect![[r#"
                fault sweep of logs/demo.mcap: laser crash at 6 times across 60s
                recorded mission: succeeded in 52.5s
                 fault at  mission         took  longest blind  state at fault  notes
                       5s  succeeded      53.1s           1.2s  go_to_door      blind: obstacle_avoider had no RangeFinder from 5s
                      15s  FAILED             -            45s  door            stopped through recovery; blind: obstacle_avoider had no RangeFinder from 15s
                      25s  FAILED        40.25s            45s  door            stopped through recovery; blind: obstacle_avoider had no RangeFinder from 25s
                      35s  succeeded    54.002s          0.25s  register        blind: obstacle_avoider had no RangeFinder from 35s; answers: recorded, script
                      45s  not run            -              -  -               cannot read logs/demo.mcap: gone
                      55s  FAILED             -             5s  sign            the laser and the sonar are gone; blind: obstacle_avoider had no RangeFinder from 55s
                the mission succeeds at 2 of the 5 fault times; it fails when the laser crashes from 15s to 25s (during door) and at 55s (during sign); 1 time could not be replayed
            "#]],
        );
    }

    #[test]
    fn a_sweep_survived_everywhere_says_so() {
        let mut s = sweep();
        s.points.retain(|p| p.succeeded);
        s.failed_points.clear();
        s.providers = vec!["laser".to_owned(), "camera".to_owned()];
        s.kind = FaultKind::OutOfService;
        let text = s.to_string();
        let last = text.lines().last().unwrap_or_default();
        assert_eq!(
            last,
            "the mission succeeds at all 2 fault times: it survives whenever the laser and \
             the camera go out of service"
        );
    }

    #[test]
    fn a_sweep_failed_everywhere_says_so() {
        let mut s = sweep();
        s.points = vec![
            point(10 * S, false, Some("door")),
            point(20 * S, false, None),
        ];
        s.failed_points.clear();
        s.kind = FaultKind::Garbage;
        let text = s.to_string();
        let last = text.lines().last().unwrap_or_default();
        assert_eq!(
            last,
            "the mission fails at all 2 fault times; it fails when the laser sends garbage \
             from 10s to 20s (during door)"
        );
    }

    #[test]
    fn a_time_that_could_not_be_replayed_splits_the_failures_around_it() {
        let mut s = sweep();
        s.points.retain(|p| !p.succeeded);
        let text = s.to_string();
        let last = text.lines().last().unwrap_or_default();
        assert_eq!(
            last,
            "the mission fails at all 3 fault times; it fails when the laser crashes from \
             15s to 25s (during door) and at 55s (during sign); 1 time could not be replayed"
        );
    }

    #[test]
    fn a_sweep_with_no_replay_says_so() {
        let mut s = sweep();
        s.points.clear();
        s.recorded_succeeded = None;
        s.recorded_time_to_finish_ns = None;
        let text = s.to_string();
        assert!(
            text.contains("recorded mission: none in the recording\n"),
            "{text}"
        );
        assert!(
            text.ends_with("no replay of the sweep could run; 1 time could not be replayed\n"),
            "{text}"
        );
    }

    #[test]
    fn lists_are_joined_as_people_write_them() {
        let words = |w: &[&str]| w.iter().map(|&s| s.to_owned()).collect::<Vec<_>>();
        assert_eq!(and_list(&words(&[])), "");
        assert_eq!(and_list(&words(&["a"])), "a");
        assert_eq!(and_list(&words(&["a", "b"])), "a and b");
        assert_eq!(and_list(&words(&["a", "b", "c"])), "a, b and c");
    }
}
