//! What the robot file asks of each machine the robot runs on (`[broker] nice`,
//! `heartbeat_priority`, `keep_cores_awake`): every host's `lewis up` does it first, before
//! it starts anything, says what it got, and undoes it when it ends. Where the machine does
//! not allow one, the robot runs without it and the reason is said once.

use super::awake::{CPU_LATENCY_DEVICE, CoresAwake, keep_cores_awake};
use super::priority::{PrioritySet, realtime_allowed, set_nice};
use lewis_robot::Robot;

/// The robot's settings on this machine, for as long as this lives.
#[derive(Debug)]
pub struct MachineSettings {
    priority: Option<PrioritySet>,
    _awake: Option<CoresAwake>,
}

impl MachineSettings {
    /// Applies the robot file's settings to this process (and so to every thread and
    /// process it starts later) and this machine.
    #[must_use]
    pub fn apply(robot: &Robot) -> Self {
        let priority = robot.broker.nice.and_then(|nice| match set_nice(nice) {
            Ok(set) => {
                tracing::info!(
                    "the robot runs at nice {nice}{}, ahead of other work",
                    if set.session_group_before.is_some() {
                        " (its session's group too)"
                    } else {
                        ""
                    }
                );
                Some(set)
            }
            Err(e) => {
                tracing::warn!(
                    "{e}; the robot runs at the priority it was started with, and a loaded \
                     machine may delay its heartbeats"
                );
                None
            }
        });
        // Each service's heartbeat thread asks for it itself; said here once for all.
        match robot.broker.heartbeat_priority {
            0 => {}
            priority => match realtime_allowed(priority) {
                Ok(()) => tracing::info!(
                    "heartbeats run at real-time priority (SCHED_FIFO {priority}), ahead of \
                     any load"
                ),
                Err(e) => tracing::warn!(
                    "{e}; heartbeats run at normal priority, and a loaded machine may delay \
                     them"
                ),
            },
        }
        let awake = robot
            .broker
            .keep_cores_awake
            .then(|| match keep_cores_awake() {
                Ok(held) => {
                    tracing::info!(
                        "the cores are kept awake while the robot runs ({CPU_LATENCY_DEVICE} \
                         held at 0)"
                    );
                    Some(held)
                }
                Err(e) => {
                    tracing::warn!(
                        "{e}; the cores sleep as the machine has them, and a wake-up across \
                         cores may take tens of microseconds"
                    );
                    None
                }
            })
            .flatten();
        Self {
            priority,
            _awake: awake,
        }
    }
}

impl Drop for MachineSettings {
    /// Gives the session's group its nice value back (the session may be a person's
    /// terminal) and lets the cores sleep again.
    fn drop(&mut self) {
        if let Some(priority) = &self.priority {
            priority.restore();
        }
    }
}
