//! The programs by name, each with its settings: what `lewis app NAME` starts. The live
//! harness that runs one as the sequencer's child is `lewis_launch::program`.

use lewis_service::Service;

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
