//! The robot ahead of other work on its machine: `lewis up` runs its broker, recorder,
//! services and programs at the nice value of the robot file (`[broker] nice`), so that a
//! compiler or a replay beside it does not delay their heartbeats past a short deadline.
//!
//! Every thread of this process gets the value (Linux keeps one per thread), and every
//! thread and process started later inherits it from its parent.

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
    /// The threads of this process could not be listed, or the system refused otherwise.
    #[error("cannot set the robot's priority to nice {nice}: {source}")]
    System {
        /// The nice value asked for.
        nice: i32,
        /// What the system said.
        source: std::io::Error,
    },
}

/// Sets the nice value of every thread of this process to `nice` (-20, first, to 19,
/// last); what they start afterwards inherits it.
///
/// # Errors
/// [`PriorityError::NotAllowed`] when the process may not raise its priority that far.
pub fn set_nice(nice: i32) -> Result<(), PriorityError> {
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
