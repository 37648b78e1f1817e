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
    pub(crate) fn to_f32(self) -> [f32; 2] {
        [self.x as f32, self.y as f32]
    }
}

/// Where a frame B lies in a frame A: a point `p` of B is at `R p + t` in A, `R` the
/// rotation by `turn_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placement {
    /// `t`, metres.
    pub translation: Point,
    /// The angle of `R`.
    pub turn_rad: f64,
}

impl Placement {
    /// The placement of B in A from one pose of the robot in each (`in_a`, `in_b`, taken
    /// at the same moment); `None` when a pose is not finite.
    pub(crate) fn between(in_a: &Pose2D, in_b: &Pose2D) -> Option<Self> {
        let finite = [in_a.x, in_a.y, in_a.theta, in_b.x, in_b.y, in_b.theta]
            .iter()
            .all(|v| v.is_finite());
        if !finite {
            return None;
        }
        let turn_rad = in_a.theta - in_b.theta;
        let (sin, cos) = turn_rad.sin_cos();
        let translation = Point::new(
            in_a.x - (cos * in_b.x - sin * in_b.y),
            in_a.y - (sin * in_b.x + cos * in_b.y),
        );
        Some(Self {
            translation,
            turn_rad,
        })
    }

    /// A point of B, in A: what [`Self::to_transform`] does in the viewer.
    #[cfg(test)]
    pub(crate) fn apply(self, p: Point) -> Point {
        let (sin, cos) = self.turn_rad.sin_cos();
        Point::new(
            self.translation.x + cos * p.x - sin * p.y,
            self.translation.y + sin * p.x + cos * p.y,
        )
    }

    /// As a Rerun transform of the entity that holds B's data.
    pub(crate) fn to_transform(self) -> rerun::Transform3D {
        rerun::Transform3D::from_translation_rotation(
            [self.translation.x as f32, self.translation.y as f32, 0.0],
            rerun::RotationAxisAngle::new(
                [0.0, 0.0, 1.0],
                rerun::Angle::from_radians(self.turn_rad as f32),
            ),
        )
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

    #[test]
    fn a_placement_maps_the_pose_in_b_onto_the_pose_in_a() {
        let in_a = Pose2D {
            x: 3.0,
            y: 12.5,
            theta: std::f64::consts::FRAC_PI_2,
        };
        let in_b = Pose2D {
            x: 1.0,
            y: 0.0,
            theta: 0.0,
        };
        let placement = Placement::between(&in_a, &in_b).unwrap();
        let at = placement.apply(Point::new(in_b.x, in_b.y));
        assert!(
            (at.x - 3.0).abs() < 1e-12 && (at.y - 12.5).abs() < 1e-12,
            "{at:?}"
        );
        // One metre ahead in B is one metre ahead of the robot in A too (north here).
        let ahead = placement.apply(Point::new(2.0, 0.0));
        assert!(
            (ahead.x - 3.0).abs() < 1e-12 && (ahead.y - 13.5).abs() < 1e-12,
            "{ahead:?}"
        );
        let broken = Pose2D {
            x: f64::NAN,
            ..in_b
        };
        assert_eq!(Placement::between(&in_a, &broken), None);
    }
}
