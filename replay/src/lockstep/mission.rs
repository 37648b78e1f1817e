//! The sequencer and its sub-task programs inside the harness: the closed loop of a whole
//! mission.
//!
//! The sequencer's decision core ([`Sequencer`]) runs on the virtual clock, started when the
//! recorded mission started. Each `run` decision builds the state's program through
//! [`Programs`] ([`AppPrograms`](super::AppPrograms): the program a script names with
//! `lewis app NAME`) and makes
//! it a participant like a re-simulated service: it is a client of the broker core (it asks
//! for what it requires, and is gone when it finishes), it ticks at its own period from its
//! start, it gets the samples of its providers and the replies to its calls. Once a handler
//! leaves it with an exit code ([`Service::exit_code`]), it gets its `on_stop`, and the
//! sequencer hears `exit code N` at that instant; a state's timeout stops it and is a
//! crash, as live.
//!
//! What a program may not do, for this to hold (and what the live harness does not need
//! either): start threads, read a clock other than `ctx.now()`, sleep, or block on a read.
//! Everything it learns comes through its handlers, so the same events in the same order
//! give the same decisions.
//!
//! When the sequencer asks the supervisor, the answer is the recorded one at that point
//! (the n-th question gets the recording's n-th answer, if it has one and it is still a
//! choice), else the script's suggestion, else `stop`; [`Answer`] says which. Every record
//! the sequencer makes goes to the sink, as live it goes to `/lewis/sequencer`.

use std::collections::{BTreeSet, VecDeque};
use std::path::{Path, PathBuf};

use lewis_runtime::broker::Event as BrokerEvent;
use lewis_sequencer::{Decision, Entry, Event, Mission, Record, Sequencer, Supervision};
use lewis_service::{ContextState, Service};
use serde::Serialize;

use super::backend::StepBackend;
use super::engine::{Sim, Timer, Work};
use super::{Emitted, Lockstep, Sink};

/// The seed of a program's context, as the live program harness gives it.
const PROGRAM_SEED: u64 = 1;

/// Builds the program a mission state names, as a participant of the harness.
pub trait Programs {
    /// The program at `program` (the state's resolved path) with `args`, or why it cannot
    /// run here.
    ///
    /// # Errors
    /// When the file is not a program this binary knows, or its arguments are wrong.
    fn build(&self, program: &Path, args: &[String]) -> Result<Program, String>;
}

/// A program ready to run.
pub struct Program {
    /// Its name as a client (`sign-follower`); the harness adds which run it is.
    pub name: String,
    /// The interfaces it asks the broker for.
    pub requires: Vec<String>,
    /// The program itself.
    pub service: Box<dyn Service>,
}

impl std::fmt::Debug for Program {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Program")
            .field("name", &self.name)
            .field("requires", &self.requires)
            .finish_non_exhaustive()
    }
}

/// The mission to run in the harness.
#[derive(Debug, Clone)]
pub struct MissionPlan {
    /// The checked mission.
    pub mission: Mission,
    /// Who answered live (recorded); a replay answers for them.
    pub supervision: Supervision,
    /// The script's path, for the first record.
    pub script: PathBuf,
    /// When the recorded mission started (its first record), on the virtual clock.
    pub start_ns: i64,
    /// The supervisor's recorded answers, in order: a state's name, or `stop`.
    pub recorded_answers: Vec<String>,
    /// How long each recorded run of a program took to come up live (from the sequencer's
    /// `run` to its first request to the broker), in order, with its state: a program of
    /// a debug build takes most of a second, and what it missed meanwhile matters.
    pub start_delays: Vec<(String, i64)>,
}

/// Where the answer to one of the sequencer's questions came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AnswerSource {
    /// The recording's answer at that point.
    Recorded,
    /// The script's suggestion (the recording has no answer there, or its answer is not a
    /// choice now).
    Suggested,
    /// Neither: the mission stops.
    Stop,
}

/// One question of the sequencer in the replay and its answer.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Answer {
    /// When it was asked, on the virtual clock.
    pub time_ns: i64,
    /// The state chosen, or `stop`.
    pub answer: String,
    /// Where the answer came from.
    pub source: AnswerSource,
}

/// The mission as the harness runs it.
pub(super) struct MissionRun<'a> {
    programs: &'a dyn Programs,
    /// The plan until the mission starts.
    plan: Option<MissionPlan>,
    script: PathBuf,
    fsm: Option<Sequencer>,
    recorded_answers: VecDeque<String>,
    start_delays: VecDeque<(String, i64)>,
    /// The delay of a run the recording has no match for: the median of the recorded ones.
    usual_delay_ns: i64,
    /// What the program starting now requires, until it comes up.
    requires: Vec<String>,
    /// The program running now: its client name and generation.
    running: Option<(String, u64)>,
    /// Programs started so far (names each one's client).
    runs: u32,
    records: Vec<Record>,
    answers: Vec<Answer>,
    over_at_ns: Option<i64>,
}

impl<'a> MissionRun<'a> {
    pub(super) fn new(plan: MissionPlan, programs: &'a dyn Programs) -> Self {
        Self {
            programs,
            script: plan.script.clone(),
            recorded_answers: plan.recorded_answers.iter().cloned().collect(),
            start_delays: plan.start_delays.iter().cloned().collect(),
            usual_delay_ns: median(plan.start_delays.iter().map(|(_, d)| *d).collect()),
            requires: Vec::new(),
            plan: Some(plan),
            fsm: None,
            running: None,
            runs: 0,
            records: Vec::new(),
            answers: Vec::new(),
            over_at_ns: None,
        }
    }

    /// Whether the mission is over (finished or aborted).
    pub(super) fn is_over(&self) -> bool {
        self.over_at_ns.is_some()
    }

    /// How long the next run, of `state`, takes to come up: as its recorded counterpart
    /// did, while the replay runs the states the recording ran; as usual otherwise.
    fn start_delay(&mut self, state: &str) -> i64 {
        match self.start_delays.pop_front() {
            Some((recorded, delay)) if recorded == state => delay,
            _ => {
                // Another course than the recording's: nothing more to match.
                self.start_delays.clear();
                self.usual_delay_ns
            }
        }
    }
}

/// The median of `values` (0 when there are none).
fn median(mut values: Vec<i64>) -> i64 {
    values.sort_unstable();
    values.get(values.len() / 2).copied().unwrap_or(0)
}

impl<'a> Lockstep<'a> {
    /// Runs `plan`'s mission in the harness, its programs built by `programs` (see the
    /// module documentation). Call it before the replay starts.
    pub fn with_mission(&mut self, plan: MissionPlan, programs: &'a dyn Programs) {
        let at = plan.start_ns;
        self.script.run_past_recorded_stops();
        self.mission = Some(MissionRun::new(plan, programs));
        self.schedule(at, Timer::MissionStarts);
    }

    /// The records of the replayed mission so far.
    #[must_use]
    pub fn mission_records(&self) -> &[Record] {
        self.mission.as_ref().map_or(&[], |m| &m.records)
    }

    /// The supervisor's answers in the replayed mission so far.
    #[must_use]
    pub fn mission_answers(&self) -> &[Answer] {
        self.mission.as_ref().map_or(&[], |m| &m.answers)
    }

    /// When the replayed mission ended, if it did.
    #[must_use]
    pub fn mission_over_at(&self) -> Option<i64> {
        self.mission.as_ref().and_then(|m| m.over_at_ns)
    }

    /// Whether `client`, seen in the recording, stands for what the mission in the harness
    /// does again: with a mission run here, a recorded client that is no service of the
    /// robot is one of the recorded sequencer's programs.
    pub(super) fn is_mission_client(&self, client: &str) -> bool {
        self.mission.is_some() && self.robot.service(client).is_none()
    }

    /// After the recording's last message: the mission goes on until it is over, or until
    /// `limit_ns`. Nothing recorded is left to follow, so every service now runs free,
    /// ticking at its own period.
    pub fn finish_mission(&mut self, limit_ns: i64, sink: &mut dyn Sink) {
        if self.mission.as_ref().is_none_or(MissionRun::is_over) {
            return;
        }
        for service in self.script.unfollow_all() {
            let Some(sim) = self.sims.get(&service) else {
                continue;
            };
            if let (Some(period), true) = (sim.tick_period_ns, sim.instance.is_some()) {
                let generation = sim.generation;
                let at = self.now_ns.saturating_add(period);
                self.schedule(
                    at,
                    Timer::Tick {
                        service: service.clone(),
                        generation,
                    },
                );
            }
            self.release_held(&service, sink);
        }
        while self.mission.as_ref().is_some_and(|m| !m.is_over()) {
            let Some(entry) = self.timers.first_entry() else {
                break;
            };
            if entry.key().0 > limit_ns {
                break;
            }
            let ((time, _), timer) = entry.remove_entry();
            self.now_ns = time;
            self.fire(timer, sink);
            self.pump(sink);
        }
    }

    pub(super) fn mission_starts(&mut self, sink: &mut dyn Sink) {
        let Some(run) = self.mission.as_mut() else {
            return;
        };
        let Some(plan) = run.plan.take() else {
            return;
        };
        let states = plan
            .mission
            .states()
            .iter()
            .map(|s| s.name.clone())
            .collect();
        let use_gui = plan.mission.use_gui();
        let (fsm, decisions) = Sequencer::start(plan.mission, plan.supervision);
        run.fsm = Some(fsm);
        let script = run.script.clone();
        self.mission_record(
            Entry::MissionStarted {
                script,
                states,
                use_gui,
                supervision: Some(plan.supervision),
            },
            sink,
        );
        self.mission_decisions(decisions, sink);
    }

    /// Feeds the sequencer one event (a program's end, the supervisor's answer).
    pub(super) fn mission_event(&mut self, event: Event, sink: &mut dyn Sink) {
        let Some(fsm) = self.mission.as_mut().and_then(|m| m.fsm.as_mut()) else {
            return;
        };
        match fsm.handle(&event) {
            Ok(decisions) => {
                self.mission_record(Entry::Observed { event }, sink);
                self.mission_decisions(decisions, sink);
            }
            Err(e) => self.mission_record(
                Entry::Refused {
                    event,
                    error: e.to_string(),
                },
                sink,
            ),
        }
    }

    fn mission_decisions(&mut self, decisions: Vec<Decision>, sink: &mut dyn Sink) {
        for decision in decisions {
            self.mission_record(
                Entry::Decided {
                    decision: decision.clone(),
                },
                sink,
            );
            match decision {
                Decision::Run {
                    state,
                    program,
                    args,
                    timeout_ns,
                    ..
                } => self.start_program(&state, &program, &args, timeout_ns),
                Decision::AskSupervisor {
                    choices, suggested, ..
                } => self.answer(&choices, suggested),
                Decision::Finished { .. } | Decision::Aborted { .. } => {
                    let now = self.now_ns;
                    if let Some(run) = self.mission.as_mut() {
                        run.over_at_ns = Some(now);
                    }
                }
                Decision::Restart { .. }
                | Decision::EnterRecovery { .. }
                | Decision::Resume { .. }
                | Decision::Transition { .. } => {}
            }
        }
    }

    fn mission_record(&mut self, entry: Entry, sink: &mut dyn Sink) {
        let now = self.now_ns;
        let Some(run) = self.mission.as_mut() else {
            return;
        };
        let record = Record {
            seq: run.records.len() as u64,
            time_ns: now,
            entry,
        };
        sink.emit(Emitted::Mission(&record));
        run.records.push(record);
    }

    /// The supervisor's answer: the recorded one if it is still a choice, else the
    /// suggestion, else `stop`. It comes at once.
    fn answer(&mut self, choices: &[String], suggested: Option<String>) {
        let now = self.now_ns;
        let Some(run) = self.mission.as_mut() else {
            return;
        };
        let recorded = run
            .recorded_answers
            .pop_front()
            .filter(|a| a == "stop" || choices.contains(a));
        let (answer, source) = match (recorded, suggested) {
            (Some(a), _) => (a, AnswerSource::Recorded),
            (None, Some(s)) => (s, AnswerSource::Suggested),
            (None, None) => ("stop".to_owned(), AnswerSource::Stop),
        };
        run.answers.push(Answer {
            time_ns: now,
            answer: answer.clone(),
            source,
        });
        let event = if answer == "stop" {
            Event::SupervisorStopped
        } else {
            Event::SupervisorChose { state: answer }
        };
        self.work.push_back(Work::Mission(event));
    }

    fn start_program(
        &mut self,
        state: &str,
        program: &Path,
        args: &[String],
        timeout_ns: Option<i64>,
    ) {
        let Some(run) = self.mission.as_mut() else {
            return;
        };
        let delay_ns = run.start_delay(state);
        let built = match run.programs.build(program, args) {
            Ok(built) => built,
            Err(error) => {
                self.work
                    .push_back(Work::Mission(Event::SpawnFailed { error }));
                return;
            }
        };
        run.runs += 1;
        // Live, a program's client is named after its process; here after its run.
        let name = format!("{}-{}", built.name, run.runs);
        let tick_period_ns = built.service.tick_period_ns().filter(|p| *p > 0);
        let sim = Sim {
            instance: Some(built.service),
            state: ContextState::new(&name, PROGRAM_SEED),
            backend: StepBackend::new(&name, [], built.requires.iter().cloned()),
            generation: 1,
            stalled: false,
            tick_period_ns,
            commands_answered: 0,
            held: VecDeque::new(),
            subscribed: BTreeSet::new(),
        };
        self.sims.insert(name.clone(), sim);
        if let Some(run) = self.mission.as_mut() {
            run.running = Some((name.clone(), 1));
            run.requires = built.requires;
        }
        let up_at = self.now_ns.saturating_add(delay_ns);
        self.schedule(
            up_at,
            Timer::ProgramComesUp {
                program: name.clone(),
                generation: 1,
            },
        );
        if let Some(timeout) = timeout_ns {
            let at = self.now_ns.saturating_add(timeout);
            self.schedule(
                at,
                Timer::ProgramTimeout {
                    program: name,
                    generation: 1,
                },
            );
        }
    }

    /// The program `name` came up: as the live harness, it asks for what it requires, then
    /// starts.
    pub(super) fn program_comes_up(&mut self, name: &str, generation: u64) {
        let Some(run) = self.mission.as_mut() else {
            return;
        };
        if run
            .running
            .as_ref()
            .is_none_or(|(n, g)| n != name || *g != generation)
        {
            return;
        }
        for interface in std::mem::take(&mut run.requires) {
            self.work
                .push_back(Work::Broker(BrokerEvent::ClientRequest {
                    client: name.to_owned(),
                    interface,
                }));
        }
        self.work.push_back(Work::Start {
            service: name.to_owned(),
            generation,
        });
    }

    /// After a handler of `name`: a program that finished ends now.
    pub(super) fn check_program_exit(&mut self, name: &str) {
        let Some((running, generation)) = self.mission.as_ref().and_then(|m| m.running.clone())
        else {
            return;
        };
        if running != name {
            return;
        }
        let code = self
            .sims
            .get(name)
            .and_then(|s| s.instance.as_ref())
            .and_then(|i| i.exit_code());
        if let Some(code) = code {
            self.end_program(name, generation, Event::Exited { code });
        }
    }

    /// The program `name` could not start (its `on_start` failed): it ends as a process
    /// that exits with 1 at once.
    pub(super) fn program_failed_to_start(&mut self, name: &str, generation: u64) {
        let current = self.mission.as_ref().and_then(|m| m.running.clone());
        if current.is_some_and(|(n, g)| n == name && g == generation) {
            self.end_program(name, generation, Event::Exited { code: 1 });
        }
    }

    /// The state's timeout: the program is stopped, a crash.
    pub(super) fn program_timed_out(&mut self, name: &str, generation: u64) {
        let current = self.mission.as_ref().and_then(|m| m.running.clone());
        if current.is_some_and(|(n, g)| n == name && g == generation) {
            self.end_program(name, generation, Event::TimedOut);
        }
    }

    /// Queues the end of the running program `name`: its `on_stop`, the broker's loss of the
    /// client, then the sequencer's event.
    fn end_program(&mut self, name: &str, generation: u64, event: Event) {
        if let Some(run) = self.mission.as_mut() {
            run.running = None;
        }
        self.work.push_back(Work::ProgramEnded {
            program: name.to_owned(),
            generation,
            event,
        });
    }

    pub(super) fn program_ended(
        &mut self,
        name: &str,
        generation: u64,
        event: Event,
        sink: &mut dyn Sink,
    ) {
        let Some(sim) = self.sims.get(name) else {
            return;
        };
        if sim.generation != generation {
            return;
        }
        if sim.instance.is_some() {
            self.dispatch(name, Vec::new(), sink, |s, ctx| s.on_stop(ctx));
        }
        if let Some(sim) = self.sims.get_mut(name) {
            sim.instance = None;
            sim.generation += 1;
            sim.held.clear();
        }
        self.bindings.retain(|(client, _), _| client != name);
        // A program that ended is not blind: its gaps end with it.
        let open: Vec<(String, String)> = self
            .last_input
            .keys()
            .filter(|(client, _)| client == name)
            .cloned()
            .collect();
        for key in open {
            if let Some(last) = self.last_input.remove(&key) {
                self.note_gap(name, &key.1, last, self.now_ns);
            }
        }
        self.work.push_back(Work::Broker(BrokerEvent::ClientGone {
            client: name.to_owned(),
        }));
        self.work.push_back(Work::Mission(event));
    }
}
