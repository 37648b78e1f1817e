//! One child process: started without a shell in its own process group, tied to the
//! supervisor's life by `PR_SET_PDEATHSIG`, watched through a pidfd, stopped with SIGTERM then
//! SIGKILL to the whole group.
//!
//! `PR_SET_PDEATHSIG` fires when the *thread* that forked the child exits, not the process.
//! A child forked from a short-lived caller thread would be killed as soon as that thread
//! ends, so every fork happens on one spawner thread that lives exactly as long as the
//! [`Spawner`] (and so as long as the supervisor that owns it).

use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::os::unix::process::CommandExt;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, mpsc};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use nix::sys::signal::{self, Signal};
use nix::unistd::Pid;
use rustix::event::{PollFd, PollFlags};
use rustix::process::{PidfdFlags, pidfd_open};

use super::error::StartError;
use super::event::ExitStatus;
use super::guard::Guard;
use super::spec::ChildSpec;

/// How long to wait for a process to die after SIGKILL before calling it stuck.
const KILL_WAIT: Duration = Duration::from_secs(10);

struct SpawnRequest {
    command: Command,
    reply: mpsc::SyncSender<io::Result<(Child, OwnedFd)>>,
}

/// The long-lived thread every child is forked from (see the module documentation).
pub(crate) struct Spawner {
    requests: Option<mpsc::Sender<SpawnRequest>>,
    thread: Option<JoinHandle<()>>,
}

impl Spawner {
    pub(crate) fn new() -> io::Result<Self> {
        let (requests, incoming) = mpsc::channel::<SpawnRequest>();
        let thread = thread::Builder::new()
            .name("lewis-spawner".to_owned())
            .spawn(move || {
                for SpawnRequest { mut command, reply } in incoming {
                    let spawned = command.spawn().and_then(|mut child| {
                        // Open the pidfd before anyone can reap the child, so the pid cannot
                        // have been reused: the child is ours and unreaped until we wait.
                        let pid = rustix::process::Pid::from_child(&child);
                        match pidfd_open(pid, PidfdFlags::empty()) {
                            Ok(pidfd) => Ok((child, pidfd)),
                            Err(e) => {
                                // Unwatchable means unsupervised: it must not run.
                                let _ = child.kill();
                                let _ = child.wait();
                                Err(e.into())
                            }
                        }
                    });
                    // The requester waits for the reply; if it is gone, the child is dropped
                    // here and, unreaped, dies with the spawner thread (PDEATHSIG).
                    let _ = reply.send(spawned);
                }
            })?;
        Ok(Self {
            requests: Some(requests),
            thread: Some(thread),
        })
    }

    fn spawn(&self, command: Command) -> io::Result<(Child, OwnedFd)> {
        let gone = || io::Error::other("the spawner thread has stopped");
        let (reply, response) = mpsc::sync_channel(1);
        self.requests
            .as_ref()
            .ok_or_else(gone)?
            .send(SpawnRequest { command, reply })
            .map_err(|_| gone())?;
        response.recv().map_err(|_| gone())?
    }
}

impl Drop for Spawner {
    fn drop(&mut self) {
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// A running (or exited but not yet reaped) child process.
#[derive(Debug)]
pub(crate) struct Process {
    child: Child,
    pidfd: OwnedFd,
    pid: u32,
    /// Kills the process's group if the supervisor's process dies before reaping it.
    guard: Arc<Guard>,
}

impl Process {
    /// Starts `spec` from the spawner thread, with stdin from /dev/null and stdout and stderr
    /// piped (taken with [`Self::take_output`]), its process group given to `guard`.
    pub(crate) fn start(
        spawner: &Spawner,
        guard: &Arc<Guard>,
        spec: &ChildSpec,
    ) -> Result<Self, StartError> {
        let mut command = Command::new(&spec.program);
        command
            .args(&spec.args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0);
        if spec.env_clear {
            command.env_clear();
        }
        // Children say as much as their parent was asked to; a spec may still override it.
        command.env(crate::logs::VERBOSITY_ENV, crate::logs::current().as_env());
        for (key, value) in &spec.env {
            command.env(key, value);
        }
        if let Some(cwd) = &spec.cwd {
            command.current_dir(cwd);
        }
        let parent_pid = std::process::id();
        // SAFETY: the closure runs in the forked child before exec, where only
        // async-signal-safe operations are allowed: it makes two raw system calls (prctl,
        // getppid), builds an io::Error from a raw errno (no allocation) and touches no lock.
        unsafe {
            command.pre_exec(move || {
                rustix::process::set_parent_process_death_signal(Some(
                    rustix::process::Signal::KILL,
                ))
                .map_err(|e| io::Error::from_raw_os_error(e.raw_os_error()))?;
                // The supervisor may have died between fork and prctl: then nobody would
                // ever kill this child, so it must not run.
                let ppid = rustix::process::getppid().map(|p| p.as_raw_nonzero().get());
                if ppid.and_then(|p| u32::try_from(p).ok()) != Some(parent_pid) {
                    return Err(io::Error::from_raw_os_error(nix::libc::ESRCH));
                }
                Ok(())
            });
        }
        let (child, pidfd) = spawner.spawn(command).map_err(|e| start_error(spec, e))?;
        let pid = child.id();
        guard.watch(pid);
        Ok(Self {
            child,
            pidfd,
            pid,
            guard: Arc::clone(guard),
        })
    }

    pub(crate) fn pid(&self) -> u32 {
        self.pid
    }

    /// The pidfd: readable once the process has exited.
    pub(crate) fn pidfd(&self) -> BorrowedFd<'_> {
        self.pidfd.as_fd()
    }

    /// The stdout and stderr pipes, once.
    pub(crate) fn take_output(
        &mut self,
    ) -> (
        Option<std::process::ChildStdout>,
        Option<std::process::ChildStderr>,
    ) {
        (self.child.stdout.take(), self.child.stderr.take())
    }

    /// Sends `signal` to the process itself (not its group).
    pub(crate) fn signal(&self, signal: Signal) -> io::Result<()> {
        let raw = rustix::process::Signal::from_named_raw(signal as i32)
            .ok_or_else(|| io::Error::from_raw_os_error(nix::libc::EINVAL))?;
        rustix::process::pidfd_send_signal(&self.pidfd, raw).map_err(io::Error::from)
    }

    /// Whether the process has exited, waiting at most `timeout` for it.
    pub(crate) fn wait_exit(&self, timeout: Duration) -> io::Result<bool> {
        let deadline = Instant::now() + timeout;
        loop {
            let remaining = deadline.saturating_duration_since(Instant::now());
            let timespec = timespec(remaining);
            let mut fds = [PollFd::new(&self.pidfd, PollFlags::IN)];
            match rustix::event::poll(&mut fds, Some(&timespec)) {
                Ok(ready) => return Ok(ready > 0),
                Err(rustix::io::Errno::INTR) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Kills what is left of the group and reaps the process. Only for a process whose pidfd
    /// is readable: it is a zombie, so its pid (the group's id) cannot have been reused.
    pub(crate) fn reap(mut self) -> io::Result<ExitStatus> {
        if let Err(e) = self.signal_group(Signal::SIGKILL) {
            tracing::warn!(
                pid = self.pid,
                "cannot kill what is left of the process group: {e}"
            );
        }
        // Before the wait: until then the zombie holds the group's id, so the guard can
        // never be left with an id that another process group has taken.
        self.guard.forget(self.pid);
        let status = self.child.wait()?;
        Ok(ExitStatus::from_std(status))
    }

    /// Sends `signal` to the whole process group (grandchildren included).
    fn signal_group(&self, signal: Signal) -> io::Result<()> {
        let pgid =
            i32::try_from(self.pid).map_err(|_| io::Error::from_raw_os_error(nix::libc::ESRCH))?;
        match signal::killpg(Pid::from_raw(pgid), signal) {
            // The group is empty but for the unreaped leader: nothing left to signal.
            Ok(()) | Err(nix::errno::Errno::ESRCH) => Ok(()),
            Err(e) => Err(e.into()),
        }
    }

    /// SIGTERM to the group, SIGKILL after `grace` if the process is still alive, then reaps
    /// it. On [`Stopped::StillAlive`] the process is handed back, still supervised.
    pub(crate) fn terminate(self, grace: Duration) -> io::Result<Stopped> {
        self.signal_group(Signal::SIGTERM)?;
        if !self.wait_exit(grace)? {
            self.signal_group(Signal::SIGKILL)?;
            if !self.wait_exit(KILL_WAIT)? {
                return Ok(Stopped::StillAlive(self));
            }
        }
        self.reap().map(Stopped::Exited)
    }

    /// SIGKILL to the group at once, then reaps the process (for the supervisor's drop).
    pub(crate) fn kill(self) -> io::Result<Stopped> {
        self.signal_group(Signal::SIGKILL)?;
        if !self.wait_exit(KILL_WAIT)? {
            return Ok(Stopped::StillAlive(self));
        }
        self.reap().map(Stopped::Exited)
    }
}

/// How [`Process::terminate`] ended.
#[derive(Debug)]
pub(crate) enum Stopped {
    /// The process is dead and reaped.
    Exited(ExitStatus),
    /// The process survived SIGKILL (stuck in the kernel).
    StillAlive(Process),
}

/// `duration` as a timespec for `poll` and `epoll_wait`, saturating instead of failing.
pub(crate) fn timespec(duration: Duration) -> rustix::time::Timespec {
    rustix::time::Timespec::try_from(duration).unwrap_or(rustix::time::Timespec {
        tv_sec: i64::MAX,
        tv_nsec: 0,
    })
}

fn start_error(spec: &ChildSpec, error: io::Error) -> StartError {
    let name = spec.name.clone();
    let program = spec.program.clone();
    match error.kind() {
        // chdir failing in the child is reported as ENOENT too: tell the two apart.
        io::ErrorKind::NotFound => match &spec.cwd {
            Some(cwd) if !cwd.is_dir() => StartError::WorkingDirNotFound {
                name,
                cwd: cwd.clone(),
            },
            _ => StartError::ProgramNotFound { name, program },
        },
        io::ErrorKind::PermissionDenied => StartError::NotExecutable { name, program },
        _ => StartError::Spawn {
            name,
            program,
            source: error.into(),
        },
    }
}
