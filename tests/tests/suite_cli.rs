//! `lewis test` as a person and a scheduler run it, on the reference recording, a real
//! laser log imported on the fly (CARMEN, `../shared/data`) and a file that is no
//! recording: on one machine with `--jobs 2`, and as a plan whose jobs run as separate
//! processes (the index from the flag, from Slurm's and from Kubernetes' variable), merged.
//! Both give the same reports, byte for byte; the page is then opened in Chromium.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Output};

use lewis_tests::browser::{browser_tools, gui_test_dir};
use lewis_tests::{lewis_exe, repo_root, shared_data};

const INDEX_VARIABLES: [&str; 2] = ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"];

/// `lewis test ARGS` from the repository's root (where the reference recording's world
/// is), with no scheduler's variable but those in `env`.
fn lewis_test(args: &[&str], env: &[(&str, String)]) -> Output {
    let mut command = Command::new(lewis_exe());
    command.arg("test").args(args).current_dir(repo_root());
    for name in INDEX_VARIABLES {
        command.env_remove(name);
    }
    for (name, value) in env {
        command.env(name, value);
    }
    command.output().unwrap()
}

fn text(output: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        output.status.code(),
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

fn reports(dir: &Path) -> Vec<(&'static str, Vec<u8>)> {
    ["report.xml", "report.json", "report.html"]
        .into_iter()
        .map(|f| (f, std::fs::read(dir.join(f)).unwrap()))
        .collect()
}

#[test]
fn a_suite_on_one_machine_and_as_separate_jobs_merged_gives_the_same_reports() {
    let dir = tempfile::tempdir().unwrap();
    let runs = dir.path().join("runs");
    std::fs::create_dir_all(&runs).unwrap();
    std::fs::copy(
        repo_root().join("tests/data/reference/sim-goal.mcap"),
        runs.join("sim-goal.mcap"),
    )
    .unwrap();
    std::fs::write(runs.join("notes.mcap"), "not a recording").unwrap();
    let log = shared_data("carmen/orebro-corrected.log.gz");
    let (runs, log) = (runs.to_str().unwrap(), log.to_str().unwrap());

    let here = dir.path().join("here");
    let output = lewis_test(
        &[runs, log, "--out", here.to_str().unwrap(), "--jobs", "2"],
        &[],
    );
    let said = text(&output);
    // The file that is no recording fails the suite, named with why; the rest still ran.
    assert_eq!(output.status.code(), Some(1), "{said}");
    assert!(
        said.contains("notes.mcap is not a readable MCAP file"),
        "{said}"
    );
    assert!(
        said.contains(
            "FAILED: 2 runs, 2 cases: 2 passed, 0 failed, 0 known failures, 1 errors; 1 skipped"
        ),
        "{said}"
    );

    let array = dir.path().join("array");
    let plan = array.join("plan.json");
    let output = lewis_test(&[runs, log, "--plan", plan.to_str().unwrap()], &[]);
    assert!(output.status.success(), "{}", text(&output));
    let plan_path = plan.to_str().unwrap();
    // Job 0 from the flag, job 1 from Slurm's index, and Kubernetes' too, in reverse.
    let output = lewis_test(
        &["--job", "--from", plan_path],
        &[("JOB_COMPLETION_INDEX", "1".to_owned())],
    );
    assert!(output.status.success(), "{}", text(&output));
    let output = lewis_test(
        &["--job", "--from", plan_path],
        &[("SLURM_ARRAY_TASK_ID", "1".to_owned())],
    );
    assert!(output.status.success(), "{}", text(&output));
    let output = lewis_test(&["--job", "0", "--from", plan_path], &[]);
    assert!(output.status.success(), "{}", text(&output));
    let output = lewis_test(&["--job", "7", "--from", plan_path], &[]);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output));
    assert!(
        text(&output).contains("the plan has 2 jobs, numbered 0 to 1: there is no job 7"),
        "{}",
        text(&output)
    );
    let output = lewis_test(&["--merge", array.to_str().unwrap()], &[]);
    assert_eq!(output.status.code(), Some(1), "{}", text(&output));
    assert_eq!(reports(&here), reports(&array), "the reports differ");

    let junit = String::from_utf8(std::fs::read(here.join("report.xml")).unwrap()).unwrap();
    assert!(junit.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"lewis test\" tests=\"3\" failures=\"0\" errors=\"1\">"), "{junit}");
    assert!(junit.contains("lewis import carmen "), "{junit}");
    // Nothing of the machine or the day in the reports; the wall times are apart.
    let timing = std::fs::read_to_string(here.join("timing.json")).unwrap();
    assert!(timing.contains("\"wall_ms\""), "{timing}");
    assert!(
        !junit.contains("timestamp") && !junit.contains("hostname"),
        "{junit}"
    );

    let chromium = browser_tools();
    let shot = dir.path().join("report.png");
    let browser = Command::new("node")
        .arg(gui_test_dir().join("suite.mjs"))
        .arg(here.join("report.html"))
        .arg(&shot)
        .env("LEWIS_CHROMIUM", &chromium)
        .current_dir(gui_test_dir())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&browser.stdout);
    assert!(
        browser.status.success() && stdout.contains("gui-test: ok"),
        "the browser test failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&browser.stderr)
    );
    assert!(shot.is_file(), "no screenshot");
    if let Some(keep) = std::env::var_os("LEWIS_SUITE_SCREENSHOT") {
        std::fs::copy(&shot, keep).unwrap();
    }
}
