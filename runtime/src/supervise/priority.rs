//! The robot ahead of other work on its machine: `lewis up` runs its broker, recorder,
//! services and programs at the nice value of the robot file (`[broker] nice`), so that a
//! compiler or a replay beside it does not delay their heartbeats past a short deadline.
//!
//! Every thread of this process gets the value (Linux keeps one per thread), and every
//! thread and process started later inherits it from its parent.
//!
//! Where the kernel groups processes by session (`kernel.sched_autogroup_enabled`, on in
//! most desktop and many server kernels), a nice value only orders the processes of one
//! session: the CPU is first shared evenly between sessions, so a compiler started from
//! another terminal gets as much as the whole robot whatever its processes' nice values.
//! The robot's session group gets the same nice value then (`/proc/self/autogroup`), for
//! as long as the robot runs: the session may be a person's terminal, which gets its own
//! value back at the end ([`PrioritySet::restore`]).

use rustix::process::{Pid, setpriority_process};

/// Why the robot could not be given its priority.
#[derive(Debug, thiserror::Error)]
pub enum PriorityError {
    /// Raising a priority (a negative nice value) needs `CAP_SYS_NICE` or a high enough
    /// `RLIMIT_NICE`.
    #[error(
        "not allowed to raise the robot's priority to nice {nice}: give lewis CAP_SYS_NICE \
         (`setcap cap_sys_nice+ep`), raise its RLIMIT_NICE (`ulimit -e`, systemd's LimitNICE=), \
         or run it as root"
    )]
    NotAllowed {
        /// The nice value asked for.
        nice: i32,
    },
    /// A real-time priority needs `CAP_SYS_NICE` or a high enough `RLIMIT_RTPRIO`.
    #[error(
        "not allowed to run heartbeats at real-time priority (SCHED_FIFO {priority}): give lewis \
         CAP_SYS_NICE (`setcap cap_sys_nice+ep`), raise its RLIMIT_RTPRIO (`ulimit -r`, \
         systemd's LimitRTPRIO=), or run it as root"
    )]
    RealtimeNotAllowed {
        /// The priority asked for.
        priority: u8,
    },
    /// The system refused a real-time priority for another reason (a container's
    /// real-time budget of zero, for one).
    #[error("cannot run heartbeats at real-time priority (SCHED_FIFO {priority}): {source}")]
    RealtimeSystem {
        /// The priority asked for.
        priority: u8,
        /// What the system said.
        source: std::io::Error,
    },
    /// The threads of this process could not be listed, or the system refused otherwise.
    #[error("cannot set the robot's priority to nice {nice}: {source}")]
    System {
        /// The nice value asked for.
        nice: i32,
        /// What the system said.
        source: std::io::Error,
    },
}

/// What [`set_nice`] set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrioritySet {
    /// The session group's nice value before, when it got the new one too (the kernel
    /// groups by session).
    pub session_group_before: Option<i32>,
}

impl PrioritySet {
    /// Gives the session's group its nice value back (the threads keep theirs: this
    /// process is ending).
    pub fn restore(&self) {
        if let Some(before) = self.session_group_before {
            // Best effort: a session whose value cannot be set back keeps the robot's.
            let _ = std::fs::write(AUTOGROUP, before.to_string());
        }
    }
}

/// This process's session group and its nice value: `/autogroup-42 nice 0`.
const AUTOGROUP: &str = "/proc/self/autogroup";

/// Sets the nice value of every thread of this process to `nice` (-20, first, to 19,
/// last), and of its session's group where the kernel groups by session; what they start
/// afterwards inherits it.
///
/// # Errors
/// [`PriorityError::NotAllowed`] when the process may not raise its priority that far.
pub fn set_nice(nice: i32) -> Result<PrioritySet, PriorityError> {
    set_threads_nice(nice)?;
    let session_group_before = set_session_group_nice(nice)?;
    Ok(PrioritySet {
        session_group_before,
    })
}

/// The session group's nice value, where the kernel groups processes by session; its value
/// before, when it did.
fn set_session_group_nice(nice: i32) -> Result<Option<i32>, PriorityError> {
    let enabled = std::fs::read_to_string("/proc/sys/kernel/sched_autogroup_enabled")
        .is_ok_and(|v| v.trim() == "1");
    // No group to set (off, or a kernel built without it): the threads' value is all.
    let Some(before) = enabled
        .then(|| std::fs::read_to_string(AUTOGROUP).ok())
        .flatten()
        .and_then(|text| autogroup_nice(&text))
    else {
        return Ok(None);
    };
    match std::fs::write(AUTOGROUP, nice.to_string()) {
        Ok(()) => Ok(Some(before)),
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            Err(PriorityError::NotAllowed { nice })
        }
        Err(source) => Err(PriorityError::System { nice, source }),
    }
}

/// Runs the calling thread under `SCHED_FIFO` at `priority` (1, lowest, to 99): it runs
/// whenever it is runnable, ahead of every thread of the normal scheduler. For threads that
/// wake briefly and often (heartbeats); what they start gets the normal scheduler back
/// (`SCHED_RESET_ON_FORK`).
///
/// # Errors
/// [`PriorityError::RealtimeNotAllowed`] when the process may not.
pub fn set_thread_realtime(priority: u8) -> Result<(), PriorityError> {
    use nix::libc;
    let param = libc::sched_param {
        sched_priority: i32::from(priority),
    };
    // SAFETY: `param` is a valid sched_param for the call; pid 0 is the calling thread.
    let set = unsafe {
        libc::sched_setscheduler(
            0,
            libc::SCHED_FIFO | libc::SCHED_RESET_ON_FORK,
            &raw const param,
        )
    };
    if set == 0 {
        return Ok(());
    }
    let source = std::io::Error::last_os_error();
    Err(match source.raw_os_error() {
        Some(libc::EPERM) => PriorityError::RealtimeNotAllowed { priority },
        _ => PriorityError::RealtimeSystem { priority, source },
    })
}

/// Whether this process's threads may run at real-time `priority`: tried on a thread made
/// for the question, so the caller's own scheduling stays as it is.
///
/// # Errors
/// Why not, as [`set_thread_realtime`] says.
pub fn realtime_allowed(priority: u8) -> Result<(), PriorityError> {
    std::thread::scope(|scope| scope.spawn(|| set_thread_realtime(priority)).join()).unwrap_or_else(
        |_| {
            Err(PriorityError::RealtimeSystem {
                priority,
                source: std::io::Error::other("the thread that tried it panicked"),
            })
        },
    )
}

/// The nice value in `/proc/self/autogroup`'s text.
fn autogroup_nice(text: &str) -> Option<i32> {
    text.split_whitespace().last()?.parse().ok()
}

fn set_threads_nice(nice: i32) -> Result<(), PriorityError> {
    let system = |source: std::io::Error| PriorityError::System { nice, source };
    let tasks = std::fs::read_dir("/proc/self/task").map_err(system)?;
    for task in tasks {
        let task = task.map_err(system)?;
        // A thread that ended since the listing has nothing left to set.
        let Some(tid) = task
            .file_name()
            .to_str()
            .and_then(|name| name.parse::<i32>().ok())
            .and_then(Pid::from_raw)
        else {
            continue;
        };
        match setpriority_process(Some(tid), nice) {
            Ok(()) | Err(rustix::io::Errno::SRCH) => {}
            Err(rustix::io::Errno::ACCESS | rustix::io::Errno::PERM) => {
                return Err(PriorityError::NotAllowed { nice });
            }
            Err(e) => return Err(system(e.into())),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_real_time_priority_is_set_where_allowed_and_refused_by_name_elsewhere() {
        match realtime_allowed(1) {
            Ok(()) => {
                let policy = std::thread::scope(|scope| {
                    scope
                        .spawn(|| {
                            set_thread_realtime(1).unwrap();
                            // SAFETY: pid 0 is the calling thread.
                            unsafe { nix::libc::sched_getscheduler(0) }
                        })
                        .join()
                        .unwrap()
                });
                assert_eq!(
                    policy & !nix::libc::SCHED_RESET_ON_FORK,
                    nix::libc::SCHED_FIFO
                );
            }
            Err(e) => assert!(
                e.to_string()
                    .contains("heartbeats at real-time priority (SCHED_FIFO 1)"),
                "{e}"
            ),
        }
    }

    #[test]
    fn the_session_groups_nice_value_is_read_from_its_line() {
        assert_eq!(autogroup_nice("/autogroup-449 nice 0\n"), Some(0));
        assert_eq!(autogroup_nice("/autogroup-7 nice -10"), Some(-10));
        assert_eq!(autogroup_nice(""), None);
        assert_eq!(autogroup_nice("/autogroup-7 nice x"), None);
    }
}
