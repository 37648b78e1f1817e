//! The registrar's answer from the supervisor's keys: `y` and `n` go to the robot's Speech
//! provider by the page's own path ([`RobotFeed::answer`]), between the sequencer's
//! questions; while it asks, the terminal reads a line (the state to resume from). Once
//! from a pipe (the mapping of input to answers and choices), once from a real
//! pseudo-terminal read key by key, whose settings come back afterwards.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::Write;
use std::net::{Ipv4Addr, SocketAddr};
use std::os::fd::OwnedFd;
use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use lewis_sequencer::gui::{Answer, RobotView};
use lewis_sequencer::keys::{KeyTerminal, answer_of_key};
use lewis_sequencer::live::{Command, control_channel};
use lewis_sequencer::record::{Entry, Record, RecordSink};
use lewis_sequencer::terminal::{TerminalKeys, answer_through};
use lewis_sequencer::{
    Decision, GuiServer, MemorySources, TerminalChooser, TrustingResolver, check_with,
};
use lewis_testkit::WATCHDOG;
use nix::sys::termios::{LocalFlags, tcgetattr};

fn answer(word: &str, text: &str) -> Answer {
    Answer {
        answer: word.into(),
        text: text.into(),
    }
}

#[test]
fn y_is_registered_n_is_not_and_other_keys_answer_nothing() {
    assert_eq!(answer_of_key(b'y'), Some(answer("yes", "registered")));
    assert_eq!(answer_of_key(b'Y'), Some(answer("yes", "registered")));
    assert_eq!(answer_of_key(b'n'), Some(answer("no", "not registered")));
    for key in [b'x', b'\n', b' ', 0x03, b'q'] {
        assert_eq!(answer_of_key(key), None, "{key}");
    }
}

fn decided(decision: Decision) -> Record {
    Record {
        seq: 0,
        time_ns: 0,
        entry: Entry::Decided { decision },
    }
}

#[test]
fn between_questions_keys_answer_and_while_asking_a_line_chooses() {
    let (reader, mut keyboard) = std::io::pipe().unwrap();
    let (controller, control) = control_channel().unwrap();
    let (tx, answers) = mpsc::channel();
    let sink = Box::new(move |a: Answer| tx.send(a).unwrap());
    let mut chooser = TerminalChooser::with_keys(
        lewis_sequencer::keys::Plain(reader),
        Vec::new(),
        controller,
        Some(sink),
    )
    .unwrap();

    keyboard.write_all(b"xy").unwrap();
    assert_eq!(
        answers.recv_timeout(WATCHDOG),
        Ok(answer("yes", "registered"))
    );

    chooser.record(&decided(Decision::AskSupervisor {
        choices: vec!["a".into(), "r".into()],
        suggested: Some("stop".into()),
        reason: "recovery is over".into(),
    }));
    // While asked, `n` is a letter of the line, not an answer.
    keyboard.write_all(b"n\nr\n").unwrap();
    let deadline = Instant::now() + WATCHDOG;
    let mut commands = Vec::new();
    while commands.len() < 2 && Instant::now() < deadline {
        commands.extend(control.drain());
        std::thread::sleep(Duration::from_millis(10));
    }
    assert_eq!(
        commands,
        [Command::Choose("n".into()), Command::Choose("r".into())]
    );
    assert!(answers.try_recv().is_err(), "no answer while asking");

    chooser.record(&decided(Decision::Resume {
        state: "r".into(),
        reason: "the supervisor chose r".into(),
    }));
    keyboard.write_all(b"n").unwrap();
    assert_eq!(
        answers.recv_timeout(WATCHDOG),
        Ok(answer("no", "not registered"))
    );
    let text = String::from_utf8(chooser.output().clone()).unwrap();
    assert!(
        text.contains("Type the state to resume from (a, r)"),
        "{text}"
    );
}

fn robot_with_speech() -> RobotView {
    RobotView {
        speech: Some("speech".into()),
        ..RobotView::default()
    }
}

#[test]
fn a_key_on_a_real_terminal_answers_through_the_page_s_path_and_the_terminal_comes_back() {
    let sources =
        MemorySources::new().with("m.seq", "start a\nstate a /bin/a\n  action 0 trans stop\n");
    let mission = check_with(Path::new("m.seq"), &sources, &TrustingResolver)
        .unwrap_or_else(|d| panic!("{d}"))
        .mission;
    let (controller, _control) = control_channel().unwrap();
    let gui = GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission,
        controller.clone(),
    )
    .unwrap();
    let feed = gui.robot_feed();
    let sent = feed.answers();
    feed.show(&robot_with_speech());

    let pty = nix::pty::openpty(None, None).unwrap();
    let slave: OwnedFd = pty.slave;
    let probe = slave.try_clone().unwrap();
    let before = tcgetattr(&probe).unwrap();
    assert!(
        before
            .local_flags
            .contains(LocalFlags::ICANON | LocalFlags::ECHO)
    );
    let (terminal, input) = KeyTerminal::open(slave).unwrap();
    TerminalKeys::start(input, controller, answer_through(feed, std::io::sink())).unwrap();

    let mut keyboard = std::fs::File::from(pty.master);
    keyboard.write_all(b"y").unwrap();
    assert_eq!(sent.recv_timeout(WATCHDOG), Ok(answer("yes", "registered")));
    let keys = tcgetattr(&probe).unwrap();
    assert!(
        !keys
            .local_flags
            .intersects(LocalFlags::ICANON | LocalFlags::ECHO),
        "read key by key, without echo: {:?}",
        keys.local_flags
    );
    assert!(
        keys.local_flags.contains(LocalFlags::ISIG),
        "Ctrl-C still interrupts"
    );

    drop(terminal);
    let after = tcgetattr(&probe).unwrap();
    assert_eq!(
        after.local_flags, before.local_flags,
        "the terminal's settings came back"
    );
    gui.shutdown();
}
