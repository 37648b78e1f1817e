//! Errors of process supervision, one enum per operation whose callers react differently.

use std::io;
use std::path::PathBuf;
use std::sync::Arc;

/// A child could not be started. Never retried by the supervisor.
#[derive(Debug, Clone, thiserror::Error)]
pub enum StartError {
    /// The program does not exist (or a bare name is not in `PATH`).
    #[error("cannot start `{name}`: program `{}` not found; check the path or PATH", program.display())]
    ProgramNotFound {
        /// The child's name.
        name: String,
        /// The program as given.
        program: PathBuf,
    },
    /// The program exists but may not be executed.
    #[error("cannot start `{name}`: program `{}` is not executable; check its permissions", program.display())]
    NotExecutable {
        /// The child's name.
        name: String,
        /// The program as given.
        program: PathBuf,
    },
    /// The working directory does not exist.
    #[error("cannot start `{name}`: working directory `{}` not found", cwd.display())]
    WorkingDirNotFound {
        /// The child's name.
        name: String,
        /// The working directory as given.
        cwd: PathBuf,
    },
    /// A child with this name is running already.
    #[error("cannot start `{name}`: it is running already (pid {pid}); stop it first")]
    AlreadyRunning {
        /// The child's name.
        name: String,
        /// The running process's id.
        pid: u32,
    },
    /// Any other failure of the operating system to start the program.
    #[error("cannot start `{name}` (program `{}`): {source}", program.display())]
    Spawn {
        /// The child's name.
        name: String,
        /// The program as given.
        program: PathBuf,
        /// What the operating system said.
        #[source]
        source: Arc<io::Error>,
    },
    /// The supervisor's own resources (its spawner thread, its epoll set) failed.
    #[error("cannot start `{name}`: the supervisor failed: {source}")]
    Supervisor {
        /// The child's name.
        name: String,
        /// What the operating system said.
        #[source]
        source: Arc<io::Error>,
    },
}

/// A child could not be stopped or signalled.
#[derive(Debug, thiserror::Error)]
pub enum StopError {
    /// No child of this name was ever started.
    #[error("no supervised child named `{name}`")]
    UnknownChild {
        /// The name asked for.
        name: String,
    },
    /// The child is not running (it exited, was stopped or waits for a restart).
    #[error("`{name}` is not running")]
    NotRunning {
        /// The child's name.
        name: String,
    },
    /// The child did not die even after SIGKILL (it is stuck in the kernel); it is still
    /// supervised and its exit will be reported as an event.
    #[error("`{name}` (pid {pid}) is still alive after SIGKILL; it is stuck in the kernel")]
    StillAlive {
        /// The child's name.
        name: String,
        /// Its process id.
        pid: u32,
    },
    /// A system call failed while stopping or signalling.
    #[error("cannot stop or signal `{name}`: {source}")]
    Os {
        /// The child's name.
        name: String,
        /// What the operating system said.
        #[source]
        source: io::Error,
    },
}

/// The supervisor could not be created or could not wait for events.
#[derive(Debug, thiserror::Error)]
pub enum SuperviseError {
    /// Creating the spawner thread, the epoll set or the restart timer failed.
    #[error("cannot set up process supervision: {0}")]
    Setup(#[source] io::Error),
    /// Waiting on the epoll set failed.
    #[error("cannot wait for supervised processes: {0}")]
    Wait(#[source] io::Error),
}
