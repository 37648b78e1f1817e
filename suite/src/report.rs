//! The suite's report, joined from a plan and its jobs' results (`lewis test --merge DIR`,
//! and the end of a one-machine run, which merges the same way): each case's verdict and
//! why, the sweeps as replay's [`Sweep`]s, what was skipped. The JSON is this structure;
//! the JUnit file and the HTML page are drawn from it.
//!
//! Nothing in it depends on where or when the jobs ran: times are the recordings' own, and
//! the results are read in the plan's order, so one machine and a job array give the same
//! bytes.

use std::path::Path;

use lewis_replay::fault::format_seconds;
use lewis_replay::sweep::{FailedPoint, Sweep};
use serde::Serialize;

use crate::expected::{Accepted, AcceptedCheck, AcceptedPoint};
use crate::plan::{Job, Plan, Run, Skipped};
use crate::run::{CheckResult, JobResult, Outcome, read_result};

/// A case's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// What was expected holds.
    Passed,
    /// What was expected does not hold.
    Failed,
    /// It fails, and the faults file says it is known to.
    KnownFailure,
    /// It could not run, or its result is missing.
    Error,
}

impl Verdict {
    /// The word of the reports.
    #[must_use]
    pub fn word(self) -> &'static str {
        match self {
            Self::Passed => "passed",
            Self::Failed => "failed",
            Self::KnownFailure => "known failure",
            Self::Error => "error",
        }
    }
}

/// One case: a run's check, or a point of a sweep.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Case {
    /// Its name within its run (`check`, `laser crash @ 12.5s`).
    pub name: String,
    /// The verdict.
    pub verdict: Verdict,
    /// Why, for people.
    pub reason: String,
    /// The fault's time, for a point.
    pub fault_at_ns: Option<i64>,
    /// The recorded mission's state at that time.
    pub state_at_fault: Option<String>,
    /// The command that reproduces it.
    pub command: String,
    /// For a known failure, why it is known to fail.
    pub known_failure: Option<String>,
}

/// One run's cases and sweeps.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// The run's name.
    pub name: String,
    /// `carmen` or `ros2` when it was imported.
    pub imported_from: Option<String>,
    /// The recording's length.
    pub duration_ns: i64,
    /// Whether a mission was lived again.
    pub closed_loop: bool,
    /// The recorded mission's verdict, if there was a mission.
    pub recorded_mission: Option<String>,
    /// The cases, in the plan's order.
    pub cases: Vec<Case>,
    /// The sweeps over it.
    pub sweeps: Vec<SweepReport>,
}

/// A sweep over a run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepReport {
    /// The sweep's name.
    pub name: String,
    /// Its points, as replay's sweep holds and draws them.
    pub sweep: Sweep,
}

/// The counts of the report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Totals {
    /// Cases.
    pub cases: usize,
    /// Passed.
    pub passed: usize,
    /// Failed.
    pub failed: usize,
    /// Known failures.
    pub known_failures: usize,
    /// Errors.
    pub errors: usize,
    /// Inputs and sweeps skipped (errors among them count in `errors` too).
    pub skipped: usize,
}

/// The whole suite.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuiteReport {
    /// Whether every expectation holds and nothing failed to run.
    pub passed: bool,
    /// The counts.
    pub totals: Totals,
    /// The runs, sorted by name.
    pub runs: Vec<RunReport>,
    /// What was left out, and why.
    pub skipped: Vec<Skipped>,
}

impl SuiteReport {
    /// The report as pretty JSON ending with a newline.
    #[must_use]
    pub fn to_json(&self) -> String {
        crate::to_json(self)
    }

    /// The accepted results of every run: what each case gave this time.
    #[must_use]
    pub fn accepted(plan: &Plan, results: &[Option<JobResult>]) -> Vec<(String, Accepted)> {
        let mut out: Vec<(String, Accepted)> = plan
            .runs
            .iter()
            .map(|r| (r.expected_file.clone(), Accepted::default()))
            .collect();
        for (job, result) in plan.jobs.iter().zip(results) {
            let Some((_, accepted)) = out.get_mut(job.run) else {
                continue;
            };
            match (result.as_ref().map(|r| &r.outcome), &job.point) {
                (Some(Outcome::Check(check)), None) => {
                    accepted.check = Some(AcceptedCheck {
                        passed: check.passed,
                        failing: check.failing.clone(),
                        succeeded: check.succeeded,
                        course: check.course.clone(),
                    });
                }
                (Some(Outcome::Point(point)), Some(p)) => {
                    if let Some(sweep) = plan.faults.sweeps.get(p.sweep) {
                        accepted.points.push(AcceptedPoint {
                            sweep: sweep.name.clone(),
                            at_ns: p.at_ns,
                            succeeded: point.succeeded,
                        });
                    }
                }
                _ => {}
            }
        }
        out
    }
}

/// Reads the results of every job of `plan` from `dir`, in the plan's order: `None` for a
/// job that left none, and the problems of those that cannot be used (a result of another
/// plan, an unreadable file), which count as missing.
#[must_use]
pub fn read_results(plan: &Plan, dir: &Path) -> (Vec<Option<JobResult>>, Vec<(usize, String)>) {
    let mut problems = Vec::new();
    let results = plan
        .jobs
        .iter()
        .map(|job| match read_result(dir, job.index) {
            Ok(Some(result)) if result.id == job.id() && result.index == job.index => Some(result),
            Ok(Some(result)) => {
                problems.push((
                    job.index,
                    format!(
                        "its result file is for `{}`, not this plan's `{}`: run the job again",
                        result.id,
                        job.id()
                    ),
                ));
                None
            }
            Ok(None) => None,
            Err(problem) => {
                problems.push((job.index, problem));
                None
            }
        })
        .collect();
    (results, problems)
}

/// Joins `plan` and its jobs' `results` (in the plan's order; `problems` say why some are
/// missing) into the report.
#[must_use]
pub fn merge(
    plan: &Plan,
    results: &[Option<JobResult>],
    problems: &[(usize, String)],
) -> SuiteReport {
    let mut runs: Vec<RunReport> = plan.runs.iter().map(run_report).collect();
    for (i, job) in plan.jobs.iter().enumerate() {
        let result = results.get(i).and_then(Option::as_ref);
        let problem = problems
            .iter()
            .find(|(index, _)| *index == job.index)
            .map(|(_, p)| p.clone());
        let (Some(run), Some(report)) = (plan.runs.get(job.run), runs.get_mut(job.run)) else {
            continue;
        };
        let mut case = judge(plan, run, job, result, problem);
        if case.verdict == Verdict::Failed
            && let Some(known) = plan
                .faults
                .known_failures
                .iter()
                .find(|k| k.matches(&job.id()))
        {
            case.verdict = Verdict::KnownFailure;
            case.known_failure = Some(known.reason.clone());
        }
        report.cases.push(case);
        if let (Some(point), Some(result)) = (&job.point, result) {
            add_to_sweep(plan, run, report, point.sweep, point.at_ns, &result.outcome);
        }
    }
    let mut totals = Totals {
        skipped: plan.skipped.len(),
        errors: plan.skipped.iter().filter(|s| s.error).count(),
        ..Totals::default()
    };
    for case in runs.iter().flat_map(|r| &r.cases) {
        totals.cases += 1;
        match case.verdict {
            Verdict::Passed => totals.passed += 1,
            Verdict::Failed => totals.failed += 1,
            Verdict::KnownFailure => totals.known_failures += 1,
            Verdict::Error => totals.errors += 1,
        }
    }
    SuiteReport {
        passed: totals.failed == 0 && totals.errors == 0,
        totals,
        runs,
        skipped: plan.skipped.clone(),
    }
}

fn run_report(run: &Run) -> RunReport {
    RunReport {
        name: run.name.clone(),
        imported_from: run.import.as_ref().map(|i| i.format.clone()),
        duration_ns: run.duration_ns,
        closed_loop: run.closed,
        recorded_mission: run.mission.as_ref().map(|m| {
            format!(
                "{}: {}",
                if m.succeeded { "succeeded" } else { "failed" },
                m.reason
            )
        }),
        cases: Vec::new(),
        sweeps: Vec::new(),
    }
}

/// A point's outcome into its sweep's [`Sweep`], made on the first point.
fn add_to_sweep(
    plan: &Plan,
    run: &Run,
    report: &mut RunReport,
    sweep: usize,
    at_ns: i64,
    outcome: &Outcome,
) {
    let Some(decl) = plan.faults.sweeps.get(sweep) else {
        return;
    };
    let Some(kind) = decl.fault_kind() else {
        return;
    };
    let index = match report.sweeps.iter().position(|s| s.name == decl.name) {
        Some(index) => index,
        None => {
            report.sweeps.push(SweepReport {
                name: decl.name.clone(),
                sweep: Sweep {
                    recording: run.name.clone(),
                    providers: decl.providers.clone(),
                    kind,
                    steps: decl.steps,
                    duration_ns: run.duration_ns,
                    recorded_succeeded: run.mission.as_ref().map(|m| m.succeeded),
                    recorded_time_to_finish_ns: run
                        .mission
                        .as_ref()
                        .and_then(|m| m.time_to_finish_ns),
                    points: Vec::new(),
                    failed_points: Vec::new(),
                },
            });
            report.sweeps.len() - 1
        }
    };
    let Some(swept) = report.sweeps.get_mut(index).map(|s| &mut s.sweep) else {
        return;
    };
    match outcome {
        Outcome::Point(point) => swept.points.push(point.clone()),
        Outcome::Error { error } => swept.failed_points.push(FailedPoint {
            fault_at_ns: at_ns,
            error: error.clone(),
        }),
        Outcome::Check(_) => {}
    }
}

/// The verdict of `job` from its result.
fn judge(
    plan: &Plan,
    run: &Run,
    job: &Job,
    result: Option<&JobResult>,
    problem: Option<String>,
) -> Case {
    let mut case = Case {
        name: job.case.clone(),
        verdict: Verdict::Passed,
        reason: String::new(),
        fault_at_ns: job.point.as_ref().map(|p| p.at_ns),
        state_at_fault: job.point.as_ref().and_then(|p| p.state.clone()),
        command: job.command.clone(),
        known_failure: None,
    };
    let Some(result) = result else {
        case.verdict = Verdict::Error;
        case.reason = problem.unwrap_or_else(|| {
            format!(
                "job {} left no result: it did not run or did not finish (run it with \
                 `lewis test --job {}`)",
                job.index, job.index
            )
        });
        return case;
    };
    match (&result.outcome, &job.point) {
        (Outcome::Error { error }, _) => {
            case.verdict = Verdict::Error;
            case.reason = format!("the replay could not run: {error}");
        }
        (Outcome::Check(check), _) => {
            let accepted = run.accepted.as_ref().and_then(|a| a.check.as_ref());
            (case.verdict, case.reason) = judge_check(check, accepted);
        }
        (Outcome::Point(point), Some(p)) => {
            let sweep = plan.faults.sweeps.get(p.sweep);
            let at = format_seconds(point.fault_at_ns);
            let state = p
                .state
                .as_deref()
                .map(|s| format!(" (the recorded mission in `{s}`)"))
                .unwrap_or_default();
            let fate = if point.succeeded {
                "succeeded"
            } else {
                "failed"
            };
            let replayed_state = point
                .state_at_fault
                .as_deref()
                .map(|s| format!(", in `{s}` when the fault struck in the replay"))
                .unwrap_or_default();
            let what = format!(
                "at {at}{state} the mission {fate}{replayed_state}: {}",
                point.reason
            );
            let broken: Vec<String> = sweep
                .map(|s| {
                    p.expect
                        .iter()
                        .filter_map(|&i| s.expect.get(i))
                        .filter(|e| e.succeeds != point.succeeded)
                        .map(crate::faults::Expectation::describe)
                        .collect()
                })
                .unwrap_or_default();
            let accepted = run.accepted.as_ref().and_then(|a| {
                a.points
                    .iter()
                    .find(|ap| sweep.is_some_and(|s| s.name == ap.sweep) && ap.at_ns == p.at_ns)
            });
            if !broken.is_empty() {
                case.verdict = Verdict::Failed;
                case.reason = format!("expected: {}; {what}", broken.join("; "));
            } else if let Some(accepted) = accepted.filter(|a| a.succeeded != point.succeeded) {
                case.verdict = Verdict::Failed;
                case.reason = format!(
                    "the accepted result is that the mission {}; {what}",
                    if accepted.succeeded {
                        "succeeds"
                    } else {
                        "fails"
                    }
                );
            } else {
                case.reason = what;
            }
        }
        (Outcome::Point(_), None) => {
            case.verdict = Verdict::Error;
            case.reason = "a point's result for a check job: run the job again".to_owned();
        }
    }
    case
}

fn judge_check(check: &CheckResult, accepted: Option<&AcceptedCheck>) -> (Verdict, String) {
    let now = describe_check(check);
    match accepted {
        Some(accepted) => {
            let same = accepted.passed == check.passed
                && accepted.failing == check.failing
                && accepted.succeeded == check.succeeded
                && accepted.course == check.course;
            if same {
                (Verdict::Passed, format!("as accepted: {now}"))
            } else {
                let then = describe_check(&CheckResult {
                    passed: accepted.passed,
                    failing: accepted.failing.clone(),
                    succeeded: accepted.succeeded,
                    course: accepted.course.clone(),
                    mission_differs: None,
                    reason: None,
                    ..check.clone()
                });
                (
                    Verdict::Failed,
                    format!("differs from the accepted result ({then}): {now}"),
                )
            }
        }
        None if check.passed => (Verdict::Passed, now),
        None => (Verdict::Failed, now),
    }
}

fn describe_check(check: &CheckResult) -> String {
    let mut parts = Vec::new();
    if let Some(differs) = &check.mission_differs {
        parts.push(differs.clone());
    }
    if !check.failing.is_empty() {
        parts.push(format!(
            "outputs differ from the recording on {}",
            check.failing.join(", ")
        ));
    }
    if parts.is_empty() {
        parts.push(if check.compared == "outputs" {
            "the outputs match the recording".to_owned()
        } else {
            "the mission went as recorded".to_owned()
        });
    }
    if let Some(succeeded) = check.succeeded {
        parts.push(format!(
            "the mission lived again {} through {}{}",
            if succeeded { "succeeded" } else { "failed" },
            check.course.join(", "),
            check
                .reason
                .as_deref()
                .map(|r| format!(" ({r})"))
                .unwrap_or_default()
        ));
    }
    format!("{} ({} loop)", parts.join("; "), check.loop_kind)
}
