//! VectorMover: moves the robot straight to a goal, closed on the odometry pose.
//!
//! Each control step turns the pose (Egomotion, odometry frame) into a translational and a
//! rotational velocity for the synchro-drive. The law is smooth: the robot turns on the
//! spot while the goal is far off its heading and drives while turning once it is near,
//! speeds fall with the remaining distance or angle so that it brakes within its
//! acceleration limits, and every command respects the velocity and acceleration limits.

use super::mover::{
    ConfigError, GoalError, GoalId, MoverRequest, MoverStatus, VelocityCommand, answer_command,
    require_non_negative, require_positive,
};
use lewis_geometry::{Vec2, pose_is_finite, position, wrap_angle};
use lewis_interfaces::msg::{Mover, MoverCommand, MoverReply, Point2D, Pose2D};

const NANOS_PER_SEC: f64 = 1e9;

/// The limits, gains and tolerances of a VectorMover.
#[derive(Debug, Clone, PartialEq)]
pub struct VectorMoverConfig {
    /// Largest translational speed, in m/s (a B21r: about 0.5).
    pub max_translation_m_s: f64,
    /// Largest rotational speed, in rad/s.
    pub max_rotation_rad_s: f64,
    /// Largest change of the translational velocity, in m/s^2 (speeding up and braking).
    pub translation_accel_m_s2: f64,
    /// Largest change of the rotational velocity, in rad/s^2.
    pub rotation_accel_rad_s2: f64,
    /// Translational speed per metre still to go, in 1/s.
    pub translation_gain_per_s: f64,
    /// Rotational speed per radian of heading error, in 1/s.
    pub rotation_gain_per_s: f64,
    /// Heading error beyond which the robot only turns; below it, it drives while turning,
    /// slower the larger the error, in rad.
    pub drive_heading_limit_rad: f64,
    /// A goto or translate is reached within this distance, in m.
    pub position_tolerance_m: f64,
    /// A rotate is reached within this angle, in rad.
    pub heading_tolerance_rad: f64,
    /// A goal is reported blocked when the robot has not moved for this long, in ns.
    pub stall_timeout_ns: i64,
    /// Moving less than this (in m, or in rad of heading) does not count as moving.
    pub stall_motion_m: f64,
    /// The step length assumed for the first step, in ns.
    pub nominal_step_ns: i64,
    /// Longer gaps between steps count as this long, so that a late step does not allow a
    /// jump in velocity, in ns.
    pub max_step_ns: i64,
}

impl Default for VectorMoverConfig {
    fn default() -> Self {
        Self {
            max_translation_m_s: 0.5,
            max_rotation_rad_s: 1.0,
            translation_accel_m_s2: 0.5,
            rotation_accel_rad_s2: 1.5,
            translation_gain_per_s: 1.0,
            rotation_gain_per_s: 2.0,
            drive_heading_limit_rad: 0.8,
            position_tolerance_m: 0.05,
            heading_tolerance_rad: 0.02,
            stall_timeout_ns: 3_000_000_000,
            stall_motion_m: 0.01,
            nominal_step_ns: 100_000_000,
            max_step_ns: 250_000_000,
        }
    }
}

impl VectorMoverConfig {
    /// Checks that every value is in range.
    ///
    /// # Errors
    /// The first field out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        require_positive("max_translation_m_s", self.max_translation_m_s)?;
        require_positive("max_rotation_rad_s", self.max_rotation_rad_s)?;
        require_positive("translation_accel_m_s2", self.translation_accel_m_s2)?;
        require_positive("rotation_accel_rad_s2", self.rotation_accel_rad_s2)?;
        require_positive("translation_gain_per_s", self.translation_gain_per_s)?;
        require_positive("rotation_gain_per_s", self.rotation_gain_per_s)?;
        require_positive("drive_heading_limit_rad", self.drive_heading_limit_rad)?;
        if self.drive_heading_limit_rad > std::f64::consts::PI {
            return Err(ConfigError {
                field: "drive_heading_limit_rad",
                value: self.drive_heading_limit_rad,
                expected: "at most pi",
            });
        }
        require_positive("position_tolerance_m", self.position_tolerance_m)?;
        require_positive("heading_tolerance_rad", self.heading_tolerance_rad)?;
        require_non_negative("stall_motion_m", self.stall_motion_m)?;
        for (field, value) in [
            ("stall_timeout_ns", self.stall_timeout_ns),
            ("nominal_step_ns", self.nominal_step_ns),
            ("max_step_ns", self.max_step_ns),
        ] {
            if value <= 0 {
                return Err(ConfigError {
                    field,
                    value: value as f64,
                    expected: "> 0 ns",
                });
            }
        }
        Ok(())
    }

    /// Speed towards a target `remaining` away, for a proportional gain and an
    /// acceleration: never more than lets the robot brake in time.
    fn approach_speed(remaining: f64, gain: f64, accel: f64, max: f64) -> f64 {
        let remaining = remaining.abs();
        max.min(gain * remaining)
            .min((2.0 * accel * remaining).sqrt())
    }

    fn turn_rate(&self, heading_error_rad: f64) -> f64 {
        let speed = Self::approach_speed(
            heading_error_rad,
            self.rotation_gain_per_s,
            self.rotation_accel_rad_s2,
            self.max_rotation_rad_s,
        );
        speed.copysign(heading_error_rad)
    }

    fn drive_speed(&self, remaining_m: f64) -> f64 {
        let speed = Self::approach_speed(
            remaining_m,
            self.translation_gain_per_s,
            self.translation_accel_m_s2,
            self.max_translation_m_s,
        );
        speed.copysign(remaining_m)
    }

    /// 1 when heading straight at the target, falling smoothly to 0 at the drive limit.
    fn drive_factor(&self, heading_error_rad: f64) -> f64 {
        let limit_cos = self.drive_heading_limit_rad.cos();
        ((heading_error_rad.cos() - limit_cos) / (1.0 - limit_cos)).clamp(0.0, 1.0)
    }
}

/// A goal resolved against the pose: everything the control law needs.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Target {
    /// Waiting for the first pose to resolve a relative goal.
    Pending(MoverRequest),
    Point {
        goal: Vec2,
    },
    Turn {
        requested_rad: f64,
        turned_rad: f64,
        last_heading_rad: f64,
    },
    Line {
        target: Vec2,
        heading_rad: f64,
    },
}

/// The last control step, as [`VectorMover::restep`] does it again.
#[derive(Debug, Clone, PartialEq)]
struct LastStep {
    pose: Pose2D,
    /// The command before it.
    command_before: VelocityCommand,
    /// Its length, in s.
    dt_s: f64,
    /// The lowest cap on the translation since, in m/s.
    translation_cap_m_s: f64,
}

/// Moves the robot straight to a goal (the paper's VectorMover), one control step at a time.
#[derive(Debug, Clone)]
pub struct VectorMover {
    config: VectorMoverConfig,
    next_id: GoalId,
    goal_id: Option<GoalId>,
    goal: Pose2D,
    target: Option<Target>,
    status: MoverStatus,
    command: VelocityCommand,
    distance_to_goal_m: f64,
    last_step_ns: Option<i64>,
    last_pose: Option<Pose2D>,
    /// What [`VectorMover::restep`] does the last step again from; `None` before the first
    /// step and after one with a pose that was not finite.
    last_step: Option<LastStep>,
    stall_anchor: Option<(Pose2D, i64)>,
}

impl VectorMover {
    /// A mover at rest with no goal.
    ///
    /// # Errors
    /// A configuration value out of range.
    pub fn new(config: VectorMoverConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            next_id: GoalId::FIRST,
            goal_id: None,
            goal: Pose2D::default(),
            target: None,
            status: MoverStatus::Idle,
            command: VelocityCommand::ZERO,
            distance_to_goal_m: 0.0,
            last_step_ns: None,
            last_pose: None,
            last_step: None,
            stall_anchor: None,
        })
    }

    /// The configuration it was built with.
    #[must_use]
    pub fn config(&self) -> &VectorMoverConfig {
        &self.config
    }

    /// Go to a point of the odometry frame. Replaces any goal.
    ///
    /// # Errors
    /// A coordinate is not finite; the current goal is kept.
    pub fn goto(&mut self, x_m: f64, y_m: f64) -> Result<GoalId, GoalError> {
        let x_m = GoalError::check("goto", "x", x_m)?;
        let y_m = GoalError::check("goto", "y", y_m)?;
        Ok(self.accept(MoverRequest::Goto { x_m, y_m }))
    }

    /// Turn in place by `angle_rad` relative to the current heading (several turns allowed).
    ///
    /// # Errors
    /// The angle is not finite; the current goal is kept.
    pub fn rotate(&mut self, angle_rad: f64) -> Result<GoalId, GoalError> {
        let angle_rad = GoalError::check("rotate", "angle", angle_rad)?;
        Ok(self.accept(MoverRequest::Rotate { angle_rad }))
    }

    /// Drive straight along the current heading, backwards when negative.
    ///
    /// # Errors
    /// The distance is not finite; the current goal is kept.
    pub fn translate(&mut self, distance_m: f64) -> Result<GoalId, GoalError> {
        let distance_m = GoalError::check("translate", "distance", distance_m)?;
        Ok(self.accept(MoverRequest::Translate { distance_m }))
    }

    /// Drop the goal: the robot comes to rest within the acceleration limits.
    pub fn stop(&mut self) {
        self.goal_id = None;
        self.target = None;
        self.status = MoverStatus::Idle;
        self.distance_to_goal_m = 0.0;
    }

    /// Carries out a request; the goal id for goto, rotate and translate.
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn request(&mut self, request: MoverRequest) -> Result<Option<GoalId>, GoalError> {
        match request {
            MoverRequest::Goto { x_m, y_m } => self.goto(x_m, y_m).map(Some),
            MoverRequest::Rotate { angle_rad } => self.rotate(angle_rad).map(Some),
            MoverRequest::Translate { distance_m } => self.translate(distance_m).map(Some),
            MoverRequest::Stop => {
                self.stop();
                Ok(None)
            }
        }
    }

    /// Carries out a Mover command and builds its reply (headers left empty).
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn handle(&mut self, command: &MoverCommand) -> Result<MoverReply, GoalError> {
        answer_command(command, |request| self.request(request))
    }

    fn accept(&mut self, request: MoverRequest) -> GoalId {
        let id = self.next_id;
        self.next_id = id.next();
        self.goal_id = Some(id);
        self.status = MoverStatus::Moving;
        self.stall_anchor = None;
        self.target = Some(Target::Pending(request));
        if let Some(pose) = self.last_pose.clone() {
            self.resolve(&pose);
        }
        id
    }

    /// Turns a relative request into a target of the odometry frame.
    fn resolve(&mut self, pose: &Pose2D) {
        let Some(Target::Pending(request)) = self.target else {
            return;
        };
        let here = position(pose);
        let (target, goal) = match request {
            MoverRequest::Goto { x_m, y_m } => {
                let goal = Vec2::new(x_m, y_m);
                let bearing = if goal.distance(here) > 0.0 {
                    (goal - here).angle()
                } else {
                    pose.theta
                };
                (
                    Some(Target::Point { goal }),
                    Pose2D {
                        x: x_m,
                        y: y_m,
                        theta: bearing,
                    },
                )
            }
            MoverRequest::Rotate { angle_rad } => (
                Some(Target::Turn {
                    requested_rad: angle_rad,
                    turned_rad: 0.0,
                    last_heading_rad: pose.theta,
                }),
                Pose2D {
                    x: pose.x,
                    y: pose.y,
                    theta: wrap_angle(pose.theta + angle_rad),
                },
            ),
            MoverRequest::Translate { distance_m } => {
                let target = here + Vec2::from_angle(pose.theta) * distance_m;
                (
                    Some(Target::Line {
                        target,
                        heading_rad: pose.theta,
                    }),
                    Pose2D {
                        x: target.x,
                        y: target.y,
                        theta: pose.theta,
                    },
                )
            }
            MoverRequest::Stop => (None, Pose2D::default()),
        };
        self.target = target;
        self.goal = goal;
    }

    /// One control step: the velocities to send now, given the pose in the odometry frame
    /// at `now_ns`. A pose that is not finite fails the goal and commands zero at once.
    pub fn step(&mut self, pose_in_odom: &Pose2D, now_ns: i64) -> VelocityCommand {
        let dt_s = self.step_length_s(now_ns);
        if !pose_is_finite(pose_in_odom) {
            if self.target.is_some() {
                self.status = MoverStatus::Failed;
                self.target = None;
            }
            self.command = VelocityCommand::ZERO;
            self.last_step = None;
            return self.command;
        }
        self.last_pose = Some(pose_in_odom.clone());
        self.resolve(pose_in_odom);
        let desired = self.desired(pose_in_odom);
        self.watch_stall(pose_in_odom, now_ns);
        let desired = if self.target.is_some() {
            desired
        } else {
            VelocityCommand::ZERO
        };
        self.last_step = Some(LastStep {
            pose: pose_in_odom.clone(),
            command_before: self.command,
            dt_s,
            translation_cap_m_s: f64::INFINITY,
        });
        self.command = self.ramp(self.command, desired, dt_s);
        self.command
    }

    /// Does the last step again for the goal given since (a new goal, or none after
    /// `stop`): the velocities to send now, so that the robot reacts to a command at once
    /// rather than at the next step. It takes the pose and the time of that step and ramps
    /// from the command before it, within the same acceleration limits: the answer depends
    /// on the steps and commands so far, not on when it is asked (a replay asks at another
    /// instant than the live run did). A cap on the translation since that step
    /// ([`VectorMover::cap_translation`]) still holds. The next step goes on from it. `None`
    /// before any step, or when the last one had a pose that was not finite.
    pub fn restep(&mut self) -> Option<VelocityCommand> {
        let LastStep {
            pose,
            command_before,
            dt_s,
            translation_cap_m_s,
        } = self.last_step.clone()?;
        self.resolve(&pose);
        let desired = self.desired(&pose);
        if let Some(step_ns) = self.last_step_ns {
            self.watch_stall(&pose, step_ns);
        }
        let desired = if self.target.is_some() {
            desired
        } else {
            VelocityCommand::ZERO
        };
        self.command = self.ramp(command_before, desired, dt_s);
        self.command.translation_m_s = self
            .command
            .translation_m_s
            .clamp(-translation_cap_m_s, translation_cap_m_s);
        Some(self.command)
    }

    fn step_length_s(&mut self, now_ns: i64) -> f64 {
        let step_ns = match self.last_step_ns {
            None => self.config.nominal_step_ns,
            Some(last) => now_ns
                .saturating_sub(last)
                .clamp(0, self.config.max_step_ns),
        };
        self.last_step_ns = Some(now_ns);

        step_ns as f64 / NANOS_PER_SEC
    }

    /// The velocities the law asks for, before the acceleration limits; marks arrival.
    fn desired(&mut self, pose: &Pose2D) -> VelocityCommand {
        let config = &self.config;
        let here = position(pose);
        let (desired, arrived) = match &mut self.target {
            None | Some(Target::Pending(_)) => (VelocityCommand::ZERO, false),
            Some(Target::Point { goal }) => {
                let to_goal = *goal - here;
                let distance = to_goal.norm();
                self.distance_to_goal_m = distance;
                let heading_error = wrap_angle(to_goal.angle() - pose.theta);
                let command = VelocityCommand {
                    translation_m_s: config.drive_speed(distance)
                        * config.drive_factor(heading_error),
                    rotation_rad_s: config.turn_rate(heading_error),
                };
                (command, distance <= config.position_tolerance_m)
            }
            Some(Target::Turn {
                requested_rad,
                turned_rad,
                last_heading_rad,
            }) => {
                *turned_rad += wrap_angle(pose.theta - *last_heading_rad);
                *last_heading_rad = pose.theta;
                let remaining = *requested_rad - *turned_rad;
                self.distance_to_goal_m = 0.0;
                let command = VelocityCommand {
                    translation_m_s: 0.0,
                    rotation_rad_s: config.turn_rate(remaining),
                };
                (command, remaining.abs() <= config.heading_tolerance_rad)
            }
            Some(Target::Line {
                target,
                heading_rad,
            }) => {
                let along = (*target - here).dot(Vec2::from_angle(*heading_rad));
                self.distance_to_goal_m = along.abs();
                let heading_error = wrap_angle(*heading_rad - pose.theta);
                let command = VelocityCommand {
                    translation_m_s: config.drive_speed(along),
                    rotation_rad_s: config.turn_rate(heading_error),
                };
                (command, along.abs() <= config.position_tolerance_m)
            }
        };
        if arrived {
            self.status = MoverStatus::Arrived;
            self.target = None;
        }
        desired
    }

    /// Reports a goal blocked when the robot has not moved for the stall timeout.
    fn watch_stall(&mut self, pose: &Pose2D, now_ns: i64) {
        if self.status != MoverStatus::Moving
            || !matches!(self.target, Some(t) if !matches!(t, Target::Pending(_)))
        {
            self.stall_anchor = None;
            return;
        }
        let Some((anchor, since_ns)) = &self.stall_anchor else {
            self.stall_anchor = Some((pose.clone(), now_ns));
            return;
        };
        let moved = position(pose).distance(position(anchor)) > self.config.stall_motion_m
            || wrap_angle(pose.theta - anchor.theta).abs() > self.config.stall_motion_m;
        if moved {
            self.stall_anchor = Some((pose.clone(), now_ns));
        } else if now_ns.saturating_sub(*since_ns) >= self.config.stall_timeout_ns {
            self.status = MoverStatus::Blocked;
            self.target = None;
        }
    }

    fn ramp(&self, from: VelocityCommand, desired: VelocityCommand, dt_s: f64) -> VelocityCommand {
        let limit = |last: f64, want: f64, accel: f64, max: f64| {
            let step = accel * dt_s;
            (last + (want - last).clamp(-step, step)).clamp(-max, max)
        };
        VelocityCommand {
            translation_m_s: limit(
                from.translation_m_s,
                desired.translation_m_s,
                self.config.translation_accel_m_s2,
                self.config.max_translation_m_s,
            ),
            rotation_rad_s: limit(
                from.rotation_rad_s,
                desired.rotation_rad_s,
                self.config.rotation_accel_rad_s2,
                self.config.max_rotation_rad_s,
            ),
        }
    }

    /// Lowers the translational speed of the last command to at most `max_abs_m_s` (for a
    /// supervisor that knows the free distance ahead, such as ObstacleAvoider); the next
    /// step ramps on from the lowered value.
    pub fn cap_translation(&mut self, max_abs_m_s: f64) -> VelocityCommand {
        let cap = if max_abs_m_s.is_nan() {
            0.0
        } else {
            max_abs_m_s.max(0.0)
        };
        if let Some(last) = &mut self.last_step {
            last.translation_cap_m_s = last.translation_cap_m_s.min(cap);
        }
        self.command.translation_m_s = self.command.translation_m_s.clamp(-cap, cap);
        self.command
    }

    /// The status to publish.
    #[must_use]
    pub fn status(&self) -> MoverStatus {
        self.status
    }

    /// The goal being pursued (or just ended), `None` after `stop` or before any goal.
    #[must_use]
    pub fn goal_id(&self) -> Option<GoalId> {
        self.goal_id
    }

    /// The goal in the odometry frame: for goto the point and the bearing from where it was
    /// accepted, for rotate the place and the final heading, for translate the end point and
    /// the heading held. `None` until the first pose resolves a relative goal.
    #[must_use]
    pub fn goal(&self) -> Option<Pose2D> {
        match self.target {
            Some(Target::Pending(_)) => None,
            _ => self.goal_id.map(|_| self.goal.clone()),
        }
    }

    /// The velocities last commanded.
    #[must_use]
    pub fn last_command(&self) -> VelocityCommand {
        self.command
    }

    /// Distance still to go at the last step (0 for rotate), in m.
    #[must_use]
    pub fn distance_to_goal_m(&self) -> f64 {
        self.distance_to_goal_m
    }

    /// The Mover publication (header left empty for the runtime to fill). The waypoint of a
    /// VectorMover is the goal's position.
    #[must_use]
    pub fn publication(&self) -> Mover {
        let goal = self.goal().unwrap_or_default();
        Mover {
            goal_id: self.goal_id.map_or(0, GoalId::get),
            status: self.status.into(),
            distance_to_goal: self.distance_to_goal_m,
            translation_velocity: self.command.translation_m_s,
            rotation_velocity: self.command.rotation_rad_s,
            waypoint: Point2D {
                x: goal.x,
                y: goal.y,
            },
            goal,
            ..Default::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mover() -> VectorMover {
        VectorMover::new(VectorMoverConfig::default()).unwrap()
    }

    #[test]
    fn invalid_configuration_names_the_field() {
        let config = VectorMoverConfig {
            max_translation_m_s: -1.0,
            ..VectorMoverConfig::default()
        };
        let err = VectorMover::new(config).unwrap_err();
        assert_eq!(err.field, "max_translation_m_s");
    }

    #[test]
    fn non_finite_goals_are_refused_and_the_goal_is_kept() {
        let mut m = mover();
        let id = m.goto(1.0, 0.0).unwrap();
        assert!(matches!(
            m.goto(f64::NAN, 0.0),
            Err(GoalError::NotFinite {
                command: "goto",
                arg: "x",
                ..
            })
        ));
        assert!(matches!(
            m.rotate(f64::INFINITY),
            Err(GoalError::NotFinite { arg: "angle", .. })
        ));
        assert_eq!(m.goal_id(), Some(id));
    }

    #[test]
    fn a_goal_before_any_pose_is_resolved_at_the_first_step() {
        let mut m = mover();
        m.translate(1.0).unwrap();
        assert_eq!(m.goal(), None);
        m.step(
            &Pose2D {
                x: 1.0,
                y: 1.0,
                theta: std::f64::consts::FRAC_PI_2,
            },
            0,
        );
        let goal = m.goal().unwrap();
        assert!((goal.x - 1.0).abs() < 1e-12 && (goal.y - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_pose_that_is_not_finite_fails_the_goal_and_stops_at_once() {
        let mut m = mover();
        m.goto(5.0, 0.0).unwrap();
        for i in 0..10 {
            m.step(&Pose2D::default(), i * 100_000_000);
        }
        assert!(m.last_command().translation_m_s > 0.0);
        let command = m.step(
            &Pose2D {
                x: f64::NAN,
                ..Pose2D::default()
            },
            1_000_000_000,
        );
        assert_eq!(command, VelocityCommand::ZERO);
        assert_eq!(m.status(), MoverStatus::Failed);
    }

    #[test]
    fn a_robot_that_does_not_move_is_reported_blocked() {
        let mut m = mover();
        m.goto(5.0, 0.0).unwrap();
        let mut now = 0;
        while now < 4_000_000_000 {
            m.step(&Pose2D::default(), now);
            now += 100_000_000;
        }
        assert_eq!(m.status(), MoverStatus::Blocked);
        assert_eq!(m.publication().status, "blocked");
    }
}
