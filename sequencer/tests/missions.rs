//! The mission scripts shipped in `robots/missions/` parse and check. Their programs are
//! the challenge sub-task programs, built elsewhere, so programs are resolved without
//! looking at the disk.

use std::path::{Path, PathBuf};

use lewis_sequencer::{FileSystem, Sequencer, Supervision, TrustingResolver, check_with};

fn missions() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/missions")
}

#[test]
fn the_challenge_script_is_the_papers_and_checks_clean() {
    let path = missions().join("challenge.seq");
    let checked =
        check_with(&path, &FileSystem, &TrustingResolver).unwrap_or_else(|d| panic!("{d}"));
    assert!(checked.warnings.is_empty(), "{}", checked.warnings);
    let names: Vec<&str> = checked
        .mission
        .states()
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    assert_eq!(names, ["door", "sign", "queue", "register", "oops"]);
    assert_eq!(checked.mission.start().restart_limit, 3);
    assert!(checked.mission.use_gui());
    let (_, decisions) = Sequencer::start(checked.mission, Supervision::Page);
    assert_eq!(
        decisions[0].to_string(),
        format!(
            "run door attempt 1: {} | the mission starts at `door`",
            missions().join("./bin/DoorNavigator").display()
        )
    );
}

#[test]
fn the_extensions_example_checks_clean_with_its_include() {
    let path = missions().join("extensions.seq");
    let checked =
        check_with(&path, &FileSystem, &TrustingResolver).unwrap_or_else(|d| panic!("{d}"));
    assert!(checked.warnings.is_empty(), "{}", checked.warnings);
    let mission = &checked.mission;
    let sign = mission.state("sign").unwrap();
    assert_eq!(sign.restart_limit, 5);
    assert_eq!(
        sign.args,
        ["--signs", "arrow left", "--signs", "arrow right"]
    );
    assert_eq!(sign.env["LEWIS_LOG"], "debug");
    assert_eq!(sign.env["LEWIS_MISSION"], "AAAI 2004 challenge");
    assert_eq!(
        mission.state("register").unwrap().args,
        ["--badge-text=Lewis\u{2122}"]
    );
    let oops = mission.recovery().unwrap();
    assert_eq!(oops.name, "oops");
    assert_eq!(oops.restart_limit, 1);
    assert_eq!(oops.timeout_ns, Some(300_000_000_000));
    assert_eq!(
        mission.state("door").unwrap().timeout_ns,
        Some(120_000_000_000)
    );
}
