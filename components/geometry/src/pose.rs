//! Poses in the plane: [`Pose2`], and the change of frame for the interface's `Pose2D`.

use lewis_interfaces::msg::Pose2D;

use crate::{Vec2, wrap_angle};

/// A position and heading in the plane (x forward, y left, heading counter-clockwise).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// x, in m.
    pub x_m: f64,
    /// y, in m.
    pub y_m: f64,
    /// Heading, in rad, counter-clockwise from the x axis.
    pub heading_rad: f64,
}

impl Pose2 {
    /// The pose (x, y, heading).
    #[must_use]
    pub const fn new(x_m: f64, y_m: f64, heading_rad: f64) -> Self {
        Self {
            x_m,
            y_m,
            heading_rad,
        }
    }

    /// Its position.
    #[must_use]
    pub fn position(self) -> Vec2 {
        Vec2::new(self.x_m, self.y_m)
    }

    /// A point given in this pose's frame, in the parent frame.
    #[must_use]
    pub fn transform_point(self, local: Vec2) -> Vec2 {
        self.position() + local.rotated(self.heading_rad)
    }

    /// A pose given in this pose's frame (a sensor on the robot), in the parent frame.
    #[must_use]
    pub fn compose(self, local: Self) -> Self {
        let p = self.transform_point(local.position());
        Self::new(p.x, p.y, wrap_angle(self.heading_rad + local.heading_rad))
    }

    /// The interface type.
    #[must_use]
    pub fn to_msg(self) -> Pose2D {
        Pose2D {
            x: self.x_m,
            y: self.y_m,
            theta: self.heading_rad,
        }
    }

    /// From the interface type.
    #[must_use]
    pub fn from_msg(pose: &Pose2D) -> Self {
        Self::new(pose.x, pose.y, pose.theta)
    }
}

/// The position of a pose as a vector.
#[must_use]
pub fn position(pose: &Pose2D) -> Vec2 {
    Vec2::new(pose.x, pose.y)
}

/// All three fields of the pose are finite.
#[must_use]
pub fn pose_is_finite(pose: &Pose2D) -> bool {
    pose.x.is_finite() && pose.y.is_finite() && pose.theta.is_finite()
}

/// A point of the robot frame expressed in the odometry frame, the robot being at
/// `robot_in_odom`.
#[must_use]
pub fn robot_to_odom(robot_in_odom: &Pose2D, point_in_robot: Vec2) -> Vec2 {
    RobotToOdom::new(robot_in_odom).apply(point_in_robot)
}

/// [`robot_to_odom`] at one pose, for the many points of one reading: the heading's sine and
/// cosine are computed once rather than once a point (the same bits as `robot_to_odom`).
#[derive(Debug, Clone, Copy)]
pub struct RobotToOdom {
    origin: Vec2,
    sin: f64,
    cos: f64,
}

impl RobotToOdom {
    /// The transform with the robot at `robot_in_odom`.
    #[must_use]
    pub fn new(robot_in_odom: &Pose2D) -> Self {
        let (sin, cos) = robot_in_odom.theta.sin_cos();
        Self {
            origin: position(robot_in_odom),
            sin,
            cos,
        }
    }

    /// A point of the robot frame in the odometry frame.
    #[inline]
    #[must_use]
    pub fn apply(&self, point_in_robot: Vec2) -> Vec2 {
        self.origin + point_in_robot.rotated_by(self.sin, self.cos)
    }
}

/// A point of the odometry frame expressed in the robot frame, the robot being at
/// `robot_in_odom`.
#[must_use]
pub fn odom_to_robot(robot_in_odom: &Pose2D, point_in_odom: Vec2) -> Vec2 {
    (point_in_odom - position(robot_in_odom)).rotated(-robot_in_odom.theta)
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    #[test]
    fn composing_poses_places_a_sensor_on_a_turned_robot() {
        let robot = Pose2::new(1.0, 2.0, PI / 2.0);
        let sensor = robot.compose(Pose2::new(0.5, 0.0, 0.0));
        assert!((sensor.x_m - 1.0).abs() < 1e-12 && (sensor.y_m - 2.5).abs() < 1e-12);
    }

    #[test]
    fn frames_round_trip() {
        let pose = Pose2D {
            x: 1.0,
            y: -2.0,
            theta: 0.7,
        };
        let p = Vec2::new(0.3, 0.4);
        let back = odom_to_robot(&pose, robot_to_odom(&pose, p));
        assert!(back.distance(p) < 1e-12);
        let ahead = robot_to_odom(
            &Pose2D {
                x: 1.0,
                y: 1.0,
                theta: PI / 2.0,
            },
            Vec2::new(1.0, 0.0),
        );
        assert!(ahead.distance(Vec2::new(1.0, 2.0)) < 1e-12);
    }
}
