//! Process supervision: spawn, watch, restart with intensity and backoff, stop in reverse order.
//!
//! One module for the broker's and the sequencer's live drivers (Linux only):
//!
//! - **Spawn** without a shell ([`ChildSpec`]: program, arguments, environment, working
//!   directory), each child in its own process group, with `PR_SET_PDEATHSIG(SIGKILL)` so no
//!   child outlives its supervisor's process, even one killed with SIGKILL. Every fork happens
//!   on one long-lived spawner thread, because the kernel sends the death signal when the
//!   *thread* that forked the child exits. A program that cannot start is a [`StartError`]
//!   naming it, never retried.
//! - **Watch** through one pidfd per child in an epoll set: [`Supervisor::wait_event`] blocks
//!   with a timeout, and [`Supervisor`] implements [`AsFd`](std::os::fd::AsFd) so an event
//!   loop (an iceoryx2 `WaitSet`, `poll`) can wait on it with other things and then call
//!   [`Supervisor::try_event`]. Exits come out as [`SupervisorEvent::Exited`] with the name,
//!   pid and [`ExitStatus`].
//! - **Output**: each child's stdout and stderr, line by line, to `tracing` (target
//!   `lewis::service`) and to an optional bounded channel of [`LogLine`]s; partial lines,
//!   invalid UTF-8 and lines over [`MAX_LINE_BYTES`] are handled.
//! - **Stop** one child ([`Supervisor::stop`]) or all in reverse start order
//!   ([`Supervisor::stop_all`]): SIGTERM to the process group, SIGKILL after the grace
//!   period, waiting on the pidfd, then SIGKILL to whatever is left of the group. A child
//!   that exits by itself also has what it left in its group killed (as systemd does), so a
//!   restart never races the leftovers of the previous run.
//! - **Restart**, when a child's spec asks for it ([`Restart`]), after the backoff that
//!   [`RestartTracker`] computes, or give up ([`SupervisorEvent::GaveUp`]). The default is
//!   [`Restart::Never`]: the broker decides restarts in its own decision core.
//!
//! - **Guard** the process groups: a grandchild does not inherit the death signal, so a
//!   small guard process forked with the supervisor kills every child's process group once
//!   the supervisor's process is gone, however it died (SIGKILL included); see `guard.rs`.
//!
//! Not covered: a grandchild that leaves its process group (`setsid`) escapes both the group
//! kill and the guard.

mod awake;
mod error;
mod event;
mod guard;
mod machine;
mod output;
mod policy;
mod priority;
mod process;
mod spec;
mod supervisor;

pub use awake::{
    AwakeError, CPU_LATENCY_DEVICE, CoresAwake, cpu_latency_target_us, keep_cores_awake,
};
pub use error::{StartError, StopError, SuperviseError};
pub use event::{ExitStatus, LogLine, Stream, SupervisorEvent};
pub use machine::MachineSettings;
pub use output::MAX_LINE_BYTES;
pub use policy::{RestartDecision, RestartTracker};
pub use priority::{PriorityError, PrioritySet, realtime_allowed, set_nice, set_thread_realtime};
pub use spec::{ChildSpec, DEFAULT_STOP_GRACE, Restart};
pub use supervisor::Supervisor;
