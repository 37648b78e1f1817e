//! The closed-loop mission replay (`lewis replay --all`) on small scripted missions that
//! run in milliseconds: a robot of two simulated range finders (a laser and a sonar, both
//! `test-range`), a script of two or three states whose programs are written below, and a
//! recording holding what a live run of it writes (the sequencer's records on
//! `/lewis/sequencer`, the broker's decisions, heartbeats). Each test lives the mission
//! again and checks what the report says of it: the verdict and why, the states visited,
//! restarts and recoveries, the live run's faults applied again, and where the
//! supervisor's answers came from.

// Test helpers fail the test by panicking, like the tests that call them.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use lewis_interfaces::msg::{Health as HealthMessage, RangeFinder, Sequencer as SequencerMessage};
use lewis_interfaces::{Interface, Message, cdr};
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_replay::fault::FaultSpec;
use lewis_replay::lockstep::{AnswerSource, Program, Programs};
use lewis_replay::outcome::{LoopKind, MissionOutcome};
use lewis_replay::report::{Compared, Report};
use lewis_replay::resim::{ReplayOptions, ServiceSelection, replay_with};
use lewis_runtime::broker::live::decision_message;
use lewis_runtime::broker::{Action, Decision as BrokerDecision};
use lewis_runtime::names;
use lewis_sequencer::{
    Entry, Event, FileSystem, Record, Sequencer, Supervision, TrustingResolver, check_with,
    to_message,
};
use lewis_service::{Context, Input, Service, ServiceRegistry};

const T0: i64 = 1_000_000_000;
const MS: i64 = 1_000_000;

/// The recording's length: long enough for a failing mission's timeouts, restarts and
/// recovery to play out within it and its overtime.
const RUN_MS: i64 = 2000;

/// When the recorded mission started.
const MISSION_AT_MS: i64 = 100;

const ROBOT: &str = r#"
[robot]
name = "looker"
description = "a laser and a sonar, and missions that look through them"

[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = 50
restart = { max_restarts = 2, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }

[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 2 }]
[services.parameters]
beams = 19
rate_hz = 50.0
seed = 1

[[services]]
name = "sonar"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 5, cost = 1 }]
[services.parameters]
beams = 24
field_of_view_deg = 360.0
rate_hz = 50.0
seed = 2
"#;

/// `scans N FROM`: asks for a RangeFinder and exits 0 once it has had N scans from the
/// provider FROM; scans from another provider do not count. It never gives up: a state's
/// timeout ends it.
struct Scans {
    wanted: u32,
    from: String,
    seen: u32,
}

impl Service for Scans {
    fn on_input(&mut self, _ctx: &mut Context<'_>, input: &Input<'_>) {
        let scan = input.decode::<RangeFinder>().unwrap();
        if scan.header.provider == self.from {
            self.seen += 1;
        }
    }

    fn exit_code(&self) -> Option<i32> {
        (self.seen >= self.wanted).then_some(0)
    }
}

/// `exit CODE`: requires nothing, exits with CODE at its first tick.
struct Exit {
    code: i32,
    ticked: bool,
}

impl Service for Exit {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(10 * MS)
    }

    fn on_tick(&mut self, _ctx: &mut Context<'_>) {
        self.ticked = true;
    }

    fn exit_code(&self) -> Option<i32> {
        self.ticked.then_some(self.code)
    }
}

/// The programs of these tests: a state's program file holds the program's name.
struct TestPrograms;

impl Programs for TestPrograms {
    fn build(&self, program: &Path, args: &[String]) -> Result<Program, String> {
        let name = std::fs::read_to_string(program).map_err(|e| e.to_string())?;
        let arg = |i: usize| {
            args.get(i)
                .cloned()
                .ok_or(format!("{name}: too few arguments"))
        };
        match name.trim() {
            "scans" => Ok(Program {
                name: "scans".into(),
                requires: vec!["RangeFinder".into()],
                service: Box::new(Scans {
                    wanted: arg(0)?.parse().map_err(|_| "scans N FROM".to_owned())?,
                    from: arg(1)?,
                    seen: 0,
                }),
            }),
            "exit" => Ok(Program {
                name: "exit".into(),
                requires: Vec::new(),
                service: Box::new(Exit {
                    code: arg(0)?.parse().map_err(|_| "exit CODE".to_owned())?,
                    ticked: false,
                }),
            }),
            other => Err(format!("no test program `{other}`")),
        }
    }
}

fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_emulators::testing::register(&mut registry);
    registry
}

/// A mission of the tests: its script in a folder of its own, with its programs.
struct Mission {
    dir: tempfile::TempDir,
    script: PathBuf,
}

impl Mission {
    fn new(script: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let bin = dir.path().join("bin");
        std::fs::create_dir(&bin).unwrap();
        for program in ["scans", "exit"] {
            std::fs::write(bin.join(program), program).unwrap();
        }
        let path = dir.path().join("mission.seq");
        std::fs::write(&path, script).unwrap();
        Self { dir, script: path }
    }

    /// The records of a live run of the mission, the sequencer's decision core fed
    /// `events` at their times (ms from the start of the recording), as the live driver
    /// records them.
    fn live_records(&self, supervision: Supervision, events: &[(i64, Event)]) -> Vec<Record> {
        let checked = check_with(&self.script, &FileSystem, &TrustingResolver).unwrap();
        let states = checked
            .mission
            .states()
            .iter()
            .map(|s| s.name.clone())
            .collect();
        let mut records = Vec::new();
        let mut push = |time_ms: i64, entry: Entry| {
            records.push(Record {
                seq: records.len() as u64,
                time_ns: T0 + time_ms * MS,
                entry,
            });
        };
        push(
            MISSION_AT_MS,
            Entry::MissionStarted {
                script: self.script.clone(),
                states,
                use_gui: false,
                supervision: Some(supervision),
            },
        );
        let (mut fsm, decisions) = Sequencer::start(checked.mission, supervision);
        for decision in decisions {
            push(MISSION_AT_MS, Entry::Decided { decision });
        }
        for (at_ms, event) in events {
            let decisions = fsm.handle(event).unwrap();
            push(
                *at_ms,
                Entry::Observed {
                    event: event.clone(),
                },
            );
            for decision in decisions {
                push(*at_ms, Entry::Decided { decision });
            }
        }
        records
    }

    /// Writes the recording of a live run: `records` on `/lewis/sequencer`, the broker's
    /// `decisions` (ms from the start, action), and both range finders' heartbeats every
    /// 100 ms for [`RUN_MS`].
    fn record(&self, records: &[Record], decisions: &[(i64, Action)]) -> PathBuf {
        self.record_with(records, decisions, false)
    }

    /// As [`Mission::record`]; with `scans`, the laser's scans too, every 20 ms from 110 ms
    /// (it came up for look), each reading 1 m: not what the replayed laser sees.
    fn record_with(&self, records: &[Record], decisions: &[(i64, Action)], scans: bool) -> PathBuf {
        let path = self.dir.path().join("run.mcap");
        let mut options = RecorderOptions::new(&path);
        options.sync_on_flush = false;
        options.disk_reserve_bytes = 0;
        options.robot_description = Some(RobotDescription {
            file_name: "looker.toml".into(),
            toml: ROBOT.into(),
        });
        let mut recorder = Recorder::create(options).unwrap();
        let sequencer = channel::<SequencerMessage>(
            &mut recorder,
            names::SEQUENCER_NODE,
            names::SEQUENCER_CHANNEL,
        );
        let broker = channel::<lewis_interfaces::msg::Broker>(
            &mut recorder,
            names::BROKER_NODE,
            names::BROKER_CHANNEL,
        );
        let health: Vec<ChannelId> = ["laser", "sonar"]
            .iter()
            .map(|s| channel::<HealthMessage>(&mut recorder, s, &names::health_channel(s)))
            .collect();
        let mut messages: Vec<(i64, ChannelId, Vec<u8>, u64)> = Vec::new();
        for record in records {
            let message = to_message(record);
            messages.push((
                record.time_ns,
                sequencer,
                cdr::to_vec(&message),
                message.header.seq,
            ));
        }
        for (seq, (at_ms, action)) in (1..).zip(decisions) {
            let at_ns = T0 + at_ms * MS;
            let mut message = decision_message(&BrokerDecision {
                at_ns,
                action: action.clone(),
                reason: "recorded".into(),
            });
            stamp(&mut message, names::BROKER_NODE, seq, at_ns);
            messages.push((at_ns, broker, cdr::to_vec(&message), seq));
        }
        for (seq, at_ms) in (1..).zip((0..=RUN_MS).step_by(100)) {
            let at_ns = T0 + at_ms * MS;
            for (channel, service) in health.iter().zip(["laser", "sonar"]) {
                let mut ok = HealthMessage {
                    state: "ok".into(),
                    ..HealthMessage::default()
                };
                stamp(&mut ok, service, seq, at_ns);
                messages.push((at_ns, *channel, cdr::to_vec(&ok), seq));
            }
        }
        if scans {
            let laser = channel::<RangeFinder>(
                &mut recorder,
                "laser",
                &names::data_channel("laser", "RangeFinder"),
            );
            for (seq, at_ms) in (1..).zip((110..=RUN_MS).step_by(20)) {
                let at_ns = T0 + at_ms * MS;
                let mut scan = RangeFinder {
                    ranges: vec![1.0; 19],
                    ..RangeFinder::default()
                };
                stamp(&mut scan, "laser", seq, at_ns);
                messages.push((at_ns, laser, cdr::to_vec(&scan), seq));
            }
        }
        messages.sort_by_key(|(at, ..)| *at);
        for (at_ns, channel, data, seq) in &messages {
            recorder
                .write(&Sample {
                    channel: *channel,
                    seq: *seq,
                    publish_time_ns: *at_ns,
                    log_time_ns: *at_ns,
                    data,
                })
                .unwrap();
        }
        recorder.close().unwrap();
        path
    }

    /// `lewis replay RUN --all` with `faults` injected: the mission lived again.
    fn replay(&self, run: &Path, faults: &[&str]) -> Report {
        self.replay_with(run, faults, false)
    }

    /// As [`Mission::replay`], the outputs checked too when `check_outputs`.
    fn replay_with(&self, run: &Path, faults: &[&str], check_outputs: bool) -> Report {
        let mut options = ReplayOptions::new(vec![run.to_path_buf()]);
        options.output = Some(self.dir.path().join("replay.mcap"));
        options.services = ServiceSelection::All;
        options.faults = faults
            .iter()
            .map(|f| f.parse::<FaultSpec>().unwrap())
            .collect();
        options.check_outputs = check_outputs;
        replay_with(&options, &registry(), Some(&TestPrograms), &mut |_| {}).unwrap()
    }
}

fn channel<T: Interface>(recorder: &mut Recorder, provider: &str, topic: &str) -> ChannelId {
    let info = lewis_interfaces::interface_info(T::NAME).unwrap();
    recorder
        .add_channel(ChannelSpec::publication(info, provider, topic))
        .unwrap()
}

fn stamp<T: Message>(message: &mut T, provider: &str, seq: u64, time_ns: i64) {
    let header = message.header_mut();
    header.provider = provider.into();
    header.seq = seq;
    header.publish_time_ns = time_ns;
}

/// The mission lived again, from a report of a closed loop.
fn replayed(report: &Report) -> &MissionOutcome {
    let mission = report.mission.as_ref().expect("a mission in the report");
    assert_eq!(mission.loop_kind, LoopKind::Closed, "{report}");
    mission.replayed.as_ref().expect("the mission lived again")
}

/// Looks for 5 laser scans, then reports; a look that sees nothing is restarted once, then
/// recovered from.
const LOOK: &str = "\
start look
restart 1
recovery oops

state look ./bin/scans 5 laser
  action 0 trans report
  timeout 400ms

state report ./bin/exit 0
  action 0 trans stop

state oops ./bin/exit 0
  action 0 trans stop
";

/// The live run of [`LOOK`] that went well: look at 100 ms, report at 300 ms, done.
fn look_went_well(mission: &Mission) -> PathBuf {
    look_went_well_with(mission, false)
}

/// As [`look_went_well`], the laser's scans recorded when `scans`.
fn look_went_well_with(mission: &Mission, scans: bool) -> PathBuf {
    let records = mission.live_records(
        Supervision::Unattended,
        &[
            (300, Event::Exited { code: 0 }),
            (320, Event::Exited { code: 0 }),
        ],
    );
    mission.record_with(&records, &[], scans)
}

#[test]
fn a_mission_lived_again_without_a_fault_succeeds_through_the_recorded_states() {
    let mission = Mission::new(LOOK);
    let run = look_went_well(&mission);
    let report = mission.replay(&run, &[]);
    let outcome = replayed(&report);
    assert!(outcome.succeeded, "{report}");
    assert_eq!(
        outcome.reason, "`report` exited with code 0, which leads to `stop`",
        "{report}"
    );
    assert_eq!(outcome.course(), ["look", "report"], "{report}");
    assert_eq!(
        outcome.states[0].left_by.as_deref(),
        Some("transition look -> report on 0")
    );
    assert_eq!((outcome.restarts, outcome.recoveries), (0, 0), "{report}");
    // Five scans at 50 Hz from a laser started on demand at 100 ms: over within 200 ms.
    let look = &outcome.states[0];
    assert_eq!(look.started_ns, MISSION_AT_MS * MS, "{report}");
    let took = outcome.time_to_finish_ns.unwrap();
    assert!(took > 80 * MS && took < 200 * MS, "{took} ns\n{report}");
    let same = report.mission.as_ref().unwrap().same_course();
    assert_eq!(same, Some(Ok(())), "{report}");
    assert!(report.check.passed, "{report}");
}

#[test]
fn a_mission_blind_from_the_start_is_restarted_recovers_and_fails() {
    let mission = Mission::new(LOOK);
    let run = look_went_well(&mission);
    let report = mission.replay(&run, &["laser@50ms-2s:crash", "sonar@50ms-2s:crash"]);
    let outcome = replayed(&report);
    assert!(!outcome.succeeded, "{report}");
    assert_eq!(
        outcome.reason,
        "it reached `stop` through the recovery state `oops` (exit code 0), not by finishing its task",
        "{report}"
    );
    assert_eq!(outcome.course(), ["look", "oops"], "{report}");
    // The timeout is a crash: one restart, then the recovery state.
    assert_eq!(outcome.states[0].attempts, 2, "{report}");
    assert_eq!((outcome.restarts, outcome.recoveries), (1, 1), "{report}");
    // Recorded, the mission succeeded: the check says how the replay went otherwise.
    assert!(!report.check.passed, "{report}");
    assert_eq!(
        report.check.mission.as_deref(),
        Some("the mission succeeded live but failed in the replay"),
        "{report}"
    );
}

/// Looks for sonar scans: only once the laser is gone does it get them.
const LOOK_AT_SONAR: &str = "\
start look
restart 1
recovery oops

state look ./bin/scans 5 sonar
  action 0 trans stop
  timeout 600ms

state oops ./bin/exit 0
  action 0 trans stop
";

#[test]
fn the_live_runs_process_deaths_are_applied_again_at_their_times() {
    let mission = Mission::new(LOOK_AT_SONAR);
    let records =
        mission.live_records(Supervision::Unattended, &[(500, Event::Exited { code: 0 })]);
    // Live, the laser died at 200 ms, was restarted, died again at 300 ms and was given up:
    // its client was moved to the sonar.
    let run = mission.record(
        &records,
        &[
            (
                200,
                Action::RestartScheduled {
                    service: "laser".into(),
                    at_ns: T0 + 220 * MS,
                    attempt: 1,
                },
            ),
            (
                300,
                Action::ServiceFailed {
                    service: "laser".into(),
                },
            ),
        ],
    );
    let report = mission.replay(&run, &[]);
    let recorded_faults = &report.mission.as_ref().unwrap().recorded_faults;
    assert_eq!(
        recorded_faults,
        &["laser@0.2s:crash", "laser@0.3s:stuck"],
        "{report}"
    );
    // Lived again, the laser fails as live, and only then does look see the sonar.
    assert!(
        report.failures.iter().any(|f| f.service == "laser"),
        "{report}"
    );
    let outcome = replayed(&report);
    assert!(outcome.succeeded, "{report}");
    assert_eq!(outcome.course(), ["look"], "{report}");
    assert_eq!((outcome.restarts, outcome.recoveries), (0, 0), "{report}");
    let ended = outcome.states[0].ended_ns.unwrap();
    assert!(
        ended > 300 * MS,
        "look ended at {ended} ns, before the laser died\n{report}"
    );
}

/// Look exits 5, which it does not list: the recovery state runs, and the supervisor is
/// asked where to resume (suggested: `again`).
const ASKED: &str = "\
start look
recovery oops

state look ./bin/exit 5
  action 1 trans again

state again ./bin/exit 0
  action 0 trans stop

state oops ./bin/exit 0
  action 0 trans again
";

#[test]
fn the_supervisors_recorded_answer_is_given_again() {
    let mission = Mission::new(ASKED);
    // Live, the supervisor stopped the mission when asked.
    let records = mission.live_records(
        Supervision::Terminal,
        &[
            (150, Event::Exited { code: 5 }),
            (200, Event::Exited { code: 0 }),
            (900, Event::SupervisorStopped),
        ],
    );
    let run = mission.record(&records, &[]);
    let report = mission.replay(&run, &[]);
    let answers = &report.mission.as_ref().unwrap().answers;
    assert_eq!(answers.len(), 1, "{report}");
    assert_eq!(
        (answers[0].answer.as_str(), answers[0].source),
        ("stop", AnswerSource::Recorded),
        "{report}"
    );
    let outcome = replayed(&report);
    assert!(!outcome.succeeded, "{report}");
    assert_eq!(outcome.course(), ["look", "oops"], "{report}");
    assert_eq!(outcome.recoveries, 1, "{report}");
    assert!(report.check.passed, "{report}");
}

#[test]
fn a_question_without_a_recorded_answer_takes_the_scripts_suggestion() {
    let mission = Mission::new(ASKED);
    // Live, look exited 1 and nobody was asked anything.
    let records = mission.live_records(
        Supervision::Terminal,
        &[
            (150, Event::Exited { code: 1 }),
            (200, Event::Exited { code: 0 }),
        ],
    );
    let run = mission.record(&records, &[]);
    let report = mission.replay(&run, &[]);
    let answers = &report.mission.as_ref().unwrap().answers;
    assert_eq!(answers.len(), 1, "{report}");
    assert_eq!(
        (answers[0].answer.as_str(), answers[0].source),
        ("again", AnswerSource::Suggested),
        "{report}"
    );
    let outcome = replayed(&report);
    assert!(outcome.succeeded, "{report}");
    assert_eq!(outcome.course(), ["look", "oops", "again"], "{report}");
    // Lived again it went another way than live (through the recovery state).
    assert_eq!(
        report.check.mission.as_deref(),
        Some("the states visited differ: look, again live, look, oops, again in the replay"),
        "{report}"
    );
    let text = report.to_string();
    assert!(
        text.contains("`again`, the script's suggestion (none recorded there)"),
        "{text}"
    );
}

#[test]
fn a_mission_lived_again_is_checked_on_its_course_alone_unless_the_outputs_are_asked_for() {
    let mission = Mission::new(LOOK);
    // The recorded scans read 1 m everywhere, the replayed laser sees its room.
    let run = look_went_well_with(&mission, true);
    let course = mission.replay_with(&run, &[], false);
    assert_eq!(course.check.compared, Compared::MissionOnly, "{course}");
    assert!(course.check.passed, "{course}");
    assert!(course.check.failing.is_empty(), "{course}");
    assert!(
        course.to_string().ends_with(
            "check (the mission's states and outcome only; --check-outputs compares the \
             outputs too): the mission went as recorded (the same states in the same order, \
             the same outcome)"
        ),
        "{course}"
    );

    let outputs = mission.replay_with(&run, &[], true);
    assert_eq!(
        outputs.check.compared,
        Compared::MissionAndOutputs,
        "{outputs}"
    );
    assert!(!outputs.check.passed, "{outputs}");
    assert_eq!(outputs.check.failing, ["/laser/RangeFinder"], "{outputs}");
    assert_eq!(outputs.check.mission, None, "{outputs}");
    assert!(
        outputs.to_string().ends_with(
            "check (the mission's states and outcome, and the outputs): the mission went as \
             recorded (the same states in the same order, the same outcome); outputs differ \
             from the recording beyond 1e-6 on /laser/RangeFinder"
        ),
        "{outputs}"
    );
}

#[test]
fn outputs_checked_in_a_closed_loop_pass_when_none_differs() {
    let mission = Mission::new(LOOK);
    // Nothing of the re-simulated services' outputs is recorded: nothing differs.
    let run = look_went_well(&mission);
    let report = mission.replay_with(&run, &[], true);
    assert_eq!(
        report.check.compared,
        Compared::MissionAndOutputs,
        "{report}"
    );
    assert!(report.check.passed, "{report}");
    assert!(
        report
            .to_string()
            .ends_with("; outputs match the recording (tolerance 1e-6)"),
        "{report}"
    );
}
