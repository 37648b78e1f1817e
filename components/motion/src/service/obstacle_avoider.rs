//! `obstacle_avoider`: the Mover interface around obstacles, by the paper's greedy strategy,
//! through a VectorMover.
//!
//! Every tick it takes in the newest range reading (RangeFinder, or Distance when it
//! requires no RangeFinder), placed with the odometry pose of when it was taken, steps an
//! [`ObstacleAvoider`] and sends the request it yields (a waypoint, a stop) to the Mover it
//! requires: a `vector_mover`, which drives the wheels. It publishes its own Mover status
//! every tick, with the velocities the VectorMover last published; its provenance names
//! the three samples it stands on (the newest odometry, the reading observed last, the
//! VectorMover status), which is what lets a replay give it exactly the same inputs.
//!
//! Between ticks, every reading goes through the reflex as it arrives
//! ([`ObstacleAvoider::react`]): when an obstacle of that reading lies on the way to the
//! current waypoint, within the reflex's lookahead, the avoider sends the VectorMover a
//! stop in the same event, and the next tick plans around the obstacle. The reflex costs a
//! pass over the reading's points, the step milliseconds (it rebuilds the cost map of up to
//! 40,000 cells and tries 180 directions), so only the reflex runs at the laser's rate. It
//! reads no clock and places the reading with the pose of when it was taken, so its answer
//! does not depend on when the event ran (live, a little after the publication; in a
//! replay, at it). It publishes nothing: the status goes out at the tick.
//!
//! The step takes in the newest reading only: a laser at 75 Hz costs the planner no more
//! than one at 10 Hz. When the range finder changes (the broker moves it from the laser to
//! the sonar), the readings simply come from the new provider; while none come the avoider
//! holds the robot (fail safe) and goes on when they come back.
//!
//! When the VectorMover stops pursuing the avoider's waypoint on its own (it arrived,
//! blocked, or was restarted and is idle) while the avoider still has a goal, the avoider
//! sends its waypoint again.
//!
//! ```toml
//! [[services]]
//! name = "obstacle_avoider"
//! kind = "obstacle_avoider"
//! provides = [{ interface = "Mover", quality = 10, cost = 2 }]
//! requires = ["RangeFinder", "Egomotion", "Mover"]
//! [services.parameters]             # all optional; defaults of ObstacleAvoiderConfig
//! rate_hz = 10.0                    # steps (plans) per second; the reflex runs on each reading
//! robot_radius_m = 0.26
//! clearance_m = 0.12
//! direction_count = 180
//! max_reading_age_ms = 500
//! fail_after_ms = 30000
//! no_progress_timeout_ms = 15000
//! memory_ms = 5000
//! detour_wait_ms = 8000             # a shut way is waited for before it is gone round
//! position_tolerance_m = 0.07
//! heading_tolerance_rad = 0.03
//! goal = { x_m = 12.0, y_m = 13.0 } # a goto taken at start, in the odometry frame
//! ```
//!
//! Without `goal` the avoider waits for a Mover command. With it, it starts moving to the
//! goal as if a client had sent `goto` before its first tick (and again after a restart):
//! for robots that have one job, and for replays of logs in which no client sent one.

use lewis_interfaces::msg::{
    Distance, InputRef, Mover, MoverGoto, MoverRotate, MoverStop, MoverTranslate, RangeFinder,
};
use lewis_service::{
    BuildError, CallFailure, CallId, CommandError, Context, IncomingCommand, Input, Reply,
    ReplyEvent, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{Complaint, InFlight, PoseTrack, answer_mover, config_error, ms_to_ns, period_ns};
use crate::{
    MoverRequest, MoverStatus, ObstacleAvoider, ObstacleAvoiderConfig, RangeScan, VelocityCommand,
};

/// The kind name in robot files.
pub const KIND: &str = "obstacle_avoider";

/// Mover commands sent to the VectorMover and not yet answered, at most.
pub const MAX_CALLS_IN_FLIGHT: usize = 4;

/// The parameters of `obstacle_avoider` (every value optional: the defaults are
/// [`ObstacleAvoiderConfig::default`]'s).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Steps per second.
    pub rate_hz: f64,
    /// The robot's radius, in m.
    pub robot_radius_m: Option<f64>,
    /// Room kept between the robot and any obstacle, in m.
    pub clearance_m: Option<f64>,
    /// Directions tried around the robot at each step.
    pub direction_count: Option<usize>,
    /// Readings older than this hold the robot, in ms.
    pub max_reading_age_ms: Option<u64>,
    /// Without fresh readings for this long the goal fails, in ms.
    pub fail_after_ms: Option<u64>,
    /// Without progress for this long the goal is blocked, in ms.
    pub no_progress_timeout_ms: Option<u64>,
    /// How long obstacles are remembered, in ms.
    pub memory_ms: Option<u64>,
    /// How long a shut way is waited for before it is gone round, in ms (0: at once).
    pub detour_wait_ms: Option<u64>,
    /// A goto or translate is reached within this distance, in m.
    pub position_tolerance_m: Option<f64>,
    /// A rotate is reached within this angle, in rad.
    pub heading_tolerance_rad: Option<f64>,
    /// Seed of the runtime's random source (unused; accepted so that every robot file may
    /// give one).
    pub seed: Option<u64>,
    /// A goal taken at start (see the module documentation).
    pub goal: Option<GoalParam>,
}

/// A point of the odometry frame to go to, as robot files write it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoalParam {
    /// x, in m.
    pub x_m: f64,
    /// y, in m.
    pub y_m: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            robot_radius_m: None,
            clearance_m: None,
            direction_count: None,
            max_reading_age_ms: None,
            fail_after_ms: None,
            no_progress_timeout_ms: None,
            memory_ms: None,
            detour_wait_ms: None,
            position_tolerance_m: None,
            heading_tolerance_rad: None,
            seed: None,
            goal: None,
        }
    }
}

impl Params {
    /// The avoider's configuration: the defaults with these parameters over them.
    #[must_use]
    pub fn avoider_config(&self) -> ObstacleAvoiderConfig {
        let d = ObstacleAvoiderConfig::default();
        let ns = |ms: Option<u64>, default: i64| ms.map_or(default, ms_to_ns);
        ObstacleAvoiderConfig {
            robot_radius_m: self.robot_radius_m.unwrap_or(d.robot_radius_m),
            clearance_m: self.clearance_m.unwrap_or(d.clearance_m),
            direction_count: self.direction_count.unwrap_or(d.direction_count),
            max_reading_age_ns: ns(self.max_reading_age_ms, d.max_reading_age_ns),
            fail_after_ns: ns(self.fail_after_ms, d.fail_after_ns),
            no_progress_timeout_ns: ns(self.no_progress_timeout_ms, d.no_progress_timeout_ns),
            memory_ns: ns(self.memory_ms, d.memory_ns),
            detour_wait_ns: ns(self.detour_wait_ms, d.detour_wait_ns),
            position_tolerance_m: self.position_tolerance_m.unwrap_or(d.position_tolerance_m),
            heading_tolerance_rad: self
                .heading_tolerance_rad
                .unwrap_or(d.heading_tolerance_rad),
            ..d
        }
    }
}

/// Which reading the avoider works from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sensor {
    RangeFinder,
    Distance,
}

impl Sensor {
    const fn interface(self) -> &'static str {
        match self {
            Self::RangeFinder => "RangeFinder",
            Self::Distance => "Distance",
        }
    }
}

/// A reading waiting for the next tick, turned into beams.
#[derive(Debug, Clone)]
struct Pending {
    scan: RangeScan,
    /// When it was taken (its publish time).
    stamp_ns: i64,
    source: InputRef,
}

/// The `obstacle_avoider` service.
#[derive(Debug)]
pub struct ObstacleAvoiderService {
    avoider: ObstacleAvoider,
    sensor: Sensor,
    period_ns: i64,
    pose: PoseTrack,
    pending: Option<Pending>,
    reading_source: Option<InputRef>,
    calls: InFlight,
    last_call: Option<CallId>,
    /// The goal id the VectorMover gave the last request answered.
    mover_goal: Option<i32>,
    /// The VectorMover's last publication, and where it came from (for provenance: the
    /// velocities published come from it).
    mover_status: Option<(Mover, InputRef)>,
    mover_failing: Complaint,
    bad_reading: Complaint,
    /// The goal taken at start.
    goal: Option<GoalParam>,
}

/// Builds an `obstacle_avoider` from its robot-file entry.
///
/// # Errors
/// When a parameter is unknown or out of range, or the service does not require Egomotion,
/// Mover and RangeFinder or Distance.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    Ok(Box::new(ObstacleAvoiderService::new(config)?))
}

impl ObstacleAvoiderService {
    /// The service its robot-file entry describes.
    ///
    /// # Errors
    /// As [`build`].
    pub fn new(config: &ServiceConfig<'_>) -> Result<Self, BuildError> {
        let params: Params = config.parameters()?;
        let requires = |name: &str| config.spec.requires.iter().any(|r| r == name);
        let sensor = if requires("RangeFinder") {
            Sensor::RangeFinder
        } else if requires("Distance") {
            Sensor::Distance
        } else {
            return Err(missing(config, "RangeFinder"));
        };
        for needed in ["Egomotion", "Mover"] {
            if !requires(needed) {
                return Err(missing(config, needed));
            }
        }
        let avoider =
            ObstacleAvoider::new(params.avoider_config()).map_err(|e| config_error(config, &e))?;
        if let Some(goal) = params.goal
            && !(goal.x_m.is_finite() && goal.y_m.is_finite())
        {
            return Err(BuildError::Parameters {
                service: config.name().to_owned(),
                reason: format!(
                    "goal = {{ x_m = {}, y_m = {} }}: give finite coordinates in m",
                    goal.x_m, goal.y_m
                ),
            });
        }
        Ok(Self {
            avoider,
            sensor,
            period_ns: period_ns(config, params.rate_hz)?,
            pose: PoseTrack::default(),
            pending: None,
            reading_source: None,
            calls: InFlight::new(MAX_CALLS_IN_FLIGHT),
            last_call: None,
            mover_goal: None,
            mover_status: None,
            mover_failing: Complaint::default(),
            bad_reading: Complaint::default(),
            goal: params.goal,
        })
    }

    /// The avoider inside (for tests and tools).
    #[must_use]
    pub fn avoider(&self) -> &ObstacleAvoider {
        &self.avoider
    }

    /// Takes in a reading: the reflex checks the motion under way against it at once, and
    /// it waits for the next step, which takes in the newest one.
    fn take_reading(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let half_width_rad = self.avoider.config().non_uniform_half_width_rad;
        let decoded = match self.sensor {
            Sensor::RangeFinder => input.decode::<RangeFinder>().map(|r| {
                let scan = RangeScan::from_range_finder(&r, half_width_rad);
                (scan, r.header.publish_time_ns, r.header.seq)
            }),
            Sensor::Distance => input.decode::<Distance>().map(|d| {
                let scan = RangeScan::from_distance(&d);
                (scan, d.header.publish_time_ns, d.header.seq)
            }),
        };
        let (scan, stamp_ns, seq) = match decoded {
            Ok((Ok(scan), stamp_ns, seq)) => (scan, stamp_ns, seq),
            Ok((Err(e), ..)) => {
                return self
                    .bad_reading
                    .raise(ctx, format!("{} sample ignored: {e}", input.interface));
            }
            Err(e) => {
                return self
                    .bad_reading
                    .raise(ctx, format!("{} sample ignored: {e}", input.interface));
            }
        };
        // The pose of when the reading was taken, not the newest: the reflex then depends
        // on the reading alone, not on when it was handled (a replay hands it over at its
        // publish time, live it comes a little later).
        if let Some(pose) = self.pose.at(stamp_ns).cloned()
            && let Some(request) = self.avoider.react(&scan, &pose)
        {
            self.send(ctx, request);
        }
        let source = InputRef {
            channel: input.channel.to_owned(),
            seq,
        };
        self.pending = Some(Pending {
            scan,
            stamp_ns,
            source,
        });
    }

    /// Places the newest reading with the pose of when it was taken.
    fn observe_pending(&mut self, ctx: &mut Context<'_>) {
        let Some(Pending {
            scan,
            stamp_ns,
            source,
        }) = self.pending.take()
        else {
            return;
        };
        let Some(pose) = self.pose.at(stamp_ns).cloned() else {
            // No odometry yet: a reading cannot be placed.
            return;
        };
        match self.avoider.observe_scan(&scan, &pose, stamp_ns) {
            Ok(()) => {
                self.reading_source = Some(source);
                self.bad_reading
                    .clear(ctx, "range readings are usable again");
            }
            Err(e) => self.bad_reading.raise(
                ctx,
                format!("{} sample ignored: {e}", self.sensor.interface()),
            ),
        }
    }

    fn send(&mut self, ctx: &mut Context<'_>, request: MoverRequest) {
        if !self.calls.has_room() {
            self.avoider.resend();
            self.mover_failing.raise(
                ctx,
                format!("the VectorMover has not answered {MAX_CALLS_IN_FLIGHT} requests: waiting"),
            );
            return;
        }
        let sent = match request {
            MoverRequest::Goto { x_m, y_m } => ctx.call(&mut MoverGoto {
                x: x_m,
                y: y_m,
                ..MoverGoto::default()
            }),
            MoverRequest::Rotate { angle_rad } => ctx.call(&mut MoverRotate {
                angle: angle_rad,
                ..MoverRotate::default()
            }),
            MoverRequest::Translate { distance_m } => ctx.call(&mut MoverTranslate {
                distance: distance_m,
                ..MoverTranslate::default()
            }),
            MoverRequest::Stop => ctx.call(&mut MoverStop::default()),
        };
        match sent {
            Ok(call) => {
                self.calls.sent(call);
                self.last_call = Some(call);
            }
            Err(e) => {
                // Ask again at the next step, when the VectorMover may be there.
                self.avoider.resend();
                self.mover_failing
                    .raise(ctx, format!("cannot reach the VectorMover: {e}"));
            }
        }
    }

    /// The VectorMover no longer pursues what the avoider asked: ask again.
    fn follow_mover(&mut self, status: &Mover) {
        if self.avoider.status() != MoverStatus::Moving || !self.calls.is_empty() {
            return;
        }
        let ours = self.mover_goal == Some(status.goal_id);
        let stopped = status.status != MoverStatus::Moving;
        // An idle mover was restarted or stopped by someone else; a final status of an
        // older goal is a publication that crossed our request.
        if stopped && (ours || status.status == MoverStatus::Idle) {
            self.avoider.resend();
        }
    }

    fn publish(&mut self, ctx: &mut Context<'_>) {
        let inputs = self
            .pose
            .source()
            .into_iter()
            .chain(self.reading_source.as_ref())
            .chain(self.mover_status.as_ref().map(|(_, source)| source))
            .cloned()
            .collect();
        ctx.set_inputs(inputs);
        let velocities = self
            .mover_status
            .as_ref()
            .map_or(VelocityCommand::ZERO, |(m, _)| VelocityCommand {
                translation_m_s: m.translation_velocity,
                rotation_rad_s: m.rotation_velocity,
            });
        let mut status = self.avoider.publication(velocities);
        if let Err(e) = ctx.publish(&mut status) {
            ctx.warn(&format!("cannot publish Mover: {e}"));
        }
    }
}

fn missing(config: &ServiceConfig<'_>, interface: &str) -> BuildError {
    BuildError::Parameters {
        service: config.name().to_owned(),
        reason: format!(
            "an obstacle_avoider requires Egomotion, Mover (a vector_mover) and RangeFinder or Distance: add \"{interface}\" to `requires`"
        ),
    }
}

impl Service for ObstacleAvoiderService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(self.period_ns)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        if let Some(goal) = self.goal {
            // Checked finite when built: the goal is accepted.
            self.avoider
                .goto(goal.x_m, goal.y_m)
                .map_err(|e| e.to_string())?;
            ctx.info(&format!(
                "going to the goal of its parameters, ({}, {})",
                goal.x_m, goal.y_m
            ));
        }
        Ok(())
    }

    fn on_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        match input.interface {
            "Egomotion" => {
                if let Err(e) = self.pose.observe(input) {
                    ctx.warn(&format!("Egomotion sample ignored: {e}"));
                }
            }
            "Mover" => match input.decode::<Mover>() {
                Ok(status) => {
                    self.follow_mover(&status);
                    let source = InputRef {
                        channel: input.channel.to_owned(),
                        seq: status.header.seq,
                    };
                    self.mover_status = Some((status, source));
                }
                Err(e) => ctx.warn(&format!("Mover sample ignored: {e}")),
            },
            interface if interface == self.sensor.interface() => self.take_reading(ctx, input),
            _ => {}
        }
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        self.observe_pending(ctx);
        let now_ns = ctx.now();
        if let Some((_, pose)) = self.pose.latest() {
            let pose = pose.clone();
            let step = self.avoider.step(&pose, now_ns);
            if let Some(request) = step.request {
                self.send(ctx, request);
            }
        }
        self.publish(ctx);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        let avoider = &mut self.avoider;
        answer_mover(ctx, command, |c| avoider.handle(c))
    }

    fn on_reply(&mut self, ctx: &mut Context<'_>, reply: &ReplyEvent<'_>) {
        if !self.calls.answered(reply.call) {
            return;
        }
        let goal_id = match reply.command {
            "goto" => reply.decode::<MoverGoto>().map(|r| Some(r.goal_id)),
            "rotate" => reply.decode::<MoverRotate>().map(|r| Some(r.goal_id)),
            "translate" => reply.decode::<MoverTranslate>().map(|r| Some(r.goal_id)),
            "stop" => reply.decode::<MoverStop>().map(|_| None),
            other => Err(CallFailure::Transport(format!(
                "a reply to Mover.{other}, which this service never sends"
            ))),
        };
        match goal_id {
            Ok(goal_id) => {
                if self.last_call == Some(reply.call) {
                    self.mover_goal = goal_id;
                }
                self.mover_failing
                    .clear(ctx, "the VectorMover answers again");
            }
            Err(e) => {
                self.avoider.resend();
                self.mover_failing.raise(
                    ctx,
                    format!("Mover.{} to the VectorMover failed: {e}", reply.command),
                );
            }
        }
    }
}
