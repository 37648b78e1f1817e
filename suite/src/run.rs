//! Running jobs: one (`lewis test --job N`) or all of a plan on worker threads (the
//! one-machine run), each a replay through the replay library, its result written to
//! `results/job-NNNNN.json` beside the plan and its wall time to
//! `results/job-NNNNN.timing.json` (kept apart: the results are compared byte for byte, the
//! wall time never is).

use std::path::{Path, PathBuf};
use std::time::Instant;

use lewis_replay::lockstep::Programs;
use lewis_replay::outcome::LoopKind;
use lewis_replay::resim::{ReplayOptions, ServiceSelection, replay_with};
use lewis_replay::sweep::{SweepPoint, SweepSpec, run_jobs, sweep_point};
use lewis_service::ServiceRegistry;
use serde::{Deserialize, Serialize};

use crate::plan::{Job, PLAN_FORMAT, Plan, replay_input};
use crate::{SuiteError, write_file};

/// The folder beside the plan that holds the jobs' results.
pub const RESULTS_DIR: &str = "results";

/// What one job found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobResult {
    /// [`PLAN_FORMAT`].
    pub format: u32,
    /// The job's number.
    pub index: usize,
    /// The case's id (`RUN: CASE`), to catch a result written for another plan.
    pub id: String,
    /// What the replay said.
    pub outcome: Outcome,
}

/// What a job's replay said.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Outcome {
    /// A run's check.
    Check(CheckResult),
    /// A sweep's point.
    Point(SweepPoint),
    /// The replay could not run.
    Error {
        /// Why, the error's chain.
        error: String,
    },
}

/// A check's outcome.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct CheckResult {
    /// Whether everything compared matched the recording.
    pub passed: bool,
    /// What was compared (`outputs`, `mission_only`).
    pub compared: String,
    /// The output channels beyond the tolerance.
    pub failing: Vec<String>,
    /// How the mission went otherwise than recorded, if it did.
    pub mission_differs: Option<String>,
    /// Whether the mission lived again succeeded (`None`: none was).
    pub succeeded: Option<bool>,
    /// Why, for people.
    pub reason: Option<String>,
    /// The states it went through.
    pub course: Vec<String>,
    /// `closed` or `open`, and why open.
    pub loop_kind: String,
}

/// A job's wall time, apart from its result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobTiming {
    /// The job's number.
    pub index: usize,
    /// How long it took on the machine that ran it, in ms.
    pub wall_ms: f64,
    /// The share of that time spent outside the replay (reading the plan, writing the
    /// result), in ms.
    pub overhead_ms: f64,
}

/// What jobs need to replay: the kinds and the programs of this binary.
#[derive(Clone, Copy)]
pub struct Replayer<'a> {
    /// The kinds replay can build.
    pub registry: &'a ServiceRegistry,
    /// The sub-task programs of a mission lived again.
    pub programs: &'a (dyn Programs + Sync),
}

/// The result file of job `index` of the plan in `dir`.
#[must_use]
pub fn result_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(RESULTS_DIR).join(format!("job-{index:05}.json"))
}

/// The timing file of job `index` of the plan in `dir`.
#[must_use]
pub fn timing_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(RESULTS_DIR)
        .join(format!("job-{index:05}.timing.json"))
}

/// Runs job `index` of `plan`, whose folder is `dir`, and writes its result and timing
/// files; returns the result.
///
/// # Errors
/// When there is no such job or the files cannot be written. A replay that fails is a
/// result ([`Outcome::Error`]), not an error.
pub fn run_job(
    plan: &Plan,
    dir: &Path,
    index: usize,
    replayer: Replayer<'_>,
) -> Result<JobResult, SuiteError> {
    let started = Instant::now();
    let job = plan.jobs.get(index).ok_or(SuiteError::NoSuchJob {
        index,
        count: plan.jobs.len(),
    })?;
    let replay_started = Instant::now();
    let outcome = replay_job(plan, dir, job, replayer);
    let replay_ms = replay_started.elapsed().as_secs_f64() * 1e3;
    let result = JobResult {
        format: PLAN_FORMAT,
        index,
        id: job.id(),
        outcome,
    };
    write_file(&result_path(dir, index), &crate::to_json(&result))?;
    let wall_ms = started.elapsed().as_secs_f64() * 1e3;
    let timing = JobTiming {
        index,
        wall_ms,
        overhead_ms: (wall_ms - replay_ms).max(0.0),
    };
    write_file(&timing_path(dir, index), &crate::to_json(&timing))?;
    Ok(result)
}

/// Runs every job of `plan` on `jobs` threads, results in the plan's order; `done` is
/// called with the number finished.
///
/// # Errors
/// As [`run_job`], the first in the plan's order.
pub fn run_all(
    plan: &Plan,
    dir: &Path,
    jobs: usize,
    replayer: Replayer<'_>,
    done: &(dyn Fn(usize) + Sync),
) -> Result<Vec<JobResult>, SuiteError> {
    let finished = std::sync::atomic::AtomicUsize::new(0);
    // The longest jobs first (by their expected time, then their index): a long job
    // handed out last would keep one thread busy while the others wait. `run_jobs` hands
    // the numbers out in this order and gives the results back in it; they are put back
    // in the plan's order below.
    let mut order: Vec<&Job> = plan.jobs.iter().collect();
    order.sort_by(|a, b| {
        b.expected_secs
            .total_cmp(&a.expected_secs)
            .then(a.index.cmp(&b.index))
    });
    let indexes: Vec<i64> = order
        .iter()
        .map(|j| i64::try_from(j.index).unwrap_or(i64::MAX))
        .collect();
    let results = run_jobs(&indexes, jobs, |_, index| {
        let result = usize::try_from(index)
            .map_err(|_| SuiteError::NoSuchJob {
                index: usize::MAX,
                count: plan.jobs.len(),
            })
            .and_then(|index| run_job(plan, dir, index, replayer));
        done(finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
        result
    });
    let mut results: Vec<(usize, JobResult)> = order
        .iter()
        .map(|j| j.index)
        .zip(results)
        .map(|(index, result)| result.map(|r| (index, r)))
        .collect::<Result<_, _>>()?;
    results.sort_by_key(|(index, _)| *index);
    Ok(results.into_iter().map(|(_, r)| r).collect())
}

fn replay_job(plan: &Plan, dir: &Path, job: &Job, replayer: Replayer<'_>) -> Outcome {
    let Some(run) = plan.runs.get(job.run) else {
        return Outcome::Error {
            error: format!("the plan has no run {}", job.run),
        };
    };
    let mut options = ReplayOptions::new(vec![replay_input(run, dir)]);
    // The suite needs the reports, not the replayed recordings.
    options.write_output = false;
    options.services = if job.all {
        ServiceSelection::All
    } else {
        ServiceSelection::NonSources
    };
    match &job.point {
        None => match replay_with(
            &options,
            replayer.registry,
            Some(replayer.programs),
            &mut |_| {},
        ) {
            Ok(report) => {
                let mission = report.mission.as_ref();
                let replayed = mission.and_then(|m| m.replayed.as_ref());
                Outcome::Check(CheckResult {
                    passed: report.check.passed,
                    compared: serde_json::to_value(report.check.compared)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_owned))
                        .unwrap_or_default(),
                    failing: report.check.failing.clone(),
                    mission_differs: report.check.mission.clone(),
                    succeeded: replayed.map(|r| r.succeeded),
                    reason: replayed.map(|r| r.reason.clone()),
                    course: replayed
                        .map(|r| r.course().into_iter().map(str::to_owned).collect())
                        .unwrap_or_default(),
                    loop_kind: match mission.map(|m| &m.loop_kind) {
                        Some(LoopKind::Closed) => "closed".to_owned(),
                        Some(LoopKind::Open { because: Some(why) }) => format!("open: {why}"),
                        Some(LoopKind::Open { because: None }) | None => "open".to_owned(),
                    },
                })
            }
            Err(e) => Outcome::Error {
                error: e.to_string(),
            },
        },
        Some(point) => {
            let Some(sweep) = plan.faults.sweeps.get(point.sweep) else {
                return Outcome::Error {
                    error: format!("the plan has no sweep {}", point.sweep),
                };
            };
            let Some(kind) = sweep.fault_kind() else {
                return Outcome::Error {
                    error: format!("`{}` is no fault kind", sweep.kind),
                };
            };
            let spec = SweepSpec {
                providers: sweep.providers.clone(),
                kind,
                steps: sweep.steps,
                jobs: 1,
            };
            match sweep_point(
                &options,
                replayer.registry,
                replayer.programs,
                &spec,
                point.at_ns,
            ) {
                Ok(point) => Outcome::Point(point),
                Err(error) => Outcome::Error { error },
            }
        }
    }
}

/// The result of job `index` in `dir`: `Ok(None)` when there is none (the job did not
/// run, or did not finish).
///
/// # Errors
/// When the file is there but cannot be read or is not a result, for people.
pub fn read_result(dir: &Path, index: usize) -> Result<Option<JobResult>, String> {
    let path = result_path(dir, index);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| format!("{} is not a job's result: {e}", path.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("{} cannot be read: {e}", path.display())),
    }
}

/// The timing of job `index` in `dir`, if there is one that can be read.
#[must_use]
pub fn read_timing(dir: &Path, index: usize) -> Option<JobTiming> {
    let text = std::fs::read_to_string(timing_path(dir, index)).ok()?;
    serde_json::from_str(&text).ok()
}
