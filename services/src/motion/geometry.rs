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

    /// Whether the length is at most `radius_m`: the same answer as `self.norm() <=
    /// radius_m`, without the cost of `hypot` unless the length is within a relative 1e-9 of
    /// the radius. The squared length is off by a few ulps at most, far inside that band,
    /// so outside it the comparison cannot go the other way; inside it, and where squares
    /// would overflow or underflow, `hypot` decides.
    #[must_use]
    pub fn norm_at_most(self, radius_m: f64) -> bool {
        match self.compare_norm(radius_m) {
            Some(ordering) => ordering.is_le(),
            None => self.norm() <= radius_m,
        }
    }

    /// Whether the length is less than `radius_m`: the same answer as `self.norm() <
    /// radius_m` (see [`Self::norm_at_most`]).
    #[must_use]
    pub fn norm_below(self, radius_m: f64) -> bool {
        match self.compare_norm(radius_m) {
            Some(ordering) => ordering.is_lt(),
            None => self.norm() < radius_m,
        }
    }

    /// The length against `radius_m` from squares, when they settle it.
    fn compare_norm(self, radius_m: f64) -> Option<std::cmp::Ordering> {
        const BAND: f64 = 1e-9;
        let squared = self.x * self.x + self.y * self.y;
        let radius_squared = radius_m * radius_m;
        if !radius_squared.is_normal() || !squared.is_finite() || radius_m < 0.0 {
            return None;
        }
        if squared < radius_squared * (1.0 - BAND) {
            Some(std::cmp::Ordering::Less)
        } else if squared > radius_squared * (1.0 + BAND) {
            Some(std::cmp::Ordering::Greater)
        } else {
            None
        }
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
    fn norm_comparisons_agree_with_hypot() {
        let radii = [
            0.0,
            1e-300,
            0.28,
            0.38,
            1.0,
            3.0,
            1e200,
            f64::INFINITY,
            -1.0,
        ];
        let mut rng = lewis_runtime::service::Rng::new(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.uniform(-1.0, 1.0);
        for &radius in &radii {
            for _ in 0..20_000 {
                let scale = if radius.is_finite() && radius > 0.0 {
                    radius
                } else {
                    1.0
                };
                let v = Vec2::new(next() * scale, next() * scale);
                assert_eq!(v.norm_at_most(radius), v.norm() <= radius, "{v:?} {radius}");
                assert_eq!(v.norm_below(radius), v.norm() < radius, "{v:?} {radius}");
            }
            // On the radius itself and one ulp either side of it.
            for v in [
                Vec2::new(radius, 0.0),
                Vec2::new(0.0, -radius),
                Vec2::new(radius * 0.6, radius * 0.8),
                Vec2::new(f64::from_bits(radius.to_bits() + 1), 0.0),
                Vec2::new(f64::from_bits(radius.to_bits().saturating_sub(1)), 0.0),
                Vec2::new(f64::NAN, 0.0),
                Vec2::new(f64::INFINITY, 1.0),
            ] {
                assert_eq!(v.norm_at_most(radius), v.norm() <= radius, "{v:?} {radius}");
                assert_eq!(v.norm_below(radius), v.norm() < radius, "{v:?} {radius}");
            }
        }
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
