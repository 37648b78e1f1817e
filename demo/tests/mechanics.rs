//! The demo's mechanics without the challenge's programs: the simulated robot of
//! `robots/sim.toml` (paths made absolute: the test runs in `demo/`) on a two-state script
//! of `/bin/sleep`s. When the first state is over, the fault thread kills the laser after
//! every restart until the broker gives it up and moves its RangeFinder client to the sonar
//! (on `/lewis/broker` in the recording); the verdict (told as soon as the mission is over),
//! the replay (its own channels only, no camera frames) and the files follow.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeSet;
use std::net::{Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};

use lewis_demo::{DemoOptions, LiveFault, run_demo};
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, LogLine};
use lewis_replay::lockstep::{Program, Programs};
use lewis_replay::outcome::LoopKind;
use lewis_runtime::ipc::Namespace;
use lewis_testkit::{lewis_exe, repository_root};

/// Door, then a sign state, then `stop`: long enough for the laser's three deaths.
const SCRIPT: &str = "\
start door
restart 3
recovery oops

state door /bin/sleep 3
  action 0 trans sign

state sign /bin/sleep 6
  action 0 trans stop

state oops /bin/true
  action 0 trans stop
";

/// The script's programs are `/bin/sleep`s, which no replay can run: the demo's replay
/// says the loop stays open.
struct SleepsOnly;

impl Programs for SleepsOnly {
    fn build(&self, program: &Path, _args: &[String]) -> Result<Program, String> {
        Err(format!("{} is not a lewis program", program.display()))
    }
}

fn robot_with_absolute_paths(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(repository_root().join("robots/sim.toml")).unwrap();
    let text = text.replace(
        "= \"robots/",
        &format!("= \"{}/robots/", repository_root().display()),
    );
    let path = dir.join("sim.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The broker's decisions and the log lines about the laser, a line each by log time, for a failure to say why it was
/// given up (a recording that cannot be read says so instead).
fn laser_decisions(recording: &Path) -> String {
    if !recording.is_file() {
        return format!("({} is missing)", recording.display());
    }
    let bytes = std::fs::read(recording).unwrap();
    let mut lines: Vec<(u64, String)> = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(Result::unwrap)
        .filter_map(|m| match m.channel.topic.as_str() {
            "/lewis/broker" => cdr::from_bytes::<Broker>(&m.data)
                .ok()
                .filter(|d| d.service == "laser")
                .map(|d| (m.log_time, format!("broker {}: {}", d.action, d.reason))),
            "/lewis/log" => cdr::from_bytes::<LogLine>(&m.data)
                .ok()
                .filter(|l| l.text.contains("laser"))
                .map(|l| (m.log_time, format!("log {}: {}", l.service, l.text))),
            _ => None,
        })
        .collect();
    lines.sort();
    lines
        .iter()
        .map(|(t, line)| format!("{t} {line}"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn broker_decisions(recording: &Path) -> Vec<Broker> {
    let bytes = std::fs::read(recording).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/lewis/broker")
        .map(|m| cdr::from_bytes::<Broker>(&m.data).unwrap())
        .collect()
}

#[test]
fn the_laser_dies_after_the_first_state_and_the_sonar_takes_over_in_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("mission.seq");
    std::fs::write(&script, SCRIPT).unwrap();
    let options = DemoOptions {
        robot: robot_with_absolute_paths(dir.path()),
        script,
        seed: Some(3),
        no_gui: true,
        gui_addr: SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        out: dir.path().join("out"),
        fault: LiveFault::laser_after_first_state(),
        namespace: Namespace::unique("demo-mechanics"),
        lewis_exe: lewis_exe(),
    };
    let mut told = Vec::new();
    let report = run_demo(
        &options,
        &lewis_kinds::registry(),
        &SleepsOnly,
        &mut |mission, fault| {
            // Before the replay: its output is not written yet.
            assert!(!options.out.join("replay.json").exists());
            told.push(lewis_demo::mission_lines(mission, fault));
        },
    )
    .unwrap();
    let summary = report.summary();
    assert_eq!(told.len(), 1, "{told:?}");
    assert!(
        summary.starts_with(&told[0]),
        "{summary}
told: {}",
        told[0]
    );

    assert!(report.succeeded(), "{summary}");
    let fault = &report.fault;
    assert!(
        fault.killed.len() >= 3,
        "{fault:?}\n{summary}\nthe broker on the laser:\n{}",
        laser_decisions(&report.files.run)
    );
    assert!(fault.failed_ns.is_some(), "{fault:?}\n{summary}");
    // Struck once `door` was over, not before.
    let door = &report.mission.verdict.states_visited[0];
    assert_eq!(door.state, "door");
    assert!(fault.struck_ns >= door.ended_ns, "{fault:?}\n{summary}");
    assert!(
        fault
            .rebinds
            .iter()
            .any(|r| r.ends_with("RangeFinder: laser -> sonar")),
        "{fault:?}\n{summary}"
    );

    let files = &report.files;
    for file in [
        &files.run,
        &files.events,
        &files.replay,
        &files.replay_report,
    ] {
        assert!(file.is_file(), "{} is missing\n{summary}", file.display());
    }
    let seeded = std::fs::read_to_string(files.robot.as_ref().unwrap()).unwrap();
    assert!(seeded.contains("seed = 3"), "{seeded}");

    let decisions = broker_decisions(&files.run);
    assert!(
        decisions
            .iter()
            .any(|d| d.action == "service-failed" && d.service == "laser"),
        "{decisions:#?}"
    );
    assert!(
        decisions.iter().any(|d| d.action == "rebind"
            && d.interface == "RangeFinder"
            && d.from_service == "laser"
            && d.to_service == "sonar"),
        "{decisions:#?}"
    );
    assert!(report.replay.is_ok(), "{summary}");
    // `/bin/sleep` cannot be lived again: the replay is open loop, and says why.
    let mission = report.replay.as_ref().unwrap().mission.as_ref().unwrap();
    match &mission.loop_kind {
        LoopKind::Open { because: Some(why) } => assert!(why.contains("/bin/sleep"), "{why}"),
        other => panic!("the loop should stay open: {other:?}\n{summary}"),
    }
    assert!(summary.contains("open loop"), "{summary}");
    assert!(summary.contains("mission succeeded"), "{summary}");
    assert!(summary.contains("moved: "), "{summary}");

    // The replay's file holds what the replay produced, without camera frames: the
    // recording has the rest.
    let bytes = std::fs::read(&files.replay).unwrap();
    let mut topics = BTreeSet::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        let interface = message.channel.metadata.get("interface").cloned();
        topics.insert((message.channel.topic.clone(), interface.unwrap_or_default()));
    }
    assert!(
        topics.iter().any(|(t, _)| t.starts_with("/replay/")),
        "{topics:?}"
    );
    assert!(
        topics
            .iter()
            .all(|(topic, interface)| (topic.starts_with("/replay/")
                || topic == lewis_recorder::STATS_TOPIC)
                && interface != "ImageSource"),
        "{topics:?}"
    );
}
