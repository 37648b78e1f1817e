//! Points in the plane and the robot-to-world transform.

use lewis_interfaces::msg::Pose2D;

/// A point in metres (or pixels, for images).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Point {
    pub x: f64,
    pub y: f64,
}

impl Point {
    pub(crate) fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    pub(crate) fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    pub(crate) fn distance(self, other: Self) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// The point at `range` along `bearing_rad` from this one.
    pub(crate) fn along(self, bearing_rad: f64, range: f64) -> Self {
        Self::new(
            self.x + range * bearing_rad.cos(),
            self.y + range * bearing_rad.sin(),
        )
    }

    /// This point, given in the frame of `pose`, in the frame `pose` is given in.
    pub(crate) fn placed(self, pose: &Pose2D) -> Self {
        let (sin, cos) = pose.theta.sin_cos();
        Self::new(
            pose.x + cos * self.x - sin * self.y,
            pose.y + sin * self.x + cos * self.y,
        )
    }

    /// Rerun stores single-precision positions.
    #[allow(clippy::cast_possible_truncation)]
    pub(crate) fn to_f32(self) -> [f32; 2] {
        [self.x as f32, self.y as f32]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(point: Point, pose: &Pose2D, expected: Point) {
        let got = point.placed(pose);
        assert!(
            got.distance(expected) < 1e-12,
            "{point:?} placed with {pose:?}: got {got:?}, expected {expected:?}"
        );
    }

    #[test]
    fn placing_a_point_rotates_then_translates() {
        let pose = |x, y, theta| Pose2D { x, y, theta };
        check(
            Point::new(1.0, 0.0),
            &pose(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0),
        );
        check(
            Point::new(1.0, 0.0),
            &pose(2.0, 3.0, std::f64::consts::FRAC_PI_2),
            Point::new(2.0, 4.0),
        );
        check(
            Point::new(0.0, 1.0),
            &pose(-1.0, 0.0, std::f64::consts::PI),
            Point::new(-1.0, -1.0),
        );
    }
}
