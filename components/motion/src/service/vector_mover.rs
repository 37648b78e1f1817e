//! `vector_mover`: the Mover interface straight to the goal, closed on Egomotion, through
//! Synchrodrive.
//!
//! Every tick it steps a [`VectorMover`] on the newest odometry pose and sends the
//! velocities with `Synchrodrive.set_velocity` (asynchronous; at most
//! [`MAX_CALLS_IN_FLIGHT`] unanswered), then publishes the Mover status. A Mover command
//! (goto, rotate, translate, stop) is carried out at once too: in the same event it does
//! the last step again for the new goal ([`VectorMover::restep`]) and sends those
//! velocities, so a stop or a new waypoint from the avoider's reflex reaches the base
//! without waiting for the next tick. Doing the last step again, on its pose and from the
//! command before it, rather than a step at the command's arrival, keeps the answer
//! independent of when the command came: a replay carries it out at the same velocities.
//!
//! When the pose is older than `max_pose_age_ms` it commands zero (fail safe) and declares
//! itself degraded until fresh odometry comes; the goal is kept (and a command waits for
//! the next fresh step). With no goal and the robot commanded to
//! rest it sends nothing, so that it does not fight another user of the base.
//!
//! ```toml
//! [[services]]
//! name = "vector_mover"
//! kind = "vector_mover"
//! provides = [{ interface = "Mover", quality = 5, cost = 1 }]
//! requires = ["Egomotion", "Synchrodrive"]
//! [services.parameters]             # all optional; defaults of VectorMoverConfig
//! rate_hz = 10.0
//! max_pose_age_ms = 500
//! max_translation_m_s = 0.5
//! max_rotation_rad_s = 1.0
//! translation_accel_m_s2 = 0.5
//! rotation_accel_rad_s2 = 1.5
//! position_tolerance_m = 0.05
//! heading_tolerance_rad = 0.02
//! stall_timeout_ms = 3000
//! ```

use lewis_interfaces::msg::{SynchrodriveSetVelocity, SynchrodriveStop};
use lewis_service::Health;
use lewis_service::{
    BuildError, CallId, CommandError, Context, IncomingCommand, Input, Reply, ReplyEvent, Service,
    ServiceConfig,
};
use serde::Deserialize;

use super::{Complaint, InFlight, PoseTrack, answer_mover, config_error, ms_to_ns, period_ns};
use crate::{MoverStatus, VectorMover, VectorMoverConfig, VelocityCommand};

/// The kind name in robot files.
pub const KIND: &str = "vector_mover";

/// Velocity commands sent and not yet answered, at most: beyond it a tick sends nothing
/// (the base is not answering; piling up commands would only replay stale velocities).
pub const MAX_CALLS_IN_FLIGHT: usize = 2;

/// The parameters of `vector_mover` (every limit optional: the defaults are
/// [`VectorMoverConfig::default`]'s).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Control steps per second.
    pub rate_hz: f64,
    /// Odometry older than this stops the robot, in ms.
    pub max_pose_age_ms: u64,
    /// Largest translational speed, in m/s.
    pub max_translation_m_s: Option<f64>,
    /// Largest rotational speed, in rad/s.
    pub max_rotation_rad_s: Option<f64>,
    /// Largest translational acceleration, in m/s^2.
    pub translation_accel_m_s2: Option<f64>,
    /// Largest rotational acceleration, in rad/s^2.
    pub rotation_accel_rad_s2: Option<f64>,
    /// A goto or translate is reached within this distance, in m.
    pub position_tolerance_m: Option<f64>,
    /// A rotate is reached within this angle, in rad.
    pub heading_tolerance_rad: Option<f64>,
    /// A goal is blocked when the robot has not moved for this long, in ms.
    pub stall_timeout_ms: Option<u64>,
    /// Seed of the runtime's random source (unused by this service; accepted so that every
    /// robot file may give one).
    pub seed: Option<u64>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            max_pose_age_ms: 500,
            max_translation_m_s: None,
            max_rotation_rad_s: None,
            translation_accel_m_s2: None,
            rotation_accel_rad_s2: None,
            position_tolerance_m: None,
            heading_tolerance_rad: None,
            stall_timeout_ms: None,
            seed: None,
        }
    }
}

impl Params {
    /// The mover's configuration: the defaults with these parameters over them.
    #[must_use]
    pub fn mover_config(&self) -> VectorMoverConfig {
        let d = VectorMoverConfig::default();
        VectorMoverConfig {
            max_translation_m_s: self.max_translation_m_s.unwrap_or(d.max_translation_m_s),
            max_rotation_rad_s: self.max_rotation_rad_s.unwrap_or(d.max_rotation_rad_s),
            translation_accel_m_s2: self
                .translation_accel_m_s2
                .unwrap_or(d.translation_accel_m_s2),
            rotation_accel_rad_s2: self
                .rotation_accel_rad_s2
                .unwrap_or(d.rotation_accel_rad_s2),
            position_tolerance_m: self.position_tolerance_m.unwrap_or(d.position_tolerance_m),
            heading_tolerance_rad: self
                .heading_tolerance_rad
                .unwrap_or(d.heading_tolerance_rad),
            stall_timeout_ns: self.stall_timeout_ms.map_or(d.stall_timeout_ns, ms_to_ns),
            ..d
        }
    }
}

/// The `vector_mover` service.
#[derive(Debug)]
pub struct VectorMoverService {
    mover: VectorMover,
    period_ns: i64,
    max_pose_age_ns: i64,
    pose: PoseTrack,
    calls: InFlight,
    /// The last velocities sent, and whether the base answered a zero since.
    sent: Option<VelocityCommand>,
    last_call: Option<CallId>,
    rest_confirmed: bool,
    /// The last tick stepped the mover on a fresh pose (a command may then be carried out
    /// at once; after a stale one the robot is held until fresh odometry comes).
    stepped_fresh: bool,
    stale_pose: Complaint,
    drive_failing: Complaint,
}

/// Builds a `vector_mover` from its robot-file entry.
///
/// # Errors
/// When a parameter is unknown or out of range, or the service does not require Egomotion
/// and Synchrodrive.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    Ok(Box::new(VectorMoverService::new(config)?))
}

impl VectorMoverService {
    /// The service its robot-file entry describes.
    ///
    /// # Errors
    /// As [`build`].
    pub fn new(config: &ServiceConfig<'_>) -> Result<Self, BuildError> {
        let params: Params = config.parameters()?;
        for needed in ["Egomotion", "Synchrodrive"] {
            if !config.spec.requires.iter().any(|r| r == needed) {
                return Err(BuildError::Parameters {
                    service: config.name().to_owned(),
                    reason: format!(
                        "a vector_mover requires Egomotion and Synchrodrive: add \"{needed}\" to `requires`"
                    ),
                });
            }
        }
        let mover =
            VectorMover::new(params.mover_config()).map_err(|e| config_error(config, &e))?;
        Ok(Self {
            mover,
            period_ns: period_ns(config, params.rate_hz)?,
            max_pose_age_ns: ms_to_ns(params.max_pose_age_ms),
            pose: PoseTrack::default(),
            calls: InFlight::new(MAX_CALLS_IN_FLIGHT),
            sent: None,
            last_call: None,
            rest_confirmed: false,
            stepped_fresh: false,
            stale_pose: Complaint::default(),
            drive_failing: Complaint::default(),
        })
    }

    /// The mover inside (for tests and tools).
    #[must_use]
    pub fn mover(&self) -> &VectorMover {
        &self.mover
    }

    /// The velocities of this step: the mover's on a fresh pose, zero on a stale one.
    fn control(&mut self, ctx: &mut Context<'_>, now_ns: i64) -> VelocityCommand {
        if let Some(pose) = self.pose.fresh(now_ns, self.max_pose_age_ns).cloned() {
            self.stale_pose
                .clear(ctx, "Egomotion is fresh again: driving on");
            ctx.set_health(Health::Ok);
            self.stepped_fresh = true;
            return self.mover.step(&pose, now_ns);
        }
        self.stepped_fresh = false;
        if self.mover.status() == MoverStatus::Moving {
            let why = match self.pose.latest() {
                None => "no Egomotion sample yet: holding the robot still".to_owned(),
                Some((t, _)) => format!(
                    "Egomotion is {} ms old: holding the robot still",
                    now_ns.saturating_sub(t) / 1_000_000
                ),
            };
            ctx.set_health(Health::Degraded(why.clone()));
            self.stale_pose.raise(ctx, why);
        }
        // The wheels stop; the next fresh step ramps up again from rest.
        self.mover.cap_translation(0.0);
        VelocityCommand::ZERO
    }

    /// Whether the base must hear from us this tick: while a goal runs, while the robot is
    /// commanded to move, and until a command to rest has been answered.
    fn must_send(&self, command: VelocityCommand) -> bool {
        self.mover.status() == MoverStatus::Moving
            || command != VelocityCommand::ZERO
            || (self.sent.is_some() && !self.rest_confirmed)
    }

    fn send(&mut self, ctx: &mut Context<'_>, command: VelocityCommand) {
        if !self.calls.has_room() {
            self.drive_failing.raise(
                ctx,
                format!(
                    "Synchrodrive has not answered {MAX_CALLS_IN_FLIGHT} velocity commands: not sending more until it does"
                ),
            );
            return;
        }
        let mut message: SynchrodriveSetVelocity = command.into();
        match ctx.call(&mut message) {
            Ok(call) => {
                self.calls.sent(call);
                self.last_call = Some(call);
                self.rest_confirmed = false;
                self.sent = Some(command);
            }
            Err(e) => self
                .drive_failing
                .raise(ctx, format!("cannot command Synchrodrive: {e}")),
        }
    }

    fn publish(&mut self, ctx: &mut Context<'_>) {
        ctx.set_inputs(self.pose.source().into_iter().cloned().collect());
        let mut status = self.mover.publication();
        if let Err(e) = ctx.publish(&mut status) {
            ctx.warn(&format!("cannot publish Mover: {e}"));
        }
    }
}

impl Service for VectorMoverService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        if input.interface == "Egomotion"
            && let Err(e) = self.pose.observe(input)
        {
            ctx.warn(&format!("Egomotion sample ignored: {e}"));
        }
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        let now_ns = ctx.now();
        let command = self.control(ctx, now_ns);
        if self.must_send(command) {
            self.send(ctx, command);
        }
        self.publish(ctx);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        let mover = &mut self.mover;
        let reply = answer_mover(ctx, command, |c| mover.handle(c))?;
        // At once, not at the next tick: a stop or a new waypoint from the avoider's reflex
        // reaches the wheels within the same event.
        if self.stepped_fresh
            && let Some(velocities) = self.mover.restep()
            && self.must_send(velocities)
        {
            self.send(ctx, velocities);
        }
        Ok(reply)
    }

    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        if !self.calls.answered(reply.call) {
            return;
        }
        match reply.decode::<SynchrodriveSetVelocity>() {
            Ok(_) => {
                if self.last_call == Some(reply.call) && self.sent == Some(VelocityCommand::ZERO) {
                    self.rest_confirmed = true;
                }
                self.drive_failing
                    .clear(ctx, "Synchrodrive answers velocity commands again");
            }
            Err(e) => self
                .drive_failing
                .raise(ctx, format!("Synchrodrive.set_velocity failed: {e}")),
        }
    }

    fn on_stop(&mut self, ctx: &mut Context<'_>) {
        // Best effort: the process ends before any answer could come.
        if self.sent.is_some_and(|c| c != VelocityCommand::ZERO) {
            let _ = ctx.call(&mut SynchrodriveStop::default());
        }
    }
}
