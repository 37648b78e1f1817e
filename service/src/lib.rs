//! The service model: a [`Service`] is a plain struct driven by events, and a [`Context`] is
//! all it may touch of the world.
//!
//! A service has no clock but [`Context::now`], starts no threads and does no IPC of its
//! own: it publishes with [`Context::publish`], calls other providers with [`Context::call`]
//! (asynchronous: the answer, or a timeout, comes back as [`Service::on_reply`]), declares
//! its health with [`Context::set_health`], draws random numbers from [`Context::rng`] (seeded
//! from the robot file) and logs with [`Context::log`]. That is what lets the same service
//! run live, one process each (`lewis_runtime::live`), and in a lockstep replay harness that feeds
//! it recorded events on a virtual clock: both harnesses implement [`Backend`].
//!
//! A source that must block on a device (a serial port, a camera) returns the device's file
//! descriptor from [`Service::device`]; the live harness waits on it with everything else
//! and calls [`Service::on_device`] when it is readable. That hook is the only part of a
//! service that never runs in replay.
//!
//! # Handlers must not block
//!
//! The live harness runs every handler on one thread and sends the service's heartbeats
//! from that same loop, between events: a heartbeat tells the broker that the service is
//! responsive, not merely that its process exists. So:
//!
//! - [`Service::on_start`] may block (open a port, probe a device's baud rate, load a
//!   model): the first heartbeat is sent when it returns, and until then the robot file's
//!   `startup_deadline_ms` applies;
//! - every other handler must return well within the `heartbeat_deadline_ms`: while one
//!   runs, no heartbeat goes out, and a handler that runs past the deadline is a stall (the
//!   broker kills the service and moves its clients). The harness logs a warning the first
//!   time a handler takes more than half its deadline;
//! - work that can block after the start (a device that goes silent, a reconnection that
//!   probes for seconds) belongs in a device reader: a thread of the service (the one kind
//!   of thread a service may own) that does the blocking reads and wakes the harness through
//!   a file descriptor returned by [`Service::device`] (a pipe or an eventfd it writes
//!   to); [`Service::on_device`] then takes what the reader produced without blocking.

mod context;
mod events;
pub mod fault;
mod health;
mod registry;
mod rng;
pub mod wire;

pub use context::{Backend, Context, ContextError, ContextState, Level};
pub use events::{
    CallFailure, CallId, CommandError, IncomingCommand, Input, InputError, Reply, ReplyEvent,
    decode_header_seq,
};
pub use health::Health;
pub use registry::{BuildError, Constructor, Role, ServiceConfig, ServiceRegistry};
pub use rng::{NoiseBytes, Rng};

use std::os::fd::BorrowedFd;

/// The variable in which `lewis up` names the recording to the robot's services when it
/// records (the file's path): a service that writes files of its own (espeak-speech's
/// audio) puts them beside it. Services never read or write the recording itself.
pub const RECORDING_ENV: &str = "LEWIS_RECORDING";

/// A service: what it does on each event. Every method has a default that does nothing, so a
/// service implements only what it needs.
pub trait Service {
    /// How often [`Service::on_tick`] runs, in nanoseconds (`None`: never).
    fn tick_period_ns(&self) -> Option<i64> {
        None
    }

    /// Runs once, before any other event. It may block (open and probe a device): the live
    /// harness sends the first heartbeat once it returns, so the startup deadline covers it
    /// (see the module documentation). An error ends the service (its process exits with a
    /// failure, which the broker sees as a crash).
    ///
    /// # Errors
    /// When the service cannot work (a device that cannot be opened, a parameter that makes
    /// no sense once combined with others).
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        let _ = ctx;
        Ok(())
    }

    /// A sample of a required interface arrived from its current provider.
    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let _ = (ctx, input);
    }

    /// A client sent a command of an interface this service provides. Decode it with
    /// [`IncomingCommand::decode`], answer with [`Context::reply`].
    ///
    /// # Errors
    /// A [`CommandError`] refuses the command; the caller gets its text.
    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        let _ = ctx;
        Err(CommandError::new(format!(
            "this service takes no command `{}` of {}",
            command.command, command.interface
        )))
    }

    /// The answer to a [`Context::call`] this service made, or its failure (timeout, no
    /// provider, refused).
    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        let _ = (ctx, reply);
    }

    /// The periodic event, every [`Service::tick_period_ns`].
    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }

    /// Runs once, last, when the service is asked to stop.
    fn on_stop(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }

    /// Whether this service has finished, and with which process exit code.
    ///
    /// Services never finish: they run until they are stopped, so the default is `None`.
    /// A sub-task program (a sequencer state's program, written against interfaces like a
    /// service) finishes itself: once it returns `Some(code)` after a handler, the harness
    /// runs [`Service::on_stop`] (which may still send a last command, a stop to the Mover)
    /// and ends, and the live process exits with `code`, the contract of the sequencer's
    /// script.
    fn exit_code(&self) -> Option<i32> {
        None
    }

    /// The file descriptor of the device this service reads, if any: the live harness waits
    /// on it and calls [`Service::on_device`] when it is readable. Never used in replay. It
    /// may be the device itself (read without blocking) or the wake-up descriptor of a device
    /// reader thread that does the blocking reads (see the module documentation).
    fn device(&self) -> Option<BorrowedFd<'_>> {
        None
    }

    /// The device is readable: read it (without blocking) and publish what it gave. Like
    /// every handler but `on_start`, it must return well within the heartbeat deadline.
    fn on_device(&mut self, ctx: &mut Context<'_>) {
        let _ = ctx;
    }
}
