//! The supervisor's choice on the terminal, for `--no-gui`: the question is printed when the
//! FSM asks, and each line read (a state's name, or `stop`) is sent as the choice.

use std::io::{self, BufRead, Write};
use std::sync::{Arc, Mutex, PoisonError};

use crate::fsm::{Decision, Event};
use crate::live::Controller;
use crate::record::{Entry, Record, RecordSink};

#[derive(Default)]
struct Shared {
    asking: bool,
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
        let shared = Arc::new(Mutex::new(Shared::default()));
        {
            let shared = Arc::clone(&shared);
            let controller = controller.clone();
            std::thread::Builder::new()
                .name("lewis-seq-terminal".into())
                .spawn(move || read_answers(input, &shared, &controller))?;
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
            shared.input_closed
        };
        let suggestion = suggested
            .map(|s| format!(" (the script suggests {s})"))
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

fn read_answers(input: impl BufRead, shared: &Mutex<Shared>, controller: &Controller) {
    for line in input.lines() {
        let Ok(line) = line else { break };
        let answer = line.trim();
        if answer.is_empty() {
            continue;
        }
        if !controller.choose(answer) {
            return;
        }
    }
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
                self.shared
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .asking = false;
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
