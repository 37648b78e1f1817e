//! `lewis test PATH...`: the recordings under the paths as a regression suite, with the
//! fault sweeps of a faults file; on one machine, or as a plan of jobs for a scheduler
//! (`--plan`, `--job`, `--merge`). The suite itself is `lewis-suite`'s.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lewis_service::ServiceRegistry;
use lewis_suite::plan::{Plan, PlanInputs};
use lewis_suite::report::{SuiteReport, Verdict, merge, read_results};
use lewis_suite::run::{Replayer, run_all, run_job};
use lewis_suite::{PLAN_FILE, faults, plan};

/// The environment variables a scheduler gives a job's index in: Slurm's job arrays,
/// Kubernetes' Indexed Jobs.
const INDEX_VARIABLES: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];

/// Arguments of `lewis test`.
#[derive(Debug, Args)]
#[command(
    after_help = "On one machine: `lewis test runs/ --faults faults.toml --jobs 2` writes \
    lewis-test/report.xml (JUnit), report.json, report.html and timing.json.\n\n\
    For a scheduler: `lewis test runs/ --faults faults.toml --plan shared/plan.json` writes \
    the jobs; each job runs `lewis test --job N --from shared/plan.json` (N from the flag, \
    or from SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX), and `lewis test --merge shared` \
    writes the same reports as one machine would.\n\n\
    Exit codes: 0 every expectation holds; 1 a case failed, could not run or is missing, \
    or an input was skipped for an error; 2 the suite could not run."
)]
pub struct TestArgs {
    /// Recordings (`.mcap`), CARMEN logs (`.log`, `.log.gz`), ROS 2 bags, or folders of
    /// them, searched whole.
    #[arg(value_name = "PATH", required_unless_present_any = ["job", "merge"])]
    pub paths: Vec<PathBuf>,
    /// The fault sweeps to run and what must hold at their points (TOML).
    #[arg(long, value_name = "FILE")]
    pub faults: Option<PathBuf>,
    /// Where the reports go (and, on one machine, the plan and the jobs' results).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Replays run at once on this machine (default: one per core).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    pub jobs: Option<u32>,
    /// Take this run's results as the expected ones: written beside each recording as
    /// RUN.expected.json, to be reviewed in a diff.
    #[arg(long, conflicts_with_all = ["plan", "job", "merge"])]
    pub accept: bool,
    /// Write the plan of independent jobs to this file and run nothing (imports go beside
    /// it, in imported/).
    #[arg(long, value_name = "OUT.json", conflicts_with_all = ["job", "merge"])]
    pub plan: Option<PathBuf>,
    /// Run one job of the plan given with --from and write its result beside the plan (in
    /// results/). Without N, the scheduler's index: SLURM_ARRAY_TASK_ID or
    /// JOB_COMPLETION_INDEX.
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "", requires = "from", conflicts_with = "merge")]
    pub job: Option<String>,
    /// The plan a job belongs to.
    #[arg(long, value_name = "PLAN.json", requires = "job")]
    pub from: Option<PathBuf>,
    /// Join the results of the jobs of the plan in DIR (DIR/plan.json, or the plan file
    /// itself) into the reports.
    #[arg(long, value_name = "DIR")]
    pub merge: Option<PathBuf>,
}

/// Runs `lewis test`.
pub fn run(args: &TestArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    let programs = crate::app::programs();
    let replayer = Replayer {
        registry,
        programs: &programs,
    };
    if let Some(job) = &args.job {
        let from = args.from.as_deref().unwrap_or(Path::new(PLAN_FILE));
        return run_one(job, from, replayer);
    }
    if let Some(dir) = &args.merge {
        let (plan_path, dir) = if dir.is_file() {
            let parent = dir.parent().unwrap_or(Path::new("")).to_path_buf();
            (dir.clone(), parent)
        } else {
            (dir.join(PLAN_FILE), dir.clone())
        };
        let plan = plan::read(&plan_path)?;
        let out = args.out.clone().unwrap_or_else(|| dir.clone());
        return finish(&plan, &dir, &out);
    }
    let faults = match &args.faults {
        Some(path) => faults::load(path)?,
        None => faults::FaultsFile::default(),
    };
    if let Some(plan_path) = &args.plan {
        let dir = plan_path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        let plan = make_plan(args, faults, &dir, replayer)?;
        plan::write(&plan, plan_path)?;
        let mut out = std::io::stdout().lock();
        say_skipped(&mut out, &plan)?;
        writeln!(
            out,
            "planned {} jobs over {} runs: {} (run each with `lewis test --job N --from {}`, \
             then `lewis test --merge {}`)",
            plan.jobs.len(),
            plan.runs.len(),
            plan_path.display(),
            plan_path.display(),
            dir.display()
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("lewis-test"));
    std::fs::create_dir_all(&out)
        .with_context(|| format!("cannot make the output folder {}", out.display()))?;
    // Results of an earlier suite in the same folder must not stand in for this one's.
    match std::fs::remove_dir_all(out.join(lewis_suite::run::RESULTS_DIR)) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(e).context("cannot clear the results of an earlier suite"),
    }
    let mut plan = make_plan(args, faults, &out, replayer)?;
    plan::write(&plan, &out.join(PLAN_FILE))?;
    let jobs = args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
        |n| n as usize,
    );
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(plan.jobs.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "testing {bar:40} {pos}/{len} replays ({elapsed} elapsed, {eta} left)",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let done = |count: usize| {
        if let Some(bar) = &bar {
            bar.set_position(count as u64);
        }
    };
    let ran = run_all(&plan, &out, jobs, replayer, &done);
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    ran?;
    if args.accept {
        let (results, _) = read_results(&plan, &out);
        let written = lewis_suite::accept(&mut plan, &results)?;
        plan::write(&plan, &out.join(PLAN_FILE))?;
        let mut stdout = std::io::stdout().lock();
        for path in written {
            writeln!(stdout, "accepted: {}", path.display())?;
        }
    }
    finish(&plan, &out, &out)
}

/// Plans the suite of `args`, imports in `dir`.
fn make_plan(
    args: &TestArgs,
    faults: faults::FaultsFile,
    dir: &Path,
    replayer: Replayer<'_>,
) -> anyhow::Result<Plan> {
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new_spinner();
        bar.set_message("planning: reading the recordings, importing logs");
        bar.enable_steady_tick(std::time::Duration::from_millis(200));
        bar
    });
    let plan = plan::plan(&PlanInputs {
        paths: &args.paths,
        faults,
        dir,
        registry: replayer.registry,
        programs: replayer.programs,
    });
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    Ok(plan?)
}

/// `lewis test --job N --from PLAN`.
fn run_one(job: &str, from: &Path, replayer: Replayer<'_>) -> anyhow::Result<ExitCode> {
    let text = if job.is_empty() {
        INDEX_VARIABLES
            .iter()
            .find_map(|name| std::env::var(name).ok())
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "--job without N: give the job's number, or run it where {} says it",
                    INDEX_VARIABLES.join(" or ")
                )
            })?
    } else {
        job.to_owned()
    };
    let index: usize = text
        .trim()
        .parse()
        .map_err(|_| anyhow::anyhow!("job `{text}` is not a number: give the job's index"))?;
    let plan = plan::read(from)?;
    let dir = from
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let result = run_job(&plan, dir, index, replayer)?;
    writeln!(
        std::io::stdout().lock(),
        "job {index}: {}: {}",
        result.id,
        match &result.outcome {
            lewis_suite::run::Outcome::Check(c) if c.passed => "replayed, matches",
            lewis_suite::run::Outcome::Check(_) => "replayed, differs",
            lewis_suite::run::Outcome::Point(p) if p.succeeded => "replayed, mission succeeded",
            lewis_suite::run::Outcome::Point(_) => "replayed, mission failed",
            lewis_suite::run::Outcome::Error { .. } => "could not replay",
        }
    )?;
    Ok(ExitCode::SUCCESS)
}

/// Merges the results in `dir`, writes the reports into `out`, prints the summary.
fn finish(plan: &Plan, dir: &Path, out: &Path) -> anyhow::Result<ExitCode> {
    let (results, problems) = read_results(plan, dir);
    let report = merge(plan, &results, &problems);
    let pictures_dir = out.join("pictures");
    let pictures = |name: &str| picture(plan, dir, &pictures_dir, name);
    let written = lewis_suite::write_reports(plan, &report, dir, out, &pictures)?;
    let mut stdout = std::io::stdout().lock();
    say(&mut stdout, &report)?;
    writeln!(
        stdout,
        "written: {}, {}, {} (wall times: {})",
        written.junit.display(),
        written.json.display(),
        written.html.display(),
        written.timing.display()
    )?;
    Ok(if report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn say_skipped(out: &mut dyn Write, plan: &Plan) -> std::io::Result<()> {
    for s in &plan.skipped {
        let label = if s.error { "error" } else { "skipped" };
        writeln!(out, "{label}: {}: {}", s.what, s.reason)?;
    }
    Ok(())
}

/// One line per case that did not pass, the skipped inputs, then the totals.
fn say(out: &mut dyn Write, report: &SuiteReport) -> std::io::Result<()> {
    for run in &report.runs {
        for case in &run.cases {
            if case.verdict == Verdict::Passed {
                continue;
            }
            writeln!(
                out,
                "{}: {}: {}: {}\n  reproduce: {}",
                run.name,
                case.name,
                case.verdict.word(),
                case.reason,
                case.command
            )?;
        }
    }
    for s in &report.skipped {
        let label = if s.error { "error" } else { "skipped" };
        writeln!(out, "{label}: {}: {}", s.what, s.reason)?;
    }
    let t = &report.totals;
    writeln!(
        out,
        "{}: {} runs, {} cases: {} passed, {} failed, {} known failures, {} errors; {} skipped",
        if report.passed { "passed" } else { "FAILED" },
        report.runs.len(),
        t.cases,
        t.passed,
        t.failed,
        t.known_failures,
        t.errors,
        t.skipped
    )
}

/// The mission's picture of the run `name`, when this binary has the viewer.
#[cfg(feature = "viewer")]
fn picture(plan: &Plan, dir: &Path, pictures: &Path, name: &str) -> Option<Vec<u8>> {
    let (index, run) = plan.runs.iter().enumerate().find(|(_, r)| r.name == name)?;
    std::fs::create_dir_all(pictures).ok()?;
    let png = pictures.join(format!("run-{index:04}.png"));
    lewis_viewer::write_png(&plan::replay_input(run, dir), &png).ok()?;
    std::fs::read(&png).ok()
}

/// Without the viewer, no picture.
#[cfg(not(feature = "viewer"))]
fn picture(_plan: &Plan, _dir: &Path, _pictures: &Path, _name: &str) -> Option<Vec<u8>> {
    None
}
