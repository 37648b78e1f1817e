//! A replay's bytes do not depend on where it is written: two replays of the reference
//! recording with the same fault, to files of different names, are the same file (the
//! recorder's statistics name the file `replay`, not the output's name).

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use lewis_replay::fault::FaultSpec;
use lewis_replay::resim::{ReplayOptions, replay};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The reference robot with its world named from the root, so that the sonar the fault
/// starts finds it whatever the test's current directory.
pub(crate) fn robot_with_absolute_world(dir: &Path) -> PathBuf {
    let root = repo_root();
    let text = std::fs::read_to_string(root.join("robots/sim-reference.toml")).unwrap();
    let world = root.join("robots/worlds/conference");
    let text = text.replace(
        "world = \"robots/worlds/conference\"",
        &format!("world = {:?}", world.to_str().unwrap()),
    );
    let path = dir.join("sim-reference.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn replay_to(output: &Path, robot: &Path) {
    let mut options =
        ReplayOptions::new(vec![repo_root().join("tests/data/reference/sim-goal.mcap")]);
    options.output = Some(output.to_path_buf());
    options.robot = Some(robot.to_path_buf());
    options.faults = vec!["laser".parse::<FaultSpec>().unwrap()];
    options.source_kinds = lewis_kinds::SOURCE_KINDS
        .iter()
        .map(|k| (*k).to_owned())
        .collect();
    let report = replay(&options, &lewis_kinds::registry(), &mut |_| {}).unwrap();
    assert_eq!(report.faults.len(), 1, "{report:?}");
}

#[test]
fn two_replays_with_a_fault_to_different_names_are_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let robot = robot_with_absolute_world(dir.path());
    let (a, b) = (
        dir.path().join("A.mcap"),
        dir.path().join("other-name.mcap"),
    );
    replay_to(&a, &robot);
    replay_to(&b, &robot);
    let (a_bytes, b_bytes) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert!(a_bytes.len() > 100_000, "{} bytes", a_bytes.len());
    assert!(
        a_bytes == b_bytes,
        "A.mcap ({} bytes) and other-name.mcap ({} bytes) differ",
        a_bytes.len(),
        b_bytes.len()
    );
}
