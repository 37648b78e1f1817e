//! The supervisor's choice on the terminal (without `use gui`, or with `--no-gui`, when the
//! standard input is a terminal): the question is printed when the FSM asks, and each line
//! read (a state's name, or `stop`) is sent as the choice; an empty line takes the script's
//! suggestion (the recovery state's listed target), when there is one.

use std::io::{self, BufRead, Write};
use std::sync::{Arc, Mutex, PoisonError};

use crate::fsm::{Decision, Event};
use crate::live::Controller;
use crate::record::{Entry, Record, RecordSink};

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

fn read_answers(input: impl BufRead, shared: &Mutex<Shared>, controller: &Controller) {
    for line in input.lines() {
        let Ok(line) = line else { break };
        let answer = match line.trim() {
            "" => {
                let shared = shared.lock().unwrap_or_else(PoisonError::into_inner);
                match (&shared.suggested, shared.asking) {
                    (Some(suggested), true) => suggested.clone(),
                    _ => continue,
                }
            }
            answer => answer.to_owned(),
        };
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
