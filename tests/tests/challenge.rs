//! The Robot Challenge end to end, real processes, as the README's main job runs it:
//! `lewis demo --seed 1 --no-gui` starts the simulated robot with the recorder and the
//! sequencer on `robots/missions/challenge.seq`; after the door the laser is killed beyond
//! its restart limit and the broker moves its clients to the sonar; the mission must still
//! succeed through door, sign (at least twice), queue and register (`register` exits 0),
//! within about 3 minutes of simulated time. The recording must read in independent
//! readers, its ROS 2 companion channels equal to the Lewis messages they came from, and a closed-loop replay of it with a fault (`--all`: the mission lived again)
//! must give the same bytes whatever the output file is called (the demo's replay holds the
//! replay's own channels without camera frames: `--outputs-only --leave-out ImageSource`).
//! The demo's own replay (the laser dead in the middle of the door) fails at the door.
//! Lived again without a new fault, the mission goes as it went live; with the laser and
//! the sonar dead before the door it fails; with the speech crashing at the registration
//! desk (what `register` needs) it still succeeds, the broker restarting it. A sweep of the
//! sonar's death fails the mission wherever the sonar is the last range finder and a state
//! still needs one. The demo's picture and Rerun file must be written.
//!
//! Its own test binary: the one live mission of CI, a closed loop in real time that should
//! not share the machine with other end-to-end tests.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

use std::path::Path;
use std::process::Command;

use lewis_interfaces::msg::Broker;
use lewis_sequencer::replay::read_json_lines;
use lewis_sequencer::verdict::Verdict;
use lewis_tests::{doctor, lewis_exe, python_tool, repo_root, run_ok};

/// The mission's limit in simulated time, with the "about 3 minutes".
const MISSION_LIMIT_S: f64 = 200.0;

#[test]
fn the_demo_mission_succeeds_through_a_laser_failure_and_replays_identically() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let namespace = lewis_runtime::ipc::Namespace::unique("challenge");
    let run = Command::new(lewis_exe())
        .current_dir(repo_root())
        .args(["demo", "--seed", "1", "--no-gui", "--out"])
        .arg(&out)
        .args(["--namespace", namespace.as_str()])
        .output()
        .expect("lewis demo runs");
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        run.status.success(),
        "lewis demo exited with {}:\n{printed}",
        run.status
    );

    // The mission, judged from its records: through door, sign (twice or more), queue and
    // register, ending on register's exit 0.
    let events = std::fs::File::open(out.join("events.jsonl")).expect("the demo writes its events");
    let records = read_json_lines(std::io::BufReader::new(events)).unwrap();
    let verdict = Verdict::of(&records);
    assert!(verdict.succeeded, "{}\n{printed}", verdict.reason);
    let states: Vec<&str> = verdict
        .states_visited
        .iter()
        .map(|v| v.state.as_str())
        .collect();
    assert_eq!(states.first(), Some(&"door"), "{states:?}");
    assert!(
        states.iter().filter(|s| **s == "sign").count() >= 2,
        "the mission follows at least two signs: {states:?}"
    );
    assert!(states.contains(&"queue"), "{states:?}");
    assert_eq!(states.last(), Some(&"register"), "{states:?}");
    assert!(
        verdict.states_visited.last().unwrap().left_by.as_deref()
            == Some("transition register -> stop on 0"),
        "{:?}",
        verdict.states_visited.last()
    );
    let first = verdict.states_visited.first().unwrap().started_ns;
    let last = verdict.states_visited.last().unwrap().ended_ns.unwrap();
    let seconds = (last - first) as f64 / 1e9;
    assert!(
        seconds <= MISSION_LIMIT_S,
        "the mission took {seconds:.0} s (limit {MISSION_LIMIT_S} s)"
    );

    for file in ["run.png", "run.rrd"] {
        assert!(
            out.join(file).exists(),
            "the demo writes {file}:\n{printed}"
        );
    }
    // Each file is removed once checked: the recording, its replays and the viewer's file
    // are each hundreds of MB (camera frames), and CI's disk holds a few of them at a time.
    remove(&out.join("run.rrd"));

    // The laser's failure and the rebinding to the sonar are in the recording.
    let run_mcap = out.join("run.mcap");
    let decisions = broker_decisions(&run_mcap);
    assert!(
        decisions
            .iter()
            .any(|d| d.action == "service-failed" && d.service == "laser"),
        "the laser fails for good: {:?}",
        decisions
            .iter()
            .map(|d| (&d.action, &d.service))
            .collect::<Vec<_>>()
    );
    assert!(
        decisions.iter().any(|d| d.action == "rebind"
            && d.client == "obstacle_avoider"
            && d.interface == "RangeFinder"
            && d.from_service == "laser"
            && d.to_service == "sonar"),
        "the obstacle_avoider is moved to the sonar"
    );

    // Independent readers: pymcap-cli doctor (and rerun's check), mcap-ros2-support, which
    // decodes every message and finds the ROS 2 companions equal to their sources.
    doctor(&run_mcap);
    let decoded = run_ok(
        python_tool("python")
            .arg(repo_root().join("tools/python/check_companions.py"))
            .arg(&run_mcap),
    );
    for line in [
        "decoded /lewis/sequencer ",
        "/laser/scan sensor_msgs/msg/LaserScan ",
        "/sonar/points sensor_msgs/msg/PointCloud2 ",
        "/base/odom nav_msgs/msg/Odometry ",
        "/sign_detector/markers visualization_msgs/msg/MarkerArray ",
        "/lewis/broker/markers visualization_msgs/msg/MarkerArray ",
        "/tf_static tf2_msgs/msg/TFMessage ",
    ] {
        assert!(decoded.contains(line), "{line} not in:\n{decoded}");
    }

    // A replay with a fault gives the same bytes twice, whatever its output is called: the
    // demo's own replay, and one more with the same fault into another file.
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("replay.json")).unwrap()).unwrap();
    let fault = report["faults"][0]["spec"]
        .as_str()
        .expect("the demo's replay names its fault")
        .to_owned();
    let again = dir.path().join("again-with-another-name.mcap");
    // From the repository's root, as the demo ran: the robot file names its world and
    // colour files relative to it.
    let replay = Command::new(lewis_exe())
        .current_dir(repo_root())
        .arg("replay")
        .arg(&run_mcap)
        .args(["--all", "--inject-fault", &fault, "-o"])
        .arg(&again)
        // As the demo writes its replay: what the replay produced, no camera frames.
        .args(["--outputs-only", "--leave-out", "ImageSource"])
        .output()
        .expect("lewis replay runs");
    assert!(
        replay.status.success(),
        "lewis replay: {}",
        String::from_utf8_lossy(&replay.stderr)
    );
    assert!(
        std::fs::read(out.join("replay.mcap")).unwrap() == std::fs::read(&again).unwrap(),
        "two replays of the same recording with the same fault ({fault}) differ"
    );
    remove(&again);
    remove(&out.join("replay.mcap"));
    // The demo's replay lived the mission again (closed loop), the live fault applied again,
    // with the laser dead from the middle of the door on: through the 1.5 m door on the
    // sonar alone the avoider dithers, and the door runs out of time.
    let mission = &report["mission"];
    assert_eq!(mission["loop"], "closed", "{mission:#}");
    assert_eq!(
        mission["replayed"]["succeeded"], false,
        "{fault}: {mission:#}"
    );
    assert_eq!(
        mission["replayed"]["states"][0]["left_by"], "recover from door",
        "{fault}: {mission:#}"
    );
    assert!(
        mission["recorded_faults"][0]
            .as_str()
            .is_some_and(|f| f.starts_with("laser@")),
        "the live laser's deaths are applied again: {mission:#}\nthe live broker on the laser:\n{}",
        decisions
            .iter()
            .filter(|d| d.service == "laser")
            .map(|d| format!("{} {}: {}", d.at_ns, d.action, d.reason))
            .collect::<Vec<_>>()
            .join("\n")
    );

    // The demo kills the laser until the broker gives it up: that last death is lived
    // again as the give-up it was (a stuck loop), whatever the replay's restart count.
    let deaths = mission["recorded_faults"].as_array().unwrap();
    assert!(
        deaths
            .last()
            .and_then(|d| d.as_str())
            .is_some_and(|d| d.ends_with(":stuck")),
        "{deaths:?}"
    );

    let same = closed_loop_verdicts(&run_mcap, dir.path(), &verdict);
    sweep_on_one_and_two_threads(&run_mcap, dir.path(), laser_back_ns(&same));
}

/// When the laser is back in the mission lived again without a new fault: the broker
/// retries a provider it failed (`it will be retried in 20 s`), and a retry that fails on
/// trial waits longer; the last failure's retry is the one that held.
fn laser_back_ns(same: &serde_json::Value) -> i64 {
    let last = same["failures"]
        .as_array()
        .unwrap()
        .iter()
        .rfind(|f| f["service"] == "laser")
        .unwrap_or_else(|| panic!("the live laser is failed again: {:#}", same["failures"]));
    let reason = last["reason"].as_str().unwrap();
    let seconds: f64 = reason
        .split_once("retried in ")
        .and_then(|(_, after)| after.split_once(" s"))
        .and_then(|(number, _)| number.parse().ok())
        .unwrap_or_else(|| panic!("no retry in the laser's failure: {reason}"));
    last["at_ns"].as_i64().unwrap() + (seconds * 1e9) as i64
}

/// `--sweep-fault sonar --steps 3`: the same JSON and plot on one thread as on two, and at
/// each point the fate the demo's run gives the mission. From the laser's live give-up
/// until the broker's retry of it holds, the sonar is the only range finder: its death
/// then leaves `sign` (Distance) and `queue` (RangeFinder) blind, and the mission must
/// fail; once the laser is back it takes over, and the mission must succeed. Over the
/// demo's 2-minute run the first two points fall before the laser is back, the third after.
fn sweep_on_one_and_two_threads(run: &Path, dir: &Path, laser_back_ns: i64) {
    let sweep = |jobs: &str| {
        let json = dir.join(format!("sweep-{jobs}.json"));
        let output = Command::new(lewis_exe())
            .current_dir(repo_root())
            .arg("replay")
            .arg(run)
            .args([
                "--all",
                "--sweep-fault",
                "sonar",
                "--steps",
                "3",
                "--jobs",
                jobs,
            ])
            .arg("--report")
            .arg(&json)
            .output()
            .expect("lewis replay runs");
        let text = String::from_utf8_lossy(&output.stdout).into_owned();
        assert!(
            output.status.success(),
            "{text}{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let png = std::fs::read(json.with_extension("png")).unwrap();
        (std::fs::read_to_string(&json).unwrap(), png, text)
    };
    let (one, one_png, text) = sweep("1");
    let (two, two_png, _) = sweep("2");
    assert_eq!(
        one, two,
        "the sweep on two threads differs from one:\n{text}"
    );
    assert!(one_png == two_png, "the plots differ");
    assert!(one_png.starts_with(b"\x89PNG"), "not a PNG");
    let swept: serde_json::Value = serde_json::from_str(&one).unwrap();
    let points = swept["points"].as_array().unwrap();
    assert_eq!(points.len(), 3, "{text}");
    assert!(text.contains("the mission"), "{text}");
    eprintln!("{text}");
    let mut fates = Vec::new();
    for point in points {
        let at_ns = point["fault_at_ns"].as_i64().unwrap();
        let must_succeed = at_ns > laser_back_ns;
        assert_eq!(
            point["succeeded"], must_succeed,
            "the sonar dead at {at_ns} ns in {} (the laser back at {laser_back_ns} ns): {}\n{text}",
            point["state_at_fault"], point["reason"]
        );
        fates.push(must_succeed);
    }
    // Both fates shown: over the demo's 2-minute run the first point falls before the
    // laser is back (it fails at the door, 1 min in) and the last after.
    assert!(
        fates.contains(&false) && fates.contains(&true),
        "the sweep shows one fate only (the laser back at {laser_back_ns} ns): {fates:?}\n{text}"
    );
}

/// `lewis replay RUN --all ARGS -o OUT --report OUT.json`: its report as JSON and its text.
fn replay_all(run: &Path, args: &[&str], out: &Path) -> (serde_json::Value, String) {
    let json = out.with_extension("json");
    let replay = Command::new(lewis_exe())
        .current_dir(repo_root())
        .arg("replay")
        .arg(run)
        .arg("--all")
        .args(args)
        .arg("-o")
        .arg(out)
        .arg("--report")
        .arg(&json)
        .output()
        .expect("lewis replay runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&replay.stdout),
        String::from_utf8_lossy(&replay.stderr)
    );
    assert!(
        replay.status.code().is_some_and(|c| c < 2),
        "lewis replay {args:?}: {}\n{text}",
        replay.status
    );
    let report = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    remove(out);
    (report, text)
}

/// Removes a checked file to make room for the next.
fn remove(file: &Path) {
    std::fs::remove_file(file).unwrap_or_else(|e| panic!("removing {}: {e}", file.display()));
}

/// The states a mission report visited.
fn course(mission: &serde_json::Value) -> Vec<String> {
    mission["states"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["state"].as_str().unwrap().to_owned())
        .collect()
}

/// The mission lived again from the recording (closed loop): without a new fault it goes as
/// live (the live laser crash applied again at its recorded time); with the laser and the
/// sonar gone before the door it fails there; with the speech crashing at the registration
/// desk, which `register` needs, it still succeeds: the broker restarts the speech, and
/// `register` says its words again. Returns the report of the replay without a new fault.
fn closed_loop_verdicts(run: &Path, dir: &Path, live: &Verdict) -> serde_json::Value {
    let (same, text) = replay_all(run, &["--check"], &dir.join("same.mcap"));
    // What the replayed broker gave up on, beside the printed summary: a closed loop that
    // goes another way than live shows it there first.
    let text = format!(
        "{text}\nthe replay's failures: {}\nrecorded deaths: {}",
        same["failures"], same["mission"]["recorded_faults"]
    );
    let mission = &same["mission"];
    assert_eq!(mission["loop"], "closed", "{text}");
    let live_course: Vec<String> = live
        .states_visited
        .iter()
        .map(|v| v.state.clone())
        .collect();
    assert_eq!(course(&mission["replayed"]), live_course, "{text}");
    assert_eq!(mission["replayed"]["succeeded"], true, "{text}");
    assert_eq!(same["check"]["passed"], true, "{text}");
    assert_eq!(same["check"]["compared"], "mission_only", "{text}");
    eprintln!(
        "closed loop without a new fault: the final poses are {} m apart",
        mission["final_pose_distance_m"]
    );

    let (blind, text) = replay_all(
        run,
        &[
            "--inject-fault",
            "laser@1s:crash",
            "--inject-fault",
            "sonar@1s:crash",
        ],
        &dir.join("blind.mcap"),
    );
    let replayed = &blind["mission"]["replayed"];
    assert_eq!(replayed["succeeded"], false, "{text}");
    assert_eq!(
        course(replayed).first().map(String::as_str),
        Some("door"),
        "{text}"
    );
    assert!(text.contains("FAILED"), "{text}");

    // Halfway through registering as the mission lived again does it: the replay with the
    // fault is the same one up to the fault. A mission lived again may reach the desk after
    // the recording's end (it runs a little slower than live), and a fault may fall there.
    let register = mission["replayed"]["states"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["state"] == "register")
        .expect("the mission lived again reaches register");
    let during = |key: &str| register[key].as_i64().expect("register starts and ends");
    let at_ms = (during("started_ns") + during("ended_ns")) / 2 / 1_000_000;
    // A crash for 50 ms: the process dies once, and its restart 100 ms later is up.
    let seconds = |ms: i64| format!("{}.{:03}s", ms / 1000, ms % 1000);
    let speech = format!("speech@{}-{}:crash", seconds(at_ms), seconds(at_ms + 50));
    let (late, text) = replay_all(run, &["--inject-fault", &speech], &dir.join("late.mcap"));
    let replayed = &late["mission"]["replayed"];
    assert_eq!(replayed["succeeded"], true, "{speech}: {text}");
    assert_eq!(course(replayed), live_course, "{speech}: {text}");
    // The crash cost register its pending answer: it said its words again after its wait.
    let late_register = replayed["states"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["state"] == "register")
        .unwrap();
    let late_ns = late_register["ended_ns"].as_i64().unwrap() - during("started_ns");
    let same_ns = during("ended_ns") - during("started_ns");
    assert!(
        late_ns > same_ns + 10_000_000_000,
        "register took {late_ns} ns with {speech}, {same_ns} ns without: the crash missed \
         what it needs\n{text}"
    );
    let reactions = late["faults"][0]["reactions"].as_array().unwrap();
    assert!(
        reactions.iter().any(|r| r["action"]
            .as_str()
            .is_some_and(|a| a.starts_with("restart speech"))),
        "the broker never restarted the speech after {speech}: {text}"
    );
    same
}

/// Every decision on `/lewis/broker` in a recording.
fn broker_decisions(path: &Path) -> Vec<Broker> {
    let bytes = std::fs::read(path).unwrap();
    let mut decisions = Vec::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        if message.channel.topic == "/lewis/broker" {
            decisions.push(lewis_interfaces::cdr::from_bytes(&message.data).unwrap());
        }
    }
    decisions
}
