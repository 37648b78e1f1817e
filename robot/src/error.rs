//! Errors of the robot description, each placed at a line and column of the file.

use std::fmt;
use std::path::PathBuf;

use lewis_stdx::Diagnostic;

/// Why a robot description could not be used.
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    /// The file could not be read.
    #[error("cannot read robot file {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The text is not a valid robot description.
    #[error("{}", Problems(problems))]
    Invalid {
        /// The file (or the name given to the text).
        path: PathBuf,
        /// Every problem found, in the order of the file, each printed
        /// `robot.toml:3:7: message` (no `error:` label: the message says what to do).
        problems: Vec<Diagnostic>,
    },
}

struct Problems<'a>(&'a [Diagnostic]);

impl fmt::Display for Problems<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        lewis_stdx::diagnostic::write_list(f, self.0)
    }
}

pub(super) use lewis_stdx::line_column;
