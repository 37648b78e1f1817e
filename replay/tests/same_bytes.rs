//! A replay's bytes do not depend on where it is written: two replays of the reference
//! recording with the same fault, to files of different names, are the same file (the
//! recorder's statistics name the file `replay`, not the output's name). With
//! `outputs_only` the file holds the replay's own channels alone, message for message as
//! in the whole file, and `left_out` leaves an interface's channels out; the report is the
//! same.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_replay::fault::FaultSpec;
use lewis_replay::report::Report;
use lewis_replay::resim::{REPLAY_PREFIX, ReplayOptions, replay};

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
    replay_with(output, robot, |_| {});
}

/// Replays the reference with the laser stalled half-way into `output`, the options as
/// `edit` leaves them.
fn replay_with(output: &Path, robot: &Path, edit: impl FnOnce(&mut ReplayOptions)) -> Report {
    let mut options =
        ReplayOptions::new(vec![repo_root().join("tests/data/reference/sim-goal.mcap")]);
    options.output = Some(output.to_path_buf());
    options.robot = Some(robot.to_path_buf());
    options.faults = vec!["laser".parse::<FaultSpec>().unwrap()];
    edit(&mut options);
    let report = replay(&options, &lewis_kinds::registry(), &mut |_| {}).unwrap();
    assert_eq!(report.faults.len(), 1, "{report:?}");
    report
}

/// Each channel of the MCAP file at `path` (but the recorder's statistics, which each
/// file has of its own) with its interface and how many messages it holds.
fn channels(path: &Path) -> BTreeMap<String, (String, u64)> {
    let bytes = std::fs::read(path).unwrap();
    let mut channels = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        if message.channel.topic == lewis_recorder::STATS_TOPIC {
            continue;
        }
        let interface = message
            .channel
            .metadata
            .get("interface")
            .cloned()
            .unwrap_or_default();
        channels
            .entry(message.channel.topic.clone())
            .or_insert((interface, 0))
            .1 += 1;
    }
    channels
}

#[test]
fn outputs_only_writes_the_replays_own_channels_and_leave_out_drops_an_interface() {
    let dir = tempfile::tempdir().unwrap();
    let robot = robot_with_absolute_world(dir.path());
    let (whole, outputs, no_scans) = (
        dir.path().join("whole.mcap"),
        dir.path().join("outputs.mcap"),
        dir.path().join("no-scans.mcap"),
    );
    let whole_report = replay_with(&whole, &robot, |_| {});
    let outputs_report = replay_with(&outputs, &robot, |o| o.outputs_only = true);
    replay_with(&no_scans, &robot, |o| {
        o.outputs_only = true;
        o.left_out = ["RangeFinder".to_owned()].into();
    });

    let prefix = format!("{REPLAY_PREFIX}/");
    let all = channels(&whole);
    let own: BTreeMap<String, (String, u64)> = all
        .iter()
        .filter(|(topic, _)| topic.starts_with(&prefix))
        .map(|(topic, c)| (topic.clone(), c.clone()))
        .collect();
    assert!(own.len() < all.len(), "the whole file copies the recording");
    assert_eq!(
        channels(&outputs),
        own,
        "outputs only: the replay's channels"
    );
    let scans = own.values().filter(|(i, _)| i == "RangeFinder").count();
    assert!(scans > 0, "the replay re-simulates a range finder: {own:?}");
    let without: BTreeMap<_, _> = own
        .into_iter()
        .filter(|(_, (interface, _))| interface != "RangeFinder")
        .collect();
    assert_eq!(channels(&no_scans), without, "RangeFinder left out");

    // The same comparison and report, but the messages written and the output's name.
    assert_eq!(outputs_report.divergence, whole_report.divergence);
    assert_eq!(outputs_report.faults, whole_report.faults);
    assert!(outputs_report.messages_written < whole_report.messages_written);
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(
        size(&outputs) < size(&whole) / 2,
        "{} of {}",
        size(&outputs),
        size(&whole)
    );
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
