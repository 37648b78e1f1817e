//! Commands to a running mission from other threads (the GUI, the terminal, a signal
//! handler, a test): a channel plus an eventfd, so the driver sleeps in one `poll` on its
//! children and its commands together.

use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::Arc;
use std::sync::mpsc::{self, Receiver, Sender, TryRecvError};

use rustix::event::{EventfdFlags, eventfd};

/// What another thread asks of the mission.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// The supervisor chose where to resume (`stop` ends the mission).
    Choose(String),
    /// The supervisor stops the mission (aborts it while a program runs).
    Stop,
    /// The sequencer must stop now (a signal, a closed terminal): the mission aborts.
    Interrupt(String),
}

/// The sending side, cheap to clone and to move to other threads.
#[derive(Debug, Clone)]
pub struct Controller {
    commands: Sender<Command>,
    wake: Arc<OwnedFd>,
}

impl Controller {
    /// Hands the supervisor's choice of `state` (or `stop`) to the mission. Returns `false`
    /// when the mission is over. A choice while nothing is asked is refused, and recorded.
    pub fn choose(&self, state: impl Into<String>) -> bool {
        self.send(Command::Choose(state.into()))
    }

    /// Stops the mission as the supervisor: aborts it while a program runs, finishes it
    /// while the supervisor is asked. Returns `false` when the mission is over.
    pub fn stop(&self) -> bool {
        self.send(Command::Stop)
    }

    /// Aborts the mission, stopping the running program: what Ctrl-C does. Returns `false`
    /// when the mission is over.
    pub fn interrupt(&self, reason: impl Into<String>) -> bool {
        self.send(Command::Interrupt(reason.into()))
    }

    /// Sends `command` and wakes the driver.
    pub fn send(&self, command: Command) -> bool {
        if self.commands.send(command).is_err() {
            return false;
        }
        // A full counter (2^64 - 2 wake-ups unread) still wakes the driver.
        let _ = rustix::io::write(&self.wake, &1_u64.to_ne_bytes());
        true
    }
}

/// The receiving side, owned by the driver.
#[derive(Debug)]
pub struct ControlReceiver {
    commands: Receiver<Command>,
    wake: Arc<OwnedFd>,
}

impl ControlReceiver {
    /// Every command sent so far, oldest first; clears the wake-up.
    pub fn drain(&self) -> Vec<Command> {
        let mut counter = [0_u8; 8];
        // Non-blocking: nothing to read just means no wake-up is pending.
        let _ = rustix::io::read(&*self.wake, &mut counter);
        let mut commands = Vec::new();
        loop {
            match self.commands.try_recv() {
                Ok(command) => commands.push(command),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return commands,
            }
        }
    }
}

impl AsFd for ControlReceiver {
    /// Readable when a command is waiting.
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.wake.as_fd()
    }
}

/// A connected controller and receiver.
///
/// # Errors
/// When the kernel gives no eventfd.
pub fn control_channel() -> io::Result<(Controller, ControlReceiver)> {
    let wake = Arc::new(eventfd(0, EventfdFlags::CLOEXEC | EventfdFlags::NONBLOCK)?);
    let (commands, incoming) = mpsc::channel();
    Ok((
        Controller {
            commands,
            wake: Arc::clone(&wake),
        },
        ControlReceiver {
            commands: incoming,
            wake,
        },
    ))
}
