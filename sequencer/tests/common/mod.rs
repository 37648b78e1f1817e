//! Helpers shared by the live tests: scripts written into a temp folder with the test
//! program, missions run on a thread, and the records shown compactly.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod http;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use lewis_sequencer::live::{Controller, LogLine, RunOptions, control_channel, run_mission};
use lewis_sequencer::record::{ChannelSink, Entry, Record, RecordSink, Tee};
use lewis_sequencer::{Decision, Mission, Outcome, Supervision, check_file};

/// The test program built with this crate.
pub const TESTPROG: &str = env!("CARGO_BIN_EXE_lewis-seq-testprog");

/// The paper's script with `{P}` for the test program and `{D}` for the temp folder.
pub const PAPER: &str = "\
start door
restart 3
recovery oops
use gui

state door {P} exit:0
  action 0 trans sign

# Follows two signs (0), then reaches the queue (1).
state sign {P} --runs {D}/sign.runs exit:0 exit:0 exit:1
  action 0 trans sign
  action 1 trans queue

# Crashes four times: three restarts, then recovery; after the supervisor sends the robot
# back here, it works.
state queue {P} --runs {D}/queue.runs signal:SEGV signal:SEGV signal:SEGV signal:SEGV exit:0
  action 0 trans register

# Exits with a code the script does not list, then succeeds.
state register {P} --runs {D}/register.runs exit:7 exit:0
  action 0 trans stop

state oops {P} print:recovering exit:0
  action 0 trans stop
";

/// Writes `script` (with `{P}` and `{D}` replaced) as `mission.seq` in `dir` and checks it.
pub fn write_script(dir: &Path, script: &str) -> (PathBuf, Mission) {
    let text = script
        .replace("{P}", TESTPROG)
        .replace("{D}", &dir.display().to_string());
    let path = dir.join("mission.seq");
    std::fs::write(&path, text).unwrap();
    let checked = check_file(&path).unwrap_or_else(|d| panic!("the test script is broken:\n{d}"));
    (path, checked.mission)
}

/// What a test does with each record while the mission runs.
pub type OnRecord<'a> = dyn FnMut(&Record, &Controller) + 'a;

/// Runs `mission` on a thread; `on_record` sees every record as it comes (and may send
/// commands); `extra` gets the records too. Returns the outcome and every record.
pub fn run_live(
    script: &Path,
    mission: Mission,
    options: impl FnOnce(RunOptions) -> RunOptions,
    extra: Option<&mut (dyn RecordSink + Send)>,
    on_record: &mut OnRecord<'_>,
) -> (Outcome, Vec<Record>) {
    let (controller, control) = control_channel().unwrap();
    let (tx, rx) = mpsc::channel();
    let options = options(RunOptions {
        stop_grace: Duration::from_millis(500),
        // As `lewis seq run` without a terminal: the page with `use gui`, else nobody.
        supervision: Supervision::decide(mission.use_gui(), false, false),
        ..RunOptions::new(script)
    });
    std::thread::scope(|scope| {
        let driver = scope.spawn(move || {
            let mut tee = Tee::new().with(ChannelSink(tx));
            if let Some(extra) = extra {
                tee = tee.with(extra);
            }
            run_mission(mission, options, &control, &mut tee)
        });
        let mut records = Vec::new();
        let mut failure = None;
        for record in rx {
            if failure.is_none() {
                let seen = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    on_record(&record, &controller);
                }));
                if let Err(panic) = seen {
                    // Stop the mission so the driver's thread ends, then fail the test.
                    controller.interrupt("the test failed");
                    failure = Some(panic);
                }
            }
            records.push(record);
        }
        let outcome = driver.join().unwrap().unwrap();
        if let Some(panic) = failure {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("{}", show(&records));
            }
            std::panic::resume_unwind(panic);
        }
        (outcome, records)
    })
}

/// Answers the supervisor's questions with `answers`, in order.
pub fn answering(answers: &[&str]) -> impl FnMut(&Record, &Controller) + Send + use<> {
    let mut answers: Vec<String> = answers.iter().rev().map(|s| (*s).to_owned()).collect();
    move |record, controller| {
        if let Entry::Decided {
            decision: Decision::AskSupervisor { .. },
        } = &record.entry
        {
            let answer = answers
                .pop()
                .expect("the supervisor was asked more often than expected");
            controller.choose(answer);
        }
    }
}

/// The records as short lines: events with `>`, decisions without their reasons (and a
/// run as `run STATE #ATTEMPT`), refusals with `refused`.
pub fn show(records: &[Record]) -> String {
    let mut out = String::new();
    for record in records {
        let line = match &record.entry {
            Entry::MissionStarted { states, .. } => format!("mission {}", states.join(" ")),
            Entry::Observed { event } => format!("> {event}"),
            Entry::Refused { event, error } => format!("refused {event}: {error}"),
            Entry::Decided {
                decision: Decision::Run { state, attempt, .. },
            } => format!("run {state} #{attempt}"),
            Entry::Decided { decision } => decision.summary(),
            Entry::ProgramStarted { .. } => continue,
        };
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// Whether process `pid` is gone, waiting up to 10 s for it to die (through a pidfd, so
/// no polling): a zombie counts as gone.
pub fn is_gone(pid: u32) -> bool {
    let Ok(raw) = i32::try_from(pid) else {
        return true;
    };
    let Some(pid) = rustix::process::Pid::from_raw(raw) else {
        return true;
    };
    let Ok(fd) = rustix::process::pidfd_open(pid, rustix::process::PidfdFlags::empty()) else {
        return true;
    };
    let mut fds = [rustix::event::PollFd::new(
        &fd,
        rustix::event::PollFlags::IN,
    )];
    let timeout = rustix::time::Timespec {
        tv_sec: 10,
        tv_nsec: 0,
    };
    matches!(rustix::event::poll(&mut fds, Some(&timeout)), Ok(1))
}

/// Reads a pid written by the test program's `pidfile:` or `child:` step.
pub fn read_pid(path: &Path) -> u32 {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .trim()
        .parse()
        .unwrap()
}

/// Waits on `lines` for a line `text` from the program of `state`.
pub fn wait_for_line(lines: &mpsc::Receiver<LogLine>, state: &str, text: &str) {
    for line in lines {
        if &*line.name == state && line.text == text {
            return;
        }
    }
    panic!("the program of `{state}` never printed `{text}`");
}
