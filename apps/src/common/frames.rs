//! The robot frame and the odometry frame: goals go to the Mover in the odometry frame,
//! sensors see in the robot frame.

use lewis_geometry::{Pose2, Vec2, wrap_angle};
use lewis_interfaces::msg::Pose2D;

/// The robot's latest pose in the odometry frame (from Egomotion).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Odometry {
    pose: Option<Pose2>,
}

impl Odometry {
    /// Takes an Egomotion pose.
    pub fn update(&mut self, pose: &Pose2D) {
        let pose = Pose2::from_msg(pose);
        if pose.x_m.is_finite() && pose.y_m.is_finite() && pose.heading_rad.is_finite() {
            self.pose = Some(pose);
        }
    }

    /// The robot's pose, once a sample came.
    #[must_use]
    pub fn pose(&self) -> Option<Pose2> {
        self.pose
    }

    /// A point of the robot frame in the odometry frame.
    #[must_use]
    pub fn to_odom(&self, local: Vec2) -> Option<Vec2> {
        self.pose.map(|p| p.transform_point(local))
    }

    /// A point of the odometry frame in the robot frame.
    #[must_use]
    pub fn to_robot(&self, point: Vec2) -> Option<Vec2> {
        self.pose.map(|p| to_robot(p, point))
    }

    /// The bearing of an odometry point from the robot, in rad.
    #[must_use]
    pub fn bearing_to(&self, point: Vec2) -> Option<f64> {
        self.to_robot(point).map(Vec2::angle)
    }
}

/// `point` (in the frame `pose` is given in) in the frame of a robot at `pose`.
#[must_use]
pub fn to_robot(pose: Pose2, point: Vec2) -> Vec2 {
    (point - pose.position()).rotated(-pose.heading_rad)
}

/// The heading difference `to - from`, in (-pi, pi].
#[must_use]
pub fn turn(from_rad: f64, to_rad: f64) -> f64 {
    wrap_angle(to_rad - from_rad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_go_between_the_robot_and_the_odometry_frames() {
        let mut odometry = Odometry::default();
        assert_eq!(odometry.to_odom(Vec2::new(1.0, 0.0)), None);
        odometry.update(&Pose2D {
            x: 1.0,
            y: 2.0,
            theta: std::f64::consts::FRAC_PI_2,
        });
        let ahead = odometry.to_odom(Vec2::new(1.0, 0.0)).unwrap();
        assert!(ahead.distance(Vec2::new(1.0, 3.0)) < 1e-9, "{ahead:?}");
        let back = odometry.to_robot(ahead).unwrap();
        assert!(back.distance(Vec2::new(1.0, 0.0)) < 1e-9, "{back:?}");
        let left = odometry.bearing_to(Vec2::new(0.0, 2.0)).unwrap();
        assert!((left - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{left}");
    }
}
