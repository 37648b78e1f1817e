//! Plane geometry for the motion services: a small vector type, angle wrapping and the
//! change of frame between the robot and the odometry frame.

use lewis_interfaces::msg::{Point2D, Pose2D};
use std::f64::consts::PI;
use std::ops::{Add, Mul, Sub};

/// A vector (or point) in a plane, in metres.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vec2 {
    /// Along x, in m.
    pub x: f64,
    /// Along y, in m.
    pub y: f64,
}

impl Vec2 {
    /// The vector with these components.
    #[must_use]
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// The unit vector pointing along `angle_rad`.
    #[must_use]
    pub fn from_angle(angle_rad: f64) -> Self {
        Self::new(angle_rad.cos(), angle_rad.sin())
    }

    /// Euclidean length.
    #[must_use]
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Dot product.
    #[must_use]
    pub fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// The z component of the cross product: positive when `other` is counter-clockwise.
    #[must_use]
    pub fn cross(self, other: Self) -> f64 {
        self.x * other.y - self.y * other.x
    }

    /// The direction of the vector, in rad.
    #[must_use]
    pub fn angle(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// Distance to another point.
    #[must_use]
    pub fn distance(self, other: Self) -> f64 {
        (self - other).norm()
    }

    /// Both components are finite.
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The vector rotated counter-clockwise by `angle_rad`.
    #[must_use]
    pub fn rotated(self, angle_rad: f64) -> Self {
        let (s, c) = angle_rad.sin_cos();
        Self::new(c * self.x - s * self.y, s * self.x + c * self.y)
    }
}

impl Add for Vec2 {
    type Output = Self;
    fn add(self, rhs: Self) -> Self {
        Self::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl Sub for Vec2 {
    type Output = Self;
    fn sub(self, rhs: Self) -> Self {
        Self::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl Mul<f64> for Vec2 {
    type Output = Self;
    fn mul(self, rhs: f64) -> Self {
        Self::new(self.x * rhs, self.y * rhs)
    }
}

impl From<Point2D> for Vec2 {
    fn from(p: Point2D) -> Self {
        Self::new(p.x, p.y)
    }
}

impl From<Vec2> for Point2D {
    fn from(v: Vec2) -> Self {
        Self { x: v.x, y: v.y }
    }
}

/// The angle wrapped into (-pi, pi].
#[must_use]
pub fn wrap_angle(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let wrapped = (angle_rad + PI).rem_euclid(2.0 * PI) - PI;
    if wrapped <= -PI {
        wrapped + 2.0 * PI
    } else {
        wrapped
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
    position(robot_in_odom) + point_in_robot.rotated(robot_in_odom.theta)
}

/// A point of the odometry frame expressed in the robot frame, the robot being at
/// `robot_in_odom`.
#[must_use]
pub fn odom_to_robot(robot_in_odom: &Pose2D, point_in_odom: Vec2) -> Vec2 {
    (point_in_odom - position(robot_in_odom)).rotated(-robot_in_odom.theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_wrap(angle_rad: f64, expected_rad: f64) {
        let got = wrap_angle(angle_rad);
        assert!(
            (got - expected_rad).abs() < 1e-12,
            "wrap_angle({angle_rad}) = {got}, expected {expected_rad}"
        );
    }

    #[test]
    fn angles_wrap_into_the_half_open_interval() {
        check_wrap(0.0, 0.0);
        check_wrap(PI, PI);
        check_wrap(-PI, PI);
        check_wrap(3.0 * PI / 2.0, -PI / 2.0);
        check_wrap(-5.0 * PI / 2.0, -PI / 2.0);
        check_wrap(7.0, 7.0 - 2.0 * PI);
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
