//! An ObstacleAvoider that drives its own VectorMover: the avoider's requests go to the
//! mover, and the mover's velocities are governed by the free distance along the motion,
//! so the robot can always brake before an obstacle even between waypoint updates.

use super::mover::{ConfigError, GoalError, GoalId, MoverRequest, MoverStatus, VelocityCommand};
use super::obstacle_avoider::{ObserveError, ObstacleAvoider, ObstacleAvoiderConfig};
use super::vector_mover::{VectorMover, VectorMoverConfig};
use lewis_interfaces::msg::{Distance, Mover, MoverCommand, MoverReply, Pose2D, RangeFinder};
use std::f64::consts::PI;

/// ObstacleAvoider and the VectorMover it moves through, in one process.
#[derive(Debug, Clone)]
pub struct AvoiderDrive {
    avoider: ObstacleAvoider,
    mover: VectorMover,
}

impl AvoiderDrive {
    /// A drive with no goal.
    ///
    /// # Errors
    /// A configuration value out of range, or an avoider tolerance tighter than the
    /// mover's (the avoider would wait for an arrival the mover never makes).
    pub fn new(
        avoider: ObstacleAvoiderConfig,
        mover: VectorMoverConfig,
    ) -> Result<Self, ConfigError> {
        if avoider.position_tolerance_m < mover.position_tolerance_m {
            return Err(ConfigError {
                field: "position_tolerance_m",
                value: avoider.position_tolerance_m,
                expected: "the avoider's tolerance no less than the VectorMover's",
            });
        }
        if avoider.heading_tolerance_rad < mover.heading_tolerance_rad {
            return Err(ConfigError {
                field: "heading_tolerance_rad",
                value: avoider.heading_tolerance_rad,
                expected: "the avoider's tolerance no less than the VectorMover's",
            });
        }
        Ok(Self {
            avoider: ObstacleAvoider::new(avoider)?,
            mover: VectorMover::new(mover)?,
        })
    }

    /// Go to a point of the odometry frame, around obstacles.
    ///
    /// # Errors
    /// A coordinate is not finite.
    pub fn goto(&mut self, x_m: f64, y_m: f64) -> Result<GoalId, GoalError> {
        self.avoider.goto(x_m, y_m)
    }

    /// Turn in place by `angle_rad`.
    ///
    /// # Errors
    /// The angle is not finite.
    pub fn rotate(&mut self, angle_rad: f64) -> Result<GoalId, GoalError> {
        self.avoider.rotate(angle_rad)
    }

    /// Drive straight, stopping when the line is obstructed.
    ///
    /// # Errors
    /// The distance is not finite.
    pub fn translate(&mut self, distance_m: f64) -> Result<GoalId, GoalError> {
        self.avoider.translate(distance_m)
    }

    /// Drop the goal and come to rest.
    pub fn stop(&mut self) {
        self.avoider.stop();
    }

    /// Carries out a Mover command and builds its reply.
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn handle(&mut self, command: &MoverCommand) -> Result<MoverReply, GoalError> {
        self.avoider.handle(command)
    }

    /// See [`ObstacleAvoider::observe_range_finder`].
    ///
    /// # Errors
    /// The reading is malformed or the pose is not finite.
    pub fn observe_range_finder(
        &mut self,
        reading: &RangeFinder,
        pose_in_odom: &Pose2D,
        stamp_ns: i64,
    ) -> Result<(), ObserveError> {
        self.avoider
            .observe_range_finder(reading, pose_in_odom, stamp_ns)
    }

    /// See [`ObstacleAvoider::observe_distance`].
    ///
    /// # Errors
    /// The reading is malformed or the pose is not finite.
    pub fn observe_distance(
        &mut self,
        reading: &Distance,
        pose_in_odom: &Pose2D,
        stamp_ns: i64,
    ) -> Result<(), ObserveError> {
        self.avoider
            .observe_distance(reading, pose_in_odom, stamp_ns)
    }

    /// One control step: the velocities for the synchro-drive.
    pub fn step(&mut self, pose_in_odom: &Pose2D, now_ns: i64) -> VelocityCommand {
        let out = self.avoider.step(pose_in_odom, now_ns);
        if let Some(request) = out.request
            && self.mover.request(request).is_err()
        {
            // The avoider only asks for finite goals; should one slip through, rest.
            self.mover.stop();
        }
        let command = self.mover.step(pose_in_odom, now_ns);
        if self.avoider.status() == MoverStatus::Moving
            && self.mover.status() != MoverStatus::Moving
        {
            // The mover gave up on (or finished) the last waypoint while the avoider goes on.
            self.avoider.resend();
        }
        if command.translation_m_s == 0.0 {
            return command;
        }
        let motion_rad = if command.translation_m_s > 0.0 {
            pose_in_odom.theta
        } else {
            pose_in_odom.theta + PI
        };
        let config = self.avoider.config();
        let governor_radius_m = config.robot_radius_m + config.clearance_m / 2.0;
        let free_m = self
            .avoider
            .free_distance_m(pose_in_odom, motion_rad, governor_radius_m);
        let braking_speed =
            (2.0 * self.mover.config().translation_accel_m_s2 * free_m.max(0.0)).sqrt();
        self.mover.cap_translation(braking_speed)
    }

    /// The status to publish (the avoider's).
    #[must_use]
    pub fn status(&self) -> MoverStatus {
        self.avoider.status()
    }

    /// The Mover publication: the avoider's goal and status, the mover's velocities.
    #[must_use]
    pub fn publication(&self) -> Mover {
        self.avoider.publication(self.mover.last_command())
    }

    /// The avoider, for its waypoint, hold reason and obstacles.
    #[must_use]
    pub fn avoider(&self) -> &ObstacleAvoider {
        &self.avoider
    }

    /// The VectorMover it drives through.
    #[must_use]
    pub fn mover(&self) -> &VectorMover {
        &self.mover
    }

    /// Carries out a request (the same as the Mover commands).
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn request(&mut self, request: MoverRequest) -> Result<Option<GoalId>, GoalError> {
        self.avoider.request(request)
    }
}
