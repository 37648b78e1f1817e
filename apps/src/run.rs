//! Running a program as the sequencer's child: one process, the live program harness.

use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::{ClockSource, LiveError, ProgramSpec, run_program};
use lewis_runtime::service::Service;

use crate::door::{self, DoorConfig, DoorNavigator};
use crate::queue::{self, QueueConfig, QueueStander};
use crate::recovery::{self, Recovery, RecoveryConfig};
use crate::register::{self, Register, RegisterConfig};
use crate::sign::{self, SignConfig, SignFollower};

/// A program and its settings.
#[derive(Debug, Clone, PartialEq)]
pub enum App {
    /// DoorNavigator.
    DoorNavigator(DoorConfig),
    /// SignFollower.
    SignFollower(SignConfig),
    /// QueueStander.
    QueueStander(QueueConfig),
    /// Register.
    Register(RegisterConfig),
    /// Recovery.
    Recovery(RecoveryConfig),
}

impl App {
    /// Its name on the command line (`lewis app NAME`).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::DoorNavigator(_) => "door-navigator",
            Self::SignFollower(_) => "sign-follower",
            Self::QueueStander(_) => "queue-stander",
            Self::Register(_) => "register",
            Self::Recovery(_) => "recovery",
        }
    }

    /// The interfaces it asks the broker for.
    #[must_use]
    pub fn requires(&self) -> &'static [&'static str] {
        match self {
            Self::DoorNavigator(_) => door::REQUIRES,
            Self::SignFollower(_) => sign::REQUIRES,
            Self::QueueStander(_) => queue::REQUIRES,
            Self::Register(_) => register::REQUIRES,
            Self::Recovery(_) => recovery::REQUIRES,
        }
    }

    /// The program itself.
    #[must_use]
    pub fn program(self) -> Box<dyn Service> {
        match self {
            Self::DoorNavigator(c) => Box::new(DoorNavigator::new(c)),
            Self::SignFollower(c) => Box::new(SignFollower::new(c)),
            Self::QueueStander(c) => Box::new(QueueStander::new(c)),
            Self::Register(c) => Box::new(Register::new(c)),
            Self::Recovery(c) => Box::new(Recovery::new(c)),
        }
    }
}

/// Runs `app` in this process until it finishes or is stopped; returns the exit code the
/// process must end with.
///
/// The node (and the broker's client) is named after the program and this process,
/// `door-navigator-4242`: a program the sequencer restarts after a crash is a new client,
/// and the broker drops the dead one's bindings when its process is gone.
///
/// # Errors
/// When IPC fails or the program does not start.
pub fn run(app: App, namespace: &Namespace, clock: ClockSource) -> Result<i32, LiveError> {
    let spec = ProgramSpec {
        name: format!("{}-{}", app.name(), std::process::id()),
        requires: app.requires().iter().map(|s| (*s).to_owned()).collect(),
        seed: 1,
    };
    let mut program = app.program();
    run_program(&spec, program.as_mut(), namespace, clock)
}
