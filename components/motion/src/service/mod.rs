//! The motion service kinds: thin adapters of the pure models to the runtime's
//! [`Service`](lewis_service::Service) trait.
//!
//! - [`vector_mover`] (`kind = "vector_mover"`): provides Mover, requires Egomotion and
//!   Synchrodrive. Every tick it steps a [`VectorMover`](super::VectorMover) on the newest
//!   odometry pose and sends the velocities to the base (`Synchrodrive.set_velocity`); a
//!   Mover command is carried out at once, its velocities sent in the command's own event.
//! - [`obstacle_avoider`] (`kind = "obstacle_avoider"`): provides Mover, requires
//!   Egomotion, Mover (a `vector_mover`, never itself: the broker does not bind a client to
//!   itself) and RangeFinder or Distance. Each reading is checked against the motion under
//!   way as it comes (the reflex: a stop at once when the way ahead is no longer free);
//!   every tick it steps an [`ObstacleAvoider`](super::ObstacleAvoider) on the newest
//!   reading and sends the waypoints it chooses to the VectorMover's Mover; it never
//!   commands the wheels.
//!
//! So a reading that shows an obstacle on the way reaches the base through two events, the
//! avoider's input and the VectorMover's command, with no tick between (the reflex latency
//! of the README); planning stays on the tick, where its cost (milliseconds: the cost map)
//! is paid ten times a second, not at the laser's rate.
//!
//! Both answer the Mover commands (goto, rotate, translate, stop) at once with the goal id
//! and publish the Mover status every tick. Calls to other services are asynchronous
//! ([`Context::call`]); their answers come back in `on_reply`. What the two share (serving
//! Mover commands, following the odometry pose, bounding calls in flight, logging a
//! persistent problem once) lives here.

pub mod obstacle_avoider;
pub mod vector_mover;

#[cfg(test)]
mod tests;

use std::collections::{BTreeSet, VecDeque};

use lewis_interfaces::Interface;
use lewis_interfaces::msg::{Egomotion, InputRef, Mover, MoverCommand, MoverReply, Pose2D};
use lewis_service::{
    BuildError, CallId, CommandError, Context, IncomingCommand, Input, InputError, Reply,
    ServiceConfig, ServiceRegistry,
};

use super::GoalError;

/// Registers the motion service kinds (`vector_mover`, `obstacle_avoider`).
pub fn register(registry: &mut ServiceRegistry) {
    registry
        .register_with_parameters::<vector_mover::Params>(vector_mover::KIND, vector_mover::build);
    registry.register_with_parameters::<obstacle_avoider::Params>(
        obstacle_avoider::KIND,
        obstacle_avoider::build,
    );
}

/// Decodes a Mover command, carries it out with `handle` (a mover's `handle`) and answers
/// it; a goal with an argument that is not finite is refused with the mover's reason.
pub(crate) fn answer_mover(
    ctx: &mut Context<'_>,
    command: &IncomingCommand<'_>,
    handle: impl FnOnce(&MoverCommand) -> Result<MoverReply, GoalError>,
) -> Result<Reply, CommandError> {
    if command.interface != Mover::NAME {
        return Err(CommandError::new(format!(
            "{} serves Mover, not {}",
            ctx.name(),
            command.interface
        )));
    }
    let decoded = command.decode::<Mover>()?;
    let reply = handle(&decoded).map_err(|e| CommandError::new(e.to_string()))?;
    Ok(match reply {
        MoverReply::Goto(r) => ctx.reply(r),
        MoverReply::Rotate(r) => ctx.reply(r),
        MoverReply::Translate(r) => ctx.reply(r),
        MoverReply::Stop(r) => ctx.reply(r),
    })
}

/// The robot's odometry pose as the Egomotion samples give it: the newest one (and where it
/// came from, for provenance) and a short history, so that a range reading can be placed
/// with the pose the robot had when it was taken.
#[derive(Debug, Clone, Default)]
pub(crate) struct PoseTrack {
    /// `(publish time in ns, pose)`, oldest first, at most [`PoseTrack::HISTORY`].
    history: VecDeque<(i64, Pose2D)>,
    source: Option<InputRef>,
}

impl PoseTrack {
    /// Poses kept: a second of odometry at 64 Hz, more than any reading's latency.
    const HISTORY: usize = 64;

    /// Takes in an Egomotion sample. A sample older than the newest one is ignored.
    pub(crate) fn observe(&mut self, input: &Input<'_>) -> Result<(), InputError> {
        let sample: Egomotion = input.decode()?;
        let stamp_ns = sample.header.publish_time_ns;
        if self.history.back().is_some_and(|(t, _)| *t > stamp_ns) {
            return Ok(());
        }
        self.history.push_back((stamp_ns, sample.pose));
        while self.history.len() > Self::HISTORY {
            self.history.pop_front();
        }
        self.source = Some(InputRef {
            channel: input.channel.to_owned(),
            seq: sample.header.seq,
        });
        Ok(())
    }

    /// The newest pose and its time, if any came.
    pub(crate) fn latest(&self) -> Option<(i64, &Pose2D)> {
        self.history.back().map(|(t, p)| (*t, p))
    }

    /// The newest pose if it is no older than `max_age_ns` at `now_ns`.
    pub(crate) fn fresh(&self, now_ns: i64, max_age_ns: i64) -> Option<&Pose2D> {
        self.latest()
            .filter(|(t, _)| now_ns.saturating_sub(*t) <= max_age_ns)
            .map(|(_, p)| p)
    }

    /// The pose the robot had at `stamp_ns`: the newest one taken no later (the oldest one
    /// kept when all are later).
    pub(crate) fn at(&self, stamp_ns: i64) -> Option<&Pose2D> {
        self.history
            .iter()
            .rev()
            .find(|(t, _)| *t <= stamp_ns)
            .or_else(|| self.history.front())
            .map(|(_, p)| p)
    }

    /// The Egomotion sample the newest pose came from.
    pub(crate) fn source(&self) -> Option<&InputRef> {
        self.source.as_ref()
    }
}

/// The calls a service has sent and not yet seen answered, bounded: a provider that stops
/// answering must not make calls pile up (each waits for its timeout).
#[derive(Debug, Clone)]
pub(crate) struct InFlight {
    calls: BTreeSet<CallId>,
    limit: usize,
}

impl InFlight {
    pub(crate) fn new(limit: usize) -> Self {
        Self {
            calls: BTreeSet::new(),
            limit,
        }
    }

    /// Whether another call may be sent now.
    pub(crate) fn has_room(&self) -> bool {
        self.calls.len() < self.limit
    }

    /// Whether no call waits for its answer.
    pub(crate) fn is_empty(&self) -> bool {
        self.calls.is_empty()
    }

    pub(crate) fn sent(&mut self, call: CallId) {
        self.calls.insert(call);
    }

    /// Forgets an answered call; whether it was one of ours.
    pub(crate) fn answered(&mut self, call: CallId) -> bool {
        self.calls.remove(&call)
    }
}

/// A problem that lasts (no provider, stale data) is logged when it starts or changes and
/// when it ends, not at every tick.
#[derive(Debug, Clone, Default)]
pub(crate) struct Complaint {
    current: Option<String>,
}

impl Complaint {
    /// The problem is (still) there.
    pub(crate) fn raise(&mut self, ctx: &mut Context<'_>, text: String) {
        if self.current.as_deref() != Some(text.as_str()) {
            ctx.warn(&text);
            self.current = Some(text);
        }
    }

    /// The problem is gone.
    pub(crate) fn clear(&mut self, ctx: &mut Context<'_>, text: &str) {
        if self.current.take().is_some() {
            ctx.info(text);
        }
    }
}

/// A tick period from a rate, checked.
pub(crate) fn period_ns(config: &ServiceConfig<'_>, rate_hz: f64) -> Result<i64, BuildError> {
    if !(rate_hz.is_finite() && (0.1..=1000.0).contains(&rate_hz)) {
        return Err(BuildError::Parameters {
            service: config.name().to_owned(),
            reason: format!("rate_hz = {rate_hz}: give a rate in [0.1, 1000] Hz"),
        });
    }
    // 1e9 / rate is at most 1e10: it fits an i64.
    let period = (1e9 / rate_hz).round() as i64;
    Ok(period)
}

/// Milliseconds as nanoseconds, saturating.
pub(crate) fn ms_to_ns(ms: u64) -> i64 {
    i64::try_from(ms)
        .unwrap_or(i64::MAX)
        .saturating_mul(1_000_000)
}

/// A motion configuration error as a build error naming the service.
pub(crate) fn config_error(config: &ServiceConfig<'_>, error: &super::ConfigError) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: error.to_string(),
    }
}
