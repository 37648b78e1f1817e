//! What the supervisor reports: how a child ended, what happened next, and its output lines.

use std::fmt;
use std::os::unix::process::ExitStatusExt;
use std::sync::Arc;

use lewis_interfaces::msg::LogLineStream;

use super::error::StartError;

/// How a child process ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitStatus {
    /// It called `exit` with this code.
    Exited {
        /// The exit code (0 to 255).
        code: i32,
    },
    /// A signal ended it.
    Signalled {
        /// The signal number (`SIGKILL` is 9).
        signal: i32,
        /// Whether the kernel wrote a core dump.
        core_dumped: bool,
    },
}

impl ExitStatus {
    /// Whether this is a clean exit (code 0).
    #[must_use]
    pub fn success(self) -> bool {
        self == Self::Exited { code: 0 }
    }

    pub(crate) fn from_std(status: std::process::ExitStatus) -> Self {
        match (status.code(), status.signal()) {
            (Some(code), _) => Self::Exited { code },
            (None, Some(signal)) => Self::Signalled {
                signal,
                core_dumped: status.core_dumped(),
            },
            // `wait` without WUNTRACED only reports exits and deaths by signal; keep the raw
            // status rather than panic should that ever change.
            (None, None) => Self::Exited {
                code: status.into_raw(),
            },
        }
    }
}

impl fmt::Display for ExitStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Exited { code } => write!(f, "exited with code {code}"),
            Self::Signalled {
                signal,
                core_dumped,
            } => {
                match nix::sys::signal::Signal::try_from(signal) {
                    Ok(named) => write!(f, "killed by {}", named.as_str())?,
                    Err(_) => write!(f, "killed by signal {signal}")?,
                }
                if core_dumped {
                    f.write_str(" (core dumped)")?;
                }
                Ok(())
            }
        }
    }
}

/// Something that happened to a supervised child, in the order it happened.
#[derive(Debug)]
pub enum SupervisorEvent {
    /// The child ended by itself or was killed by someone else (not by [`stop`]).
    ///
    /// [`stop`]: super::Supervisor::stop
    Exited {
        /// The child's name.
        name: String,
        /// The process id it had.
        pid: u32,
        /// How it ended.
        status: ExitStatus,
    },
    /// The child will be restarted after a backoff (its spec asks for automatic restarts).
    RestartScheduled {
        /// The child's name.
        name: String,
        /// Which restart this is within the policy's window, counting from 1.
        attempt: u32,
        /// The backoff before the restart, in milliseconds.
        delay_ms: u64,
    },
    /// The child was started again after a backoff.
    Restarted {
        /// The child's name.
        name: String,
        /// The new process id.
        pid: u32,
        /// Which restart this is within the policy's window, counting from 1.
        attempt: u32,
    },
    /// The child failed more often than its restart policy allows: it stays down.
    GaveUp {
        /// The child's name.
        name: String,
        /// Failures within the policy's window, the last one included.
        failures: u32,
    },
    /// An automatic restart could not start the program; it is not retried.
    RestartFailed {
        /// The child's name.
        name: String,
        /// Why the program could not start.
        error: StartError,
    },
}

impl SupervisorEvent {
    /// The name of the child this event is about.
    #[must_use]
    pub fn name(&self) -> &str {
        match self {
            Self::Exited { name, .. }
            | Self::RestartScheduled { name, .. }
            | Self::Restarted { name, .. }
            | Self::GaveUp { name, .. }
            | Self::RestartFailed { name, .. } => name,
        }
    }
}

/// Which output stream of a child a line came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stream {
    /// Standard output.
    Stdout,
    /// Standard error.
    Stderr,
}

impl Stream {
    /// `"stdout"` or `"stderr"`: its word in a `LogLine`.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        LogLineStream::from(self).as_str()
    }
}

impl From<Stream> for LogLineStream {
    fn from(stream: Stream) -> Self {
        match stream {
            Stream::Stdout => Self::Stdout,
            Stream::Stderr => Self::Stderr,
        }
    }
}

impl fmt::Display for Stream {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One line a child wrote, tagged with the child's name and the stream.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LogLine {
    /// The child's name.
    pub name: Arc<str>,
    /// The process id of the child that wrote it.
    pub pid: u32,
    /// The stream it was written to.
    pub stream: Stream,
    /// The line without its line ending; invalid UTF-8 is replaced by U+FFFD.
    pub text: String,
    /// The line was longer than [`MAX_LINE_BYTES`](super::MAX_LINE_BYTES) and continues in
    /// the next `LogLine` of the same stream.
    pub continues: bool,
}
