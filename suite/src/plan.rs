//! The plan of a suite: every run found under the paths, what each can be replayed as,
//! and the list of independent jobs (a run's check, a sweep's point), as JSON
//! (`lewis test --plan OUT.json`) that any scheduler can hand out by index.
//!
//! Planning opens every recording (its summary, its robot and its recorded mission: not its
//! messages), imports CARMEN logs and ROS 2 bags into `imported/` beside the plan, checks
//! the sweeps against each run (unknown providers, states the mission does not have) and
//! places the sweeps' points. What cannot be used is listed in [`Plan::skipped`] with
//! why; everything else is planned. The same paths, files and faults file give the same
//! plan, byte for byte, wherever it is written: paths are kept as the user gave them, an
//! import's as relative to the plan's folder.

use std::path::{Path, PathBuf};

use lewis_formats::import::carmen::{CarmenImport, ImportOptions, SonarOptions};
use lewis_formats::import::record::{WriteOptions, write_carmen, write_ros2};
use lewis_formats::import::ros2;
use lewis_recorder::Compression;
use lewis_recording::{Recording, RecordingError};
use lewis_replay::fault::format_seconds;
use lewis_replay::lockstep::Programs;
use lewis_replay::outcome::MissionOutcome;
use lewis_replay::resim::{ReplayOptions, ServiceSelection, prepare};
use lewis_replay::sweep::fault_times;
use lewis_service::ServiceRegistry;
use serde::{Deserialize, Serialize};

use crate::expected::{Accepted, expected_path};
use crate::faults::{FaultsFile, When};
use crate::{SuiteError, write_file};

/// The version of the plan's and the results' format: a job refuses a plan of another.
pub const PLAN_FORMAT: u32 = 1;

/// The folder beside the plan that holds the imported recordings.
pub const IMPORTED_DIR: &str = "imported";

/// The plan of a suite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// [`PLAN_FORMAT`].
    pub format: u32,
    /// The runs that can be replayed, sorted by name.
    pub runs: Vec<Run>,
    /// The faults file's sweeps and known failures (none without `--faults`).
    pub faults: FaultsFile,
    /// What was left out, and why.
    pub skipped: Vec<Skipped>,
    /// The jobs, numbered from 0 in this order.
    pub jobs: Vec<Job>,
}

/// A run of the suite.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Run {
    /// Its name: the file as the paths name it.
    pub name: String,
    /// The recording replayed: the file itself, or its import relative to the plan's
    /// folder.
    pub input: String,
    /// How it was imported, if it was.
    pub import: Option<Import>,
    /// The recording's length.
    pub duration_ns: i64,
    /// The recorded robot's name.
    pub robot: String,
    /// Its services, in the robot file's order.
    pub services: Vec<String>,
    /// Whether a mission can be lived again (`--all` closes the loop).
    pub closed: bool,
    /// Why the loop cannot be closed, if asked and it cannot.
    pub open_because: Option<String>,
    /// The recorded mission, if there is one.
    pub mission: Option<RecordedMission>,
    /// The results accepted for it (`--accept`), read from beside it.
    pub accepted: Option<Accepted>,
    /// Where the accepted results are kept.
    pub expected_file: String,
}

/// How a run was imported from another robot software's file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Import {
    /// `carmen` or `ros2`.
    pub format: String,
    /// The name of the imported recording in the commands that reproduce a job.
    pub file_name: String,
}

/// The recorded mission, as far as a plan needs it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RecordedMission {
    /// Whether it succeeded.
    pub succeeded: bool,
    /// Why, for people.
    pub reason: String,
    /// How long it took, from its first record to its end (`None`: it did not end).
    pub time_to_finish_ns: Option<i64>,
    /// The states visited, in order, times from the start of the recording.
    pub states: Vec<StateSpan>,
}

/// A visit of a state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateSpan {
    /// The state.
    pub state: String,
    /// When it was entered.
    pub started_ns: i64,
    /// When it was left, if it was.
    pub ended_ns: Option<i64>,
}

impl RecordedMission {
    /// The state the mission was in at `at_ns`.
    #[must_use]
    pub fn state_at(&self, at_ns: i64) -> Option<&str> {
        self.states
            .iter()
            .rev()
            .find(|s| s.started_ns <= at_ns)
            .map(|s| s.state.as_str())
    }

    /// Whether `at_ns` is `when` the first visit of `state` (`None`: no such state).
    #[must_use]
    pub fn is(&self, at_ns: i64, when: When, state: &str) -> Option<bool> {
        let visit = self.states.iter().find(|s| s.state == state)?;
        Some(match when {
            When::Before => at_ns < visit.started_ns,
            When::During => {
                at_ns >= visit.started_ns && visit.ended_ns.is_none_or(|end| at_ns < end)
            }
            When::After => visit.ended_ns.is_some_and(|end| at_ns >= end),
        })
    }
}

/// Something the suite could not use.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Skipped {
    /// The path, or `RUN: SWEEP`.
    pub what: String,
    /// Why.
    pub reason: String,
    /// Whether it is an error (a file that cannot be replayed, a sweep that names what the
    /// run does not have) rather than a sweep that does not apply (a run without a mission
    /// to live again).
    pub error: bool,
}

/// One job: a run's check, or one point of a sweep over it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// Its number (the scheduler's index).
    pub index: usize,
    /// The run, by its place in [`Plan::runs`].
    pub run: usize,
    /// The recording, as the run names it.
    pub recording: String,
    /// The case's name in the reports: `check`, or `SWEEP @ TIME`.
    pub case: String,
    /// The fault of a sweep's point.
    pub point: Option<Point>,
    /// Whether the replay lives the mission again (`--all`).
    pub all: bool,
    /// What the job should take, in seconds: the recording's length (twice it for a point,
    /// whose mission may run on past the end).
    pub expected_secs: f64,
    /// The command that reproduces it on one's own machine.
    pub command: String,
}

impl Job {
    /// The case's id, which known failures match: `RUN: CASE`.
    #[must_use]
    pub fn id(&self) -> String {
        format!("{}: {}", self.recording, self.case)
    }
}

/// The fault of a sweep's point.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Point {
    /// The sweep, by its place in the faults file.
    pub sweep: usize,
    /// When the providers fail, from the start of the recording.
    pub at_ns: i64,
    /// The state of the recorded mission then.
    pub state: Option<String>,
    /// The sweep's expectations that apply here, by their place.
    pub expect: Vec<usize>,
}

/// What a plan is made of: the recordings and logs under `paths`, the faults file's sweeps;
/// `dir` is the plan's folder (imports go to `dir/imported`).
pub struct PlanInputs<'a> {
    /// Files and folders to look in.
    pub paths: &'a [PathBuf],
    /// The faults file, checked.
    pub faults: FaultsFile,
    /// The plan's folder, never searched.
    pub dir: &'a Path,
    /// The kinds replay can build.
    pub registry: &'a ServiceRegistry,
    /// The sub-task programs of a mission lived again.
    pub programs: &'a dyn Programs,
}

/// Makes the plan.
///
/// # Errors
/// Only when the plan's folder cannot be written to (an import); every problem of a file
/// is a [`Skipped`] of the plan.
pub fn plan(inputs: &PlanInputs<'_>) -> Result<Plan, SuiteError> {
    let mut skipped = Vec::new();
    let mut files = Vec::new();
    for path in inputs.paths {
        let found = crate::discover::find(path, inputs.dir);
        match found {
            Ok(found) if found.is_empty() => skipped.push(Skipped {
                what: path.display().to_string(),
                reason: "no recordings here (looked for .mcap, .log and .log.gz files)".to_owned(),
                error: true,
            }),
            Ok(found) => files.extend(found),
            Err(reason) => skipped.push(Skipped {
                what: path.display().to_string(),
                reason,
                error: true,
            }),
        }
    }
    files.sort();
    files.dedup();
    let mut runs = Vec::new();
    for (number, file) in files.iter().enumerate() {
        match open_run(file, number, inputs)? {
            Ok(run) => runs.push(run),
            Err(reason) => skipped.push(Skipped {
                what: file.display().to_string(),
                reason,
                error: true,
            }),
        }
    }
    let mut jobs = Vec::new();
    for (r, run) in runs.iter().enumerate() {
        jobs.push(Job {
            index: jobs.len(),
            run: r,
            recording: run.name.clone(),
            case: "check".to_owned(),
            point: None,
            all: run.closed,
            expected_secs: secs(run.duration_ns),
            command: command(run, run.closed, &[], true),
        });
        for (s, sweep) in inputs.faults.sweeps.iter().enumerate() {
            if !sweep.applies_to(&run.name) {
                continue;
            }
            let what = format!("{}: {}", run.name, sweep.name);
            let mission = match (&run.mission, run.closed) {
                (Some(mission), true) => mission,
                (None, _) => {
                    skipped.push(Skipped {
                        what,
                        reason: "the recording holds no mission: a sweep judges a mission \
                                 lived again"
                            .to_owned(),
                        error: !sweep.runs.is_empty(),
                    });
                    continue;
                }
                (Some(_), false) => {
                    skipped.push(Skipped {
                        what,
                        reason: format!(
                            "the mission cannot be lived again: {}",
                            run.open_because.as_deref().unwrap_or("open loop")
                        ),
                        error: !sweep.runs.is_empty(),
                    });
                    continue;
                }
            };
            if let Err(reason) = check_sweep(sweep, run, mission) {
                skipped.push(Skipped {
                    what,
                    reason,
                    error: true,
                });
                continue;
            }
            for at_ns in fault_times(0, run.duration_ns, sweep.steps) {
                let expect = sweep
                    .expect
                    .iter()
                    .enumerate()
                    .filter(|(_, e)| mission.is(at_ns, e.when, &e.state) == Some(true))
                    .map(|(i, _)| i)
                    .collect();
                let faults: Vec<String> = sweep
                    .providers
                    .iter()
                    .map(|p| format!("{p}@{}:{}", format_seconds(at_ns), sweep.kind))
                    .collect();
                jobs.push(Job {
                    index: jobs.len(),
                    run: r,
                    recording: run.name.clone(),
                    case: format!("{} @ {}", sweep.name, format_seconds(at_ns)),
                    point: Some(Point {
                        sweep: s,
                        at_ns,
                        state: mission.state_at(at_ns).map(str::to_owned),
                        expect,
                    }),
                    all: true,
                    expected_secs: 2.0 * secs(run.duration_ns),
                    command: command(run, true, &faults, false),
                });
            }
        }
    }
    Ok(Plan {
        format: PLAN_FORMAT,
        runs,
        faults: inputs.faults.clone(),
        skipped,
        jobs,
    })
}

/// Whether `sweep` can run over `run`: its providers are services of the robot, its
/// expectations' states are states of the mission.
fn check_sweep(
    sweep: &crate::faults::SweepDecl,
    run: &Run,
    mission: &RecordedMission,
) -> Result<(), String> {
    for provider in &sweep.providers {
        if !run.services.contains(provider) {
            let near = lewis_stdx::closest(provider, run.services.iter().map(String::as_str))
                .map(|n| format!(" (did you mean `{n}`?)"))
                .unwrap_or_default();
            return Err(format!(
                "the provider `{provider}` is no service of the robot `{}`{near}; it has: {}",
                run.robot,
                run.services.join(", ")
            ));
        }
    }
    for e in &sweep.expect {
        if !mission.states.iter().any(|s| s.state == e.state) {
            let visited: Vec<&str> = mission.states.iter().map(|s| s.state.as_str()).collect();
            return Err(format!(
                "an expectation names the state `{}`, which the recorded mission never \
                 entered; it went through: {}",
                e.state,
                visited.join(", ")
            ));
        }
    }
    Ok(())
}

/// The file a run's replay reads.
#[must_use]
pub fn replay_input(run: &Run, dir: &Path) -> PathBuf {
    if run.import.is_some() {
        dir.join(&run.input)
    } else {
        PathBuf::from(&run.input)
    }
}

/// Opens (importing first, if need be) the file `file`, the `number`th found: the run, or
/// why it cannot be one. Only a failure to write into the plan's folder is an error.
fn open_run(
    file: &Path,
    number: usize,
    inputs: &PlanInputs<'_>,
) -> Result<Result<Run, String>, SuiteError> {
    let name = file.display().to_string();
    let lower = name.to_ascii_lowercase();
    let is_log = lower.ends_with(".log") || lower.ends_with(".log.gz");
    let (input, import) = if is_log {
        match import(file, number, "carmen", inputs.dir)? {
            Ok(import) => import,
            Err(reason) => return Ok(Err(reason)),
        }
    } else {
        match Recording::open(&[file.to_path_buf()]) {
            Ok(_) => (name.clone(), None),
            Err(RecordingError::NoRobot { origin, .. }) if origin.contains("ros2") => {
                match import(file, number, "ros2", inputs.dir)? {
                    Ok(import) => import,
                    Err(reason) => return Ok(Err(reason)),
                }
            }
            Err(e) => return Ok(Err(e.to_string())),
        }
    };
    let path = if import.is_some() {
        inputs.dir.join(&input)
    } else {
        PathBuf::from(&input)
    };
    let recording = match Recording::open(std::slice::from_ref(&path)) {
        Ok(recording) => recording,
        Err(e) => return Ok(Err(e.to_string())),
    };
    let mut options = ReplayOptions::new(vec![path.clone()]);
    options.services = ServiceSelection::All;
    let prepared = match prepare(&recording, &options, inputs.registry, Some(inputs.programs)) {
        Ok(prepared) => prepared,
        Err(e) => return Ok(Err(format!("cannot be replayed: {e}"))),
    };
    let (start_ns, end_ns) = (recording.start_ns(), recording.end_ns());
    let closure = &prepared.closure;
    let mission = (!closure.recorded.is_empty()).then(|| {
        let outcome = MissionOutcome::of(&closure.recorded, start_ns, None, None);
        RecordedMission {
            succeeded: outcome.succeeded,
            reason: outcome.reason,
            time_to_finish_ns: outcome.time_to_finish_ns,
            states: outcome
                .states
                .iter()
                .map(|v| StateSpan {
                    state: v.state.clone(),
                    started_ns: v.started_ns,
                    ended_ns: v.ended_ns,
                })
                .collect(),
        }
    });
    let expected_file = expected_path(file);
    let accepted = match crate::expected::read(&expected_file) {
        Ok(accepted) => accepted,
        Err(reason) => return Ok(Err(reason)),
    };
    Ok(Ok(Run {
        name,
        input,
        import,
        duration_ns: end_ns - start_ns,
        robot: recording.robot().name.clone(),
        services: recording
            .robot()
            .services
            .iter()
            .map(|s| s.name.clone())
            .collect(),
        closed: closure.is_closed() && closure.mission.is_some(),
        open_because: closure.open_because.clone(),
        mission,
        accepted,
        expected_file: expected_file.display().to_string(),
    }))
}

/// Imports `file` (a CARMEN log or a ROS 2 bag, `format`) into the plan's folder: the
/// replay's input relative to it and the import, or why it cannot be imported.
fn import(
    file: &Path,
    number: usize,
    format: &str,
    dir: &Path,
) -> Result<Result<(String, Option<Import>), String>, SuiteError> {
    let file_name = file
        .file_name()
        .map_or_else(|| "import".to_owned(), |f| f.to_string_lossy().into_owned());
    let stem = ["-lewis.mcap", ".mcap", ".gz", ".log"]
        .iter()
        .fold(file_name.as_str(), |s, suffix| {
            s.strip_suffix(suffix).unwrap_or(s)
        })
        .to_owned();
    let imported_name = format!("{stem}.mcap");
    // Numbered: two logs of one name in two folders do not meet.
    let relative = format!("{IMPORTED_DIR}/{number:04}-{imported_name}");
    let output = dir.join(&relative);
    if let Some(parent) = output.parent() {
        std::fs::create_dir_all(parent).map_err(|source| SuiteError::Write {
            path: parent.to_owned(),
            source,
        })?;
    }
    // A plan made again imports again: the log may have changed, and the writers never
    // replace a file.
    match std::fs::remove_file(&output) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(source) => {
            return Err(SuiteError::Write {
                path: output,
                source,
            });
        }
    }
    let result = match format {
        "carmen" => {
            let options = ImportOptions {
                sonar: Some(SonarOptions::default()),
                ..ImportOptions::default()
            };
            CarmenImport::open(file, options)
                .map_err(|e| format!("cannot be imported as a CARMEN log: {e}"))
                .and_then(|import| {
                    write_carmen(&import, &WriteOptions::new(&output), &mut |_| {})
                        .map(|_| ())
                        .map_err(|e| format!("cannot be imported as a CARMEN log: {e}"))
                })
        }
        _ => {
            let options = ros2::ImportOptions {
                sonar: Some(SonarOptions::default()),
                ..ros2::ImportOptions::default()
            };
            ros2::Ros2Import::open(file, &options)
                .map_err(|e| format!("cannot be imported as a ROS 2 bag: {e}"))
                .and_then(|import| {
                    write_ros2(&import, &output, Compression::Zstd, &mut |_| {})
                        .map(|_| ())
                        .map_err(|e| format!("cannot be imported as a ROS 2 bag: {e}"))
                })
        }
    };
    Ok(result.map(|()| {
        (
            relative,
            Some(Import {
                format: format.to_owned(),
                file_name: imported_name,
            }),
        )
    }))
}

/// The command that reproduces a replay of `run` on one's own machine.
fn command(run: &Run, all: bool, faults: &[String], check: bool) -> String {
    let quoted = |s: &str| crate::shell_word(s);
    let (prefix, input) = match &run.import {
        Some(import) => (
            format!(
                "lewis import {} {} -o {} && ",
                import.format,
                quoted(&run.name),
                quoted(&import.file_name)
            ),
            quoted(&import.file_name),
        ),
        None => (String::new(), quoted(&run.name)),
    };
    let mut text = format!("{prefix}lewis replay {input}");
    if all {
        text.push_str(" --all");
    }
    if check {
        text.push_str(" --check");
    }
    for fault in faults {
        text.push_str(" --inject-fault ");
        text.push_str(&quoted(fault));
    }
    text
}

// For a plan's estimate only.
fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

/// Writes `plan` as pretty JSON to `path`.
///
/// # Errors
/// When the file cannot be written.
pub fn write(plan: &Plan, path: &Path) -> Result<(), SuiteError> {
    write_file(path, &crate::to_json(plan))
}

/// Reads the plan at `path`.
///
/// # Errors
/// When it cannot be read, is not a plan, or is of another format.
pub fn read(path: &Path) -> Result<Plan, SuiteError> {
    let text = std::fs::read_to_string(path).map_err(|source| SuiteError::Read {
        path: path.to_owned(),
        source,
    })?;
    let plan: Plan = serde_json::from_str(&text).map_err(|e| SuiteError::NotAPlan {
        path: path.to_owned(),
        reason: e.to_string(),
    })?;
    if plan.format != PLAN_FORMAT {
        return Err(SuiteError::NotAPlan {
            path: path.to_owned(),
            reason: format!(
                "it is of format {}, this lewis reads format {PLAN_FORMAT}: plan again",
                plan.format
            ),
        });
    }
    Ok(plan)
}
