//! Who answers `lewis seq run` after recovery (a real process): on a terminal (a
//! pseudo-terminal here, as a person at a console) the supervisor is asked even without
//! `use gui`, and Enter takes the script's suggestion; with no terminal (standard input
//! from `/dev/null`, as under a service manager or CI) nobody is asked and the recovery
//! state's own actions apply, which the program says.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::mpsc;

use common::{TESTPROG, show};
use lewis_runtime::ipc::Namespace;
use lewis_sequencer::record::{Entry, Record};
use lewis_sequencer::{Supervision, read_json_lines};
use lewis_testkit::{WATCHDOG, lewis_exe, wait_child};

/// `a` fails twice with a code the script does not list; the recovery `r` suggests `stop`.
const SCRIPT: &str = "\
start a
recovery r

state a {P} --runs {D}/a.runs exit:3 exit:3 exit:0
  action 0 trans stop

state r {P} exit:0
  action 0 trans stop
";

const PROMPT: &str = "then Enter:";

fn write_script(dir: &Path, script: &str) -> std::path::PathBuf {
    let path = dir.join("mission.seq");
    std::fs::write(
        &path,
        script
            .replace("{P}", TESTPROG)
            .replace("{D}", &dir.display().to_string()),
    )
    .unwrap();
    path
}

fn lewis_seq_run(script: &Path, events: &Path, extra: &[&str]) -> Command {
    let mut command = Command::new(lewis_exe());
    command
        .args(["seq", "run"])
        .arg(script)
        .args(["--namespace", Namespace::unique("seq-tty").as_str()])
        .arg("--events")
        .arg(events)
        .args(extra);
    command
}

fn records(events: &Path) -> Vec<Record> {
    read_json_lines(std::io::BufReader::new(
        std::fs::File::open(events).unwrap(),
    ))
    .unwrap()
}

fn supervision(records: &[Record]) -> Option<Supervision> {
    match records.first().map(|r| &r.entry) {
        Some(Entry::MissionStarted { supervision, .. }) => *supervision,
        other => panic!("the first record is not the mission's start: {other:?}"),
    }
}

/// Reads the terminal's output on a thread, handing over what it has each time it reads.
fn read_terminal(mut master: std::fs::File) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buffer = [0_u8; 4096];
        // EIO once every holder of the terminal's other side has closed it: the end.
        while let Ok(read) = master.read(&mut buffer) {
            if read == 0
                || tx
                    .send(String::from_utf8_lossy(&buffer[..read]).into_owned())
                    .is_err()
            {
                break;
            }
        }
    });
    rx
}

/// Waits for the `n`th prompt in what the terminal printed, collecting it in `seen`.
fn wait_prompt(output: &mpsc::Receiver<String>, seen: &mut String, n: usize) {
    while seen.matches(PROMPT).count() < n {
        match output.recv_timeout(WATCHDOG) {
            Ok(text) => seen.push_str(&text),
            Err(e) => panic!("no prompt {n} ({e}); the terminal showed:\n{seen}"),
        }
    }
}

#[test]
fn on_a_terminal_without_use_gui_the_supervisor_is_asked_and_enter_takes_the_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    let script = write_script(dir.path(), SCRIPT);
    let events = dir.path().join("events.jsonl");
    let pty = nix::pty::openpty(None, None).unwrap();
    let slave: OwnedFd = pty.slave;
    let mut child = lewis_seq_run(&script, &events, &[])
        .stdin(Stdio::from(slave.try_clone().unwrap()))
        .stdout(Stdio::from(slave.try_clone().unwrap()))
        .stderr(Stdio::from(slave))
        .spawn()
        .unwrap();
    let mut keyboard = std::fs::File::from(pty.master);
    let output = read_terminal(keyboard.try_clone().unwrap());
    let mut seen = String::new();

    wait_prompt(&output, &mut seen, 1);
    keyboard.write_all(b"a\n").unwrap();
    wait_prompt(&output, &mut seen, 2);
    keyboard.write_all(b"\n").unwrap();
    let status = wait_child(&mut child);
    while let Ok(text) = output.recv_timeout(WATCHDOG) {
        seen.push_str(&text);
    }

    // The supervisor stopped the mission after recovery: it reached `stop`, but its task
    // was not done, so `lewis seq run` exits with 1 (issue 20).
    assert_eq!(status.code(), Some(1), "the terminal showed:\n{seen}");
    assert!(
        seen.contains("the supervisor is asked on this terminal after recovery"),
        "{seen}"
    );
    assert!(
        seen.contains(
            "Type the state to resume from (a, r) or `stop` (the script suggests stop: just Enter)"
        ),
        "{seen}"
    );
    let records = records(&events);
    assert_eq!(supervision(&records), Some(Supervision::Terminal));
    let shown = show(&records);
    let tail: Vec<&str> = shown.lines().skip(1).collect();
    assert_eq!(
        tail,
        [
            "run a #1",
            "> exit code 3",
            "recover from a",
            "run r #1",
            "> exit code 0",
            "ask the supervisor: a, r or stop (suggested stop)",
            "> the supervisor's choice of `a`",
            "resume at a",
            "run a #1",
            "> exit code 3",
            "recover from a",
            "run r #1",
            "> exit code 0",
            "ask the supervisor: a, r or stop (suggested stop)",
            "> the supervisor's choice of `stop`",
            "finished",
        ],
        "the terminal showed:\n{seen}"
    );
}

#[test]
fn without_a_terminal_nobody_is_asked_even_with_use_gui_and_no_gui_and_recovery_decides() {
    let dir = tempfile::tempdir().unwrap();
    let script = write_script(dir.path(), &format!("use gui\n{SCRIPT}"));
    let events = dir.path().join("events.jsonl");
    let child = lewis_seq_run(&script, &events, &["--no-gui"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    let output = rx
        .recv_timeout(WATCHDOG)
        .unwrap_or_else(|_| panic!("lewis seq run (pid {pid}) still runs after {WATCHDOG:?}"))
        .unwrap();
    let printed = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);

    // Recovery led to `stop`: a failure (issue 20), so `lewis seq run` exits with 1.
    assert_eq!(output.status.code(), Some(1), "{printed}");
    assert!(
        printed.contains("mission failed: it reached `stop` through the recovery state `r`"),
        "{printed}"
    );
    assert!(
        printed.contains(
            "seq: nobody can answer (no supervisor's page, and the standard input is not a \
             terminal): after recovery the recovery state's actions apply"
        ),
        "{printed}"
    );
    let records = records(&events);
    assert_eq!(supervision(&records), Some(Supervision::Unattended));
    let shown = show(&records);
    assert!(
        shown.ends_with("run r #1\n> exit code 0\ntransition r -> stop on 0\nfinished\n"),
        "{shown}"
    );
    assert!(
        printed.contains("nobody can be asked where to resume"),
        "{printed}"
    );
}
