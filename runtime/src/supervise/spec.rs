//! What to run: a program, its arguments, environment and working directory, and what to do
//! when it exits.

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

use lewis_robot::RestartPolicy;

/// How long a child has between SIGTERM and SIGKILL unless its spec says otherwise.
pub const DEFAULT_STOP_GRACE: Duration = Duration::from_secs(2);

/// Whether the supervisor restarts a child by itself when it exits.
///
/// The broker decides most restarts in its own decision core (with the same
/// [`RestartTracker`](super::RestartTracker)), so the default is [`Restart::Never`]: the exit
/// is reported and the caller decides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Restart {
    /// Report the exit and do nothing else.
    #[default]
    Never,
    /// Restart after a failure (a non-zero exit code or a signal) within the policy.
    OnFailure(RestartPolicy),
    /// Restart after any exit, a clean one included, within the policy.
    Always(RestartPolicy),
}

/// A child process to supervise: what to execute (directly, never through a shell) and how.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChildSpec {
    /// The child's name, unique within a supervisor; it tags events and log lines.
    pub name: String,
    /// The program: a path, or a bare name looked up in `PATH`.
    pub program: PathBuf,
    /// The arguments after the program name.
    pub args: Vec<OsString>,
    /// Variables set in the child's environment, in this order.
    pub env: Vec<(OsString, OsString)>,
    /// Start from an empty environment instead of the supervisor's own.
    pub env_clear: bool,
    /// The working directory; the supervisor's own when `None`.
    pub cwd: Option<PathBuf>,
    /// Whether the supervisor restarts the child by itself.
    pub restart: Restart,
    /// Time between SIGTERM and SIGKILL when the child is stopped.
    pub stop_grace: Duration,
}

impl ChildSpec {
    /// A spec that runs `program` with no arguments, the inherited environment, no automatic
    /// restart and the default stop grace.
    #[must_use]
    pub fn new(name: impl Into<String>, program: impl Into<PathBuf>) -> Self {
        Self {
            name: name.into(),
            program: program.into(),
            args: Vec::new(),
            env: Vec::new(),
            env_clear: false,
            cwd: None,
            restart: Restart::Never,
            stop_grace: DEFAULT_STOP_GRACE,
        }
    }

    /// Appends one argument.
    #[must_use]
    pub fn arg(mut self, arg: impl Into<OsString>) -> Self {
        self.args.push(arg.into());
        self
    }

    /// Appends several arguments.
    #[must_use]
    pub fn args<I, S>(mut self, args: I) -> Self
    where
        I: IntoIterator<Item = S>,
        S: Into<OsString>,
    {
        self.args.extend(args.into_iter().map(Into::into));
        self
    }

    /// Sets one environment variable in the child.
    #[must_use]
    pub fn env(mut self, key: impl Into<OsString>, value: impl Into<OsString>) -> Self {
        self.env.push((key.into(), value.into()));
        self
    }

    /// Starts the child from an empty environment (plus the variables set with [`Self::env`]).
    #[must_use]
    pub fn env_clear(mut self) -> Self {
        self.env_clear = true;
        self
    }

    /// Sets the working directory.
    #[must_use]
    pub fn cwd(mut self, cwd: impl Into<PathBuf>) -> Self {
        self.cwd = Some(cwd.into());
        self
    }

    /// Sets the automatic restart behaviour.
    #[must_use]
    pub fn restart(mut self, restart: Restart) -> Self {
        self.restart = restart;
        self
    }

    /// Sets the time between SIGTERM and SIGKILL.
    #[must_use]
    pub fn stop_grace(mut self, grace: Duration) -> Self {
        self.stop_grace = grace;
        self
    }
}
