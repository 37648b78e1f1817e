//! The supervisor's choice on the terminal (without `use gui`, or with `--no-gui`, when the
//! standard input is a terminal): the question is printed when the FSM asks, and each line
//! read (a state's name, or `stop`) is sent as the choice; an empty line takes the script's
//! suggestion (the recovery state's listed target), when there is one.
//!
//! With the robot's Speech provider to answer for, the terminal's keys answer between two
//! questions (`y`, `n`: [`crate::keys`]), through the same [`RobotFeed::answer`] as the
//! page's button; [`TerminalKeys`] reads the keys alone when the page asks the questions.

use std::io::{self, BufRead, Write};
use std::sync::{Arc, Mutex, PoisonError};

use crate::fsm::{Decision, Event};
use crate::gui::{Answer, RobotFeed};
use crate::keys::{Plain, TerminalInput, answer_of_key};
use crate::live::Controller;
use crate::record::{Entry, Record, RecordSink};

/// Where the terminal's answers for the robot's Speech provider go.
pub type AnswerSink = Box<dyn FnMut(Answer) + Send>;

/// An [`AnswerSink`] that sends through `feed` (the page's one way) and says on `out` why
/// an answer was refused (what became of one sent, the feed tells:
/// [`RobotFeed::on_answered`]).
pub fn answer_through(feed: RobotFeed, mut out: impl Write + Send + 'static) -> AnswerSink {
    Box::new(move |answer| {
        if let Err(refused) = feed.answer(answer) {
            let _ = writeln!(out, "registrar: {refused}");
        }
    })
}

#[derive(Default)]
struct Shared {
    asking: bool,
    /// What an empty answer chooses while asking.
    suggested: Option<String>,
    input_closed: bool,
}

/// Prints the question and reads the answer; a [`RecordSink`] to give the driver.
///
/// When the input ends while (or before) the supervisor is asked, nobody can answer: the
/// mission is interrupted rather than left waiting forever.
pub struct TerminalChooser<W: Write> {
    out: W,
    shared: Arc<Mutex<Shared>>,
    controller: Controller,
}

impl<W: Write> TerminalChooser<W> {
    /// Reads answers from `input` on a thread of its own (left running until the input ends
    /// or the mission is over) and writes questions to `out`.
    ///
    /// # Errors
    /// When the thread cannot start.
    pub fn start(
        input: impl BufRead + Send + 'static,
        out: W,
        controller: Controller,
    ) -> io::Result<Self> {
        Self::with_keys(Plain(input), out, controller, None)
    }

    /// As [`TerminalChooser::start`], reading `input`; with `answers`, between two
    /// questions the keys `y` and `n` go there as the registrar's answers (and the
    /// terminal is read key by key), while asking it reads lines.
    ///
    /// # Errors
    /// When the thread cannot start.
    pub fn with_keys(
        input: impl TerminalInput,
        out: W,
        controller: Controller,
        answers: Option<AnswerSink>,
    ) -> io::Result<Self> {
        let shared = Arc::new(Mutex::new(Shared::default()));
        {
            let shared = Arc::clone(&shared);
            let controller = controller.clone();
            std::thread::Builder::new()
                .name("lewis-seq-terminal".into())
                .spawn(move || read_terminal(input, Some(&shared), &controller, answers))?;
        }
        Ok(Self {
            out,
            shared,
            controller,
        })
    }

    /// Where the questions were written.
    pub fn output(&self) -> &W {
        &self.out
    }

    fn ask(&mut self, choices: &[String], suggested: Option<&String>, reason: &str) {
        let input_closed = {
            let mut shared = self.shared.lock().unwrap_or_else(PoisonError::into_inner);
            shared.asking = true;
            shared.suggested = suggested.cloned();
            shared.input_closed
        };
        let suggestion = suggested
            .map(|s| format!(" (the script suggests {s}: just Enter)"))
            .unwrap_or_default();
        let _ = write!(
            self.out,
            "\nThe sequencer needs the supervisor: {reason}.\n\
             Type the state to resume from ({}) or `stop`{suggestion}, then Enter:\n> ",
            choices.join(", ")
        );
        let _ = self.out.flush();
        if input_closed {
            self.controller
                .interrupt("no terminal input left to ask the supervisor on");
        }
    }
}

/// The keys alone on the terminal, for the registrar's answers (the page asks the
/// questions): `y` and `n` go to `answers` until the input ends.
pub struct TerminalKeys;

impl TerminalKeys {
    /// Reads `input` key by key on a thread of its own (left running until the input ends).
    ///
    /// # Errors
    /// When the thread cannot start.
    pub fn start(
        input: impl TerminalInput,
        controller: Controller,
        answers: AnswerSink,
    ) -> io::Result<()> {
        std::thread::Builder::new()
            .name("lewis-seq-keys".into())
            .spawn(move || read_terminal(input, None, &controller, Some(answers)))?;
        Ok(())
    }
}

/// Reads the supervisor: lines (choices) while the sequencer asks, or always without
/// `answers`; keys for `answers` otherwise. Without `shared` (no chooser), keys only.
fn read_terminal(
    mut input: impl TerminalInput,
    shared: Option<&Mutex<Shared>>,
    controller: &Controller,
    mut answers: Option<AnswerSink>,
) {
    let asking =
        |shared: &Mutex<Shared>| shared.lock().unwrap_or_else(PoisonError::into_inner).asking;
    let keys = answers.is_some();
    let mut line = Vec::new();
    loop {
        // Lines while asking or while a line is begun; keys otherwise, decided when the byte
        // comes (a key pressed as the question came is the first letter of the answer).
        let started = !line.is_empty();
        let lines = || shared.is_some_and(|s| !keys || started || asking(s));
        let byte = match input.next_byte(&lines) {
            Ok(Some(byte)) => byte,
            Ok(None) => break,
            Err(e) => {
                tracing::debug!("the supervisor's terminal cannot be read: {e}");
                break;
            }
        };
        let Some(shared) = shared.filter(|_| lines()) else {
            if let (Some(answer), Some(send)) = (answer_of_key(byte), answers.as_mut()) {
                send(answer);
            }
            continue;
        };
        if byte != b'\n' {
            line.push(byte);
            continue;
        }
        let text = String::from_utf8_lossy(&line).trim().to_owned();
        line.clear();
        let answer = if text.is_empty() {
            let shared = shared.lock().unwrap_or_else(PoisonError::into_inner);
            match (&shared.suggested, shared.asking) {
                (Some(suggested), true) => suggested.clone(),
                _ => continue,
            }
        } else {
            text
        };
        if !controller.choose(answer) {
            return;
        }
    }
    let Some(shared) = shared else { return };
    let asking = {
        let mut shared = shared.lock().unwrap_or_else(PoisonError::into_inner);
        shared.input_closed = true;
        shared.asking
    };
    if asking {
        controller.interrupt("the terminal input ended while the supervisor was asked");
    }
}

impl<W: Write> RecordSink for TerminalChooser<W> {
    fn record(&mut self, record: &Record) {
        match &record.entry {
            Entry::Decided {
                decision:
                    Decision::AskSupervisor {
                        choices,
                        suggested,
                        reason,
                    },
            } => self.ask(choices, suggested.as_ref(), reason),
            Entry::Decided { .. } => {
                let mut shared = self.shared.lock().unwrap_or_else(PoisonError::into_inner);
                shared.asking = false;
                shared.suggested = None;
            }
            Entry::Refused {
                event: Event::SupervisorChose { .. },
                error,
            } => {
                let _ = write!(self.out, "{error}\n> ");
                let _ = self.out.flush();
            }
            _ => {}
        }
    }
}
