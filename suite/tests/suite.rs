//! The suite end to end, in the library: small recorded missions planned, run on threads
//! and as separate jobs, merged and judged.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod fixture;

use std::path::{Path, PathBuf};

use lewis_suite::faults::{self, FaultsFile};
use lewis_suite::plan::{Plan, PlanInputs, plan};
use lewis_suite::report::{SuiteReport, merge, read_results};
use lewis_suite::run::{Replayer, run_all, run_job};

use fixture::{TestPrograms, registry};

/// Plans `paths` with the faults file `faults` (TOML) into `dir`.
fn plan_in(dir: &Path, paths: &[PathBuf], faults: &str) -> Plan {
    let file = dir.join("faults.toml");
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(&file, faults).unwrap();
    let faults: FaultsFile = faults::load(&file).unwrap();
    plan(&PlanInputs {
        paths,
        faults,
        dir,
        registry: &registry(),
        programs: &TestPrograms,
    })
    .unwrap()
}

/// Runs every job of `plan` on `jobs` threads and merges.
fn run_here(plan: &Plan, dir: &Path, jobs: usize) -> SuiteReport {
    let registry = registry();
    let replayer = Replayer {
        registry: &registry,
        programs: &TestPrograms,
    };
    run_all(plan, dir, jobs, replayer, &|_| {}).unwrap();
    let (results, problems) = read_results(plan, dir);
    merge(plan, &results, &problems)
}

const SWEEPS: &str = r#"
[[sweep]]
name = "laser dies"
providers = ["laser"]
steps = 4
expect = [{ after = "look", mission = "succeeds" }]

[[sweep]]
name = "both die"
providers = ["laser", "sonar"]
steps = 4
expect = [{ before = "look", mission = "fails" }]
"#;

/// A folder of runs with one recorded mission, `runs/a.mcap`.
fn runs(dir: &Path) -> PathBuf {
    let runs = dir.join("runs");
    std::fs::create_dir_all(&runs).unwrap();
    fixture::recorded_mission(&runs, "a");
    runs
}

/// The report files of `dir`, as bytes.
fn report_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    ["report.xml", "report.json", "report.html"]
        .iter()
        .map(|f| (f.to_string(), std::fs::read(dir.join(f)).unwrap()))
        .collect()
}

fn no_pictures(_: &str) -> Option<Vec<u8>> {
    None
}

#[test]
fn expectations_that_hold_pass_and_every_point_is_a_case() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let out = dir.path().join("out");
    let plan = plan_in(&out, &[runs], SWEEPS);
    // A check and 4 points of each sweep; the points before `look` and after it carry the
    // expectations that apply there.
    assert_eq!(plan.jobs.len(), 9, "{}", lewis_suite::to_json(&plan));
    let expectations: Vec<(String, usize)> = plan
        .jobs
        .iter()
        .map(|j| {
            (
                j.case.clone(),
                j.point.as_ref().map_or(0, |p| p.expect.len()),
            )
        })
        .collect();
    assert_eq!(
        expectations,
        [
            ("check", 0),
            ("laser dies @ 0.25s", 0),
            ("laser dies @ 0.75s", 0),
            ("laser dies @ 1.25s", 1),
            ("laser dies @ 1.75s", 1),
            ("both die @ 0.25s", 1),
            ("both die @ 0.75s", 0),
            ("both die @ 1.25s", 0),
            ("both die @ 1.75s", 0),
        ]
        .map(|(c, n)| (c.to_owned(), n))
    );
    let report = run_here(&plan, &out, 2);
    assert!(report.passed, "{}", report.to_json());
    assert_eq!(report.totals.cases, 9);
    assert_eq!(report.runs[0].sweeps.len(), 2);
    let both = &report.runs[0].cases[5];
    assert!(
        both.reason.contains("the mission failed"),
        "{}",
        both.reason
    );
}

#[test]
fn one_machine_on_two_threads_and_separate_jobs_merged_give_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let here = dir.path().join("here");
    let plan_here = plan_in(&here, std::slice::from_ref(&runs), SWEEPS);
    let report = run_here(&plan_here, &here, 2);
    lewis_suite::write_reports(&plan_here, &report, &here, &here, &no_pictures).unwrap();

    // As a job array would: the plan elsewhere, each job on its own, in any order.
    let array = dir.path().join("array");
    let plan = plan_in(&array, &[runs], SWEEPS);
    let registry = registry();
    let replayer = Replayer {
        registry: &registry,
        programs: &TestPrograms,
    };
    for index in (0..plan.jobs.len()).rev() {
        let plan = lewis_suite::plan::read(&{
            let path = array.join("plan.json");
            lewis_suite::plan::write(&plan, &path).unwrap();
            path
        })
        .unwrap();
        run_job(&plan, &array, index, replayer).unwrap();
    }
    let (results, problems) = read_results(&plan, &array);
    assert!(problems.is_empty(), "{problems:?}");
    let merged = merge(&plan, &results, &problems);
    lewis_suite::write_reports(&plan, &merged, &array, &array, &no_pictures).unwrap();
    assert_eq!(report_files(&here), report_files(&array));
}

#[test]
fn an_expectation_that_does_not_hold_fails_with_the_run_time_state_and_command() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let out = dir.path().join("out");
    let plan = plan_in(
        &out,
        std::slice::from_ref(&runs),
        "[[sweep]]\nproviders = [\"laser\", \"sonar\"]\nsteps = 4\n\
         expect = [{ before = \"look\", mission = \"succeeds\" }]\n",
    );
    let report = run_here(&plan, &out, 1);
    assert!(!report.passed);
    assert_eq!(report.totals.failed, 1, "{}", report.to_json());
    let failed = report.runs[0]
        .cases
        .iter()
        .find(|c| c.verdict == lewis_suite::report::Verdict::Failed)
        .unwrap();
    assert_eq!(failed.name, "laser+sonar crash @ 0.25s");
    assert!(
        failed.reason.starts_with(
            "expected: the mission succeeds when the fault strikes before `look`; at 0.25s \
             the mission failed: it reached `stop` through the recovery state `oops`"
        ),
        "{}",
        failed.reason
    );
    let run = runs.join("a.mcap").display().to_string();
    assert_eq!(
        failed.command,
        format!(
            "lewis replay {run} --all --inject-fault laser@0.25s:crash --inject-fault \
             sonar@0.25s:crash"
        )
    );
    let junit = lewis_suite::junit::to_junit(&report);
    assert!(
        junit.contains(
            "<failure type=\"expectation\" message=\"expected: the mission succeeds when the \
             fault strikes before `look`; at 0.25s the mission failed"
        ),
        "{junit}"
    );
    assert!(
        junit.contains(&format!("run: {run}\ntime: 0.25s\n")),
        "{junit}"
    );
    assert!(junit.contains("reproduce: lewis replay"), "{junit}");
}

#[test]
fn a_missing_job_is_reported_as_an_error_never_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let out = dir.path().join("out");
    let plan = plan_in(&out, &[runs], SWEEPS);
    run_here(&plan, &out, 2);
    std::fs::remove_file(lewis_suite::run::result_path(&out, 3)).unwrap();
    std::fs::write(lewis_suite::run::result_path(&out, 4), "{ cut sho").unwrap();
    let (results, problems) = read_results(&plan, &out);
    let report = merge(&plan, &results, &problems);
    assert!(!report.passed);
    assert_eq!(report.totals.cases, 9);
    assert_eq!(report.totals.errors, 2);
    let reasons: Vec<&str> = report.runs[0].cases[3..5]
        .iter()
        .map(|c| c.reason.as_str())
        .collect();
    assert!(
        reasons[0].starts_with("job 3 left no result"),
        "{reasons:?}"
    );
    assert!(reasons[1].contains("is not a job's result"), "{reasons:?}");
}

#[test]
fn bad_inputs_are_named_with_why_and_the_rest_still_runs() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    std::fs::write(runs.join("notes.mcap"), "not a recording").unwrap();
    let whole = std::fs::read(runs.join("a.mcap")).unwrap();
    std::fs::write(runs.join("cut.mcap"), &whole[..whole.len() / 2]).unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let out = dir.path().join("out");
    let plan = plan_in(
        &out,
        &[runs.clone(), empty.clone()],
        "[[sweep]]\nproviders = [\"lazer\"]\nsteps = 2\n",
    );
    let report = run_here(&plan, &out, 2);
    assert!(!report.passed);
    assert_eq!(report.totals.cases, 1, "the check of a.mcap still runs");
    assert!(report.runs[0].cases[0].verdict == lewis_suite::report::Verdict::Passed);
    let skipped: Vec<(String, String)> = report
        .skipped
        .iter()
        .map(|s| {
            let what = s.what.replace(&dir.path().display().to_string(), "DIR");
            let reason = s.reason.replace(&dir.path().display().to_string(), "DIR");
            (what, reason)
        })
        .collect();
    assert_eq!(
        skipped,
        [
            (
                "DIR/empty",
                "no recordings here (looked for .mcap, .log and .log.gz files)"
            ),
            (
                "DIR/runs/cut.mcap",
                "DIR/runs/cut.mcap is not a readable MCAP file: Bad magic number"
            ),
            (
                "DIR/runs/notes.mcap",
                "DIR/runs/notes.mcap is not a readable MCAP file: Bad magic number"
            ),
            (
                "DIR/runs/a.mcap: lazer crash",
                "the provider `lazer` is no service of the robot `looker` (did you mean \
                 `laser`?); it has: laser, sonar"
            ),
        ]
        .map(|(a, b)| (a.to_owned(), b.to_owned()))
    );
    assert!(report.skipped.iter().all(|s| s.error));
}

#[test]
fn accepted_results_are_what_later_runs_are_judged_against() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let out = dir.path().join("out");
    let sweep = "[[sweep]]\nproviders = [\"laser\", \"sonar\"]\nsteps = 2\n";
    let mut plan = plan_in(&out, std::slice::from_ref(&runs), sweep);
    run_here(&plan, &out, 2);
    let (results, _) = read_results(&plan, &out);
    let written = lewis_suite::accept(&mut plan, &results).unwrap();
    let expected = runs.join("a.mcap.expected.json");
    assert_eq!(written, std::slice::from_ref(&expected));

    // Nothing changed: every case is as accepted.
    let plan = plan_in(&out, std::slice::from_ref(&runs), sweep);
    assert!(plan.runs[0].accepted.is_some());
    assert!(run_here(&plan, &out, 2).passed);

    // Accepted otherwise (as after a change of behaviour, reviewed in the diff): the point
    // whose mission now goes differently fails, naming what was accepted.
    let text = std::fs::read_to_string(&expected).unwrap();
    std::fs::write(
        &expected,
        text.replace("\"succeeded\": true", "\"succeeded\": false"),
    )
    .unwrap();
    let plan = plan_in(&out, std::slice::from_ref(&runs), sweep);
    let report = run_here(&plan, &out, 2);
    assert!(!report.passed);
    let failed: Vec<&str> = report.runs[0]
        .cases
        .iter()
        .filter(|c| c.verdict == lewis_suite::report::Verdict::Failed)
        .map(|c| c.name.as_str())
        .collect();
    assert_eq!(failed, ["check", "laser+sonar crash @ 1.5s"]);
    let check = &report.runs[0].cases[0];
    assert!(
        check.reason.starts_with("differs from the accepted result"),
        "{}",
        check.reason
    );
}

#[test]
fn a_known_failure_is_reported_with_its_reason_and_does_not_fail_the_suite() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let out = dir.path().join("out");
    let plan = plan_in(
        &out,
        &[runs],
        "[[sweep]]\nname = \"both\"\nproviders = [\"laser\", \"sonar\"]\nsteps = 4\n\
         expect = [{ before = \"look\", mission = \"succeeds\" }]\n\n\
         [[known_failure]]\ncase = \"*: both @ 0.25s\"\nreason = \"no third range finder yet\"\n",
    );
    let report = run_here(&plan, &out, 2);
    assert!(report.passed, "{}", report.to_json());
    assert_eq!(report.totals.known_failures, 1);
    let known = &report.runs[0].cases[1];
    assert_eq!(
        known.known_failure.as_deref(),
        Some("no third range finder yet")
    );
    let junit = lewis_suite::junit::to_junit(&report);
    assert!(
        junit.contains("<skipped message=\"known failure: no third range finder yet\">"),
        "{junit}"
    );
}
