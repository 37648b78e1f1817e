//! Lewis test: a team's recordings as a regression suite (`lewis test PATH...`). Every run
//! found under the paths is replayed with `--check` (and `--all` where the loop closes),
//! plus the fault sweeps a small TOML file declares ([`faults`]) with what must hold at
//! their points; the verdicts go to a JUnit file, a JSON file and a self-contained HTML
//! page.
//!
//! The work is a [`plan`] of independent jobs (a run's check, a sweep's point), so that one
//! machine runs them on threads and a scheduler (Slurm's job arrays, Kubernetes' Indexed
//! Jobs, a CI matrix) runs them anywhere: each job writes a result file ([`run`]), and
//! [`report::merge`] joins them into the same report, byte for byte, naming every job that
//! left none.
//!
//! This crate owns the suite: finding runs, importing other software's logs through
//! `lewis-formats`, the plan, the verdicts, the accepted results ([`expected`]) and the
//! reports. It does not replay (`lewis-replay` does, called as a library), draw a mission
//! (the caller passes a picture drawer: the viewer is the binary's), or parse a command
//! line.

pub mod discover;
pub mod expected;
pub mod faults;
pub mod html;
pub mod junit;
pub mod plan;
pub mod report;
pub mod run;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::plan::Plan;
use crate::report::SuiteReport;
use crate::run::read_timing;

/// The report files, in the output folder.
pub const JUNIT_FILE: &str = "report.xml";
/// The report as JSON.
pub const JSON_FILE: &str = "report.json";
/// The page.
pub const HTML_FILE: &str = "report.html";
/// The jobs' wall times: never compared, kept apart from the reports.
pub const TIMING_FILE: &str = "timing.json";
/// The plan, in the output folder of a run on one machine and where `--merge DIR` looks.
pub const PLAN_FILE: &str = "plan.json";

/// Why the suite cannot go on.
#[derive(Debug, thiserror::Error)]
pub enum SuiteError {
    /// A file cannot be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A file cannot be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The plan cannot be used.
    #[error("{path} is not a plan of `lewis test --plan`: {reason}")]
    NotAPlan {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A job number beyond the plan.
    #[error("the plan has {count} jobs, numbered 0 to {}: there is no job {index}", count.saturating_sub(1))]
    NoSuchJob {
        /// The number asked for.
        index: usize,
        /// How many there are.
        count: usize,
    },
}

/// Where the report files went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The JUnit file.
    pub junit: PathBuf,
    /// The JSON report.
    pub json: PathBuf,
    /// The page.
    pub html: PathBuf,
    /// The timing file.
    pub timing: PathBuf,
}

/// Writes the reports of `report` (the plan in `dir`) into `out`: JUnit, JSON, the page
/// (with the runs' pictures `pictures` draws) and the jobs' wall times.
///
/// # Errors
/// When a file cannot be written.
pub fn write_reports(
    plan: &Plan,
    report: &SuiteReport,
    dir: &Path,
    out: &Path,
    pictures: html::Pictures<'_>,
) -> Result<Written, SuiteError> {
    let written = Written {
        junit: out.join(JUNIT_FILE),
        json: out.join(JSON_FILE),
        html: out.join(HTML_FILE),
        timing: out.join(TIMING_FILE),
    };
    write_file(&written.junit, &junit::to_junit(report))?;
    write_file(&written.json, &report.to_json())?;
    let plots = |sweep: &lewis_replay::sweep::Sweep| sweep.png(Path::new("sweep.png")).ok();
    write_file(&written.html, &html::to_html(report, &plots, pictures))?;
    write_file(&written.timing, &timing_json(plan, dir))?;
    Ok(written)
}

/// The jobs' wall times, as JSON: each job's, its overhead (the time outside the replay),
/// and the sums.
#[must_use]
pub fn timing_json(plan: &Plan, dir: &Path) -> String {
    #[derive(Serialize)]
    struct Timing {
        jobs: Vec<run::JobTiming>,
        missing: Vec<usize>,
        total_wall_ms: f64,
        total_overhead_ms: f64,
    }
    let mut timing = Timing {
        jobs: Vec::new(),
        missing: Vec::new(),
        total_wall_ms: 0.0,
        total_overhead_ms: 0.0,
    };
    for job in &plan.jobs {
        match read_timing(dir, job.index) {
            Some(t) => {
                timing.total_wall_ms += t.wall_ms;
                timing.total_overhead_ms += t.overhead_ms;
                timing.jobs.push(t);
            }
            None => timing.missing.push(job.index),
        }
    }
    to_json(&timing)
}

/// Writes the accepted results of every run of `plan` beside its recording (see
/// [`expected`]), from the `results` of its jobs; returns the files written and puts the
/// accepted results into `plan`, so that a merge judges against them.
///
/// # Errors
/// When a file cannot be written (a read-only folder of recordings).
pub fn accept(
    plan: &mut Plan,
    results: &[Option<run::JobResult>],
) -> Result<Vec<PathBuf>, SuiteError> {
    let mut written = Vec::new();
    for (r, (path, accepted)) in SuiteReport::accepted(plan, results).into_iter().enumerate() {
        let path = PathBuf::from(path);
        write_file(&path, &to_json(&accepted))?;
        if let Some(run) = plan.runs.get_mut(r) {
            run.accepted = Some(accepted);
        }
        written.push(path);
    }
    Ok(written)
}

/// `value` as pretty JSON ending with a newline: the same value gives the same bytes.
#[must_use]
#[expect(
    clippy::expect_used,
    reason = "the suite's types are strings, numbers, booleans, lists and maps with string keys: serde_json cannot fail on them"
)]
pub fn to_json(value: &impl Serialize) -> String {
    let mut text = serde_json::to_string_pretty(value).expect("serializes to JSON");
    text.push('\n');
    text
}

/// Writes `text` to `path`, making its folder, through a temporary file renamed into
/// place: a reader (a merge, a scheduler's next step) never sees half a file.
///
/// # Errors
/// When the folder or the file cannot be written.
pub fn write_file(path: &Path, text: &str) -> Result<(), SuiteError> {
    let error = |source| SuiteError::Write {
        path: path.to_owned(),
        source,
    };
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(error)?;
    }
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(format!(".{}.tmp", std::process::id()));
    let temporary = PathBuf::from(temporary);
    std::fs::write(&temporary, text).map_err(error)?;
    std::fs::rename(&temporary, path).map_err(error)
}

/// `word` as a POSIX shell reads it back: as is when it is plain, else in single quotes.
#[must_use]
pub fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./@:+=,%".contains(c));
    if plain {
        word.to_owned()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}
