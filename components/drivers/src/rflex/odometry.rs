//! Dead reckoning from the odometry reports: the encoder counts of the translation axis give
//! the distance, those of the rotation axis the bearing.

use lewis_geometry::{Pose2, wrap_angle};

use super::{Axis, OdometryReport};

/// Encoder units per metre and per radian: the robot file's conversion factors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryConversion {
    /// Translation units per metre (B21r: 103000).
    pub distance_units_per_m: f64,
    /// Rotation units per radian (B21r: 35000).
    pub angle_units_per_rad: f64,
}

impl OdometryConversion {
    /// The B21r's factors (PROTOCOLS.md).
    pub const B21R: Self = Self {
        distance_units_per_m: 103_000.0,
        angle_units_per_rad: 35_000.0,
    };

    /// The factor of one axis.
    pub fn units_per(&self, axis: Axis) -> f64 {
        match axis {
            Axis::Translation => self.distance_units_per_m,
            Axis::Rotation => self.angle_units_per_rad,
        }
    }
}

impl Default for OdometryConversion {
    fn default() -> Self {
        Self::B21R
    }
}

/// Integrates odometry reports into a pose in the frame where the first reports arrived.
#[derive(Debug, Clone)]
pub struct OdometryIntegrator {
    conversion: OdometryConversion,
    last_distance: Option<i32>,
    last_bearing: Option<i32>,
    pose: Pose2,
    translation_velocity_mps: f64,
    rotation_velocity_radps: f64,
}

impl OdometryIntegrator {
    /// An integrator at the origin that takes the first report of each axis as its reference.
    pub fn new(conversion: OdometryConversion) -> Self {
        Self {
            conversion,
            last_distance: None,
            last_bearing: None,
            pose: Pose2::default(),
            translation_velocity_mps: 0.0,
            rotation_velocity_radps: 0.0,
        }
    }

    /// Takes one report: a rotation report turns the heading, a translation report moves
    /// along it (`theta += d_bearing / angle_conv; d = d_distance / dist_conv;
    /// x += d cos theta; y += d sin theta`). Counts that wrap around are handled.
    pub fn update(&mut self, report: &OdometryReport) -> Pose2 {
        let factor = self.conversion.units_per(report.axis);
        let velocity = f64::from(report.velocity) / factor;
        let last = match report.axis {
            Axis::Translation => {
                self.translation_velocity_mps = velocity;
                &mut self.last_distance
            }
            Axis::Rotation => {
                self.rotation_velocity_radps = velocity;
                &mut self.last_bearing
            }
        };
        let delta = last.map_or(0, |previous| report.position.wrapping_sub(previous));
        *last = Some(report.position);
        let change = f64::from(delta) / factor;
        match report.axis {
            Axis::Rotation => {
                self.pose.heading_rad = wrap_angle(self.pose.heading_rad + change);
            }
            Axis::Translation => {
                self.pose.x_m += change * self.pose.heading_rad.cos();
                self.pose.y_m += change * self.pose.heading_rad.sin();
            }
        }
        self.pose
    }

    /// The pose so far.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// The last reported translational velocity.
    pub fn translation_velocity_mps(&self) -> f64 {
        self.translation_velocity_mps
    }

    /// The last reported rotational velocity.
    pub fn rotation_velocity_radps(&self) -> f64 {
        self.rotation_velocity_radps
    }

    /// Whether both axes have reported (before that the pose cannot move).
    pub fn is_referenced(&self) -> bool {
        self.last_distance.is_some() && self.last_bearing.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(axis: Axis, position: i32) -> OdometryReport {
        OdometryReport {
            word0: 0,
            timestamp: 0,
            axis,
            position,
            velocity: 0,
            acceleration: 0,
            torque: 0,
        }
    }

    #[test]
    fn a_straight_line_along_x_integrates_to_its_length() {
        let mut odometry = OdometryIntegrator::new(OdometryConversion::B21R);
        odometry.update(&report(Axis::Rotation, 500));
        odometry.update(&report(Axis::Translation, 1_000));
        for step in 1..=10 {
            odometry.update(&report(Axis::Translation, 1_000 + step * 10_300));
        }
        let pose = odometry.pose();
        assert!((pose.x_m - 1.0).abs() < 1e-12, "{pose:?}");
        assert!(pose.y_m.abs() < 1e-12);
        assert_eq!(pose.heading_rad, 0.0);
    }

    #[test]
    fn a_quarter_turn_then_a_metre_ends_on_the_y_axis() {
        let mut odometry = OdometryIntegrator::new(OdometryConversion::B21R);
        odometry.update(&report(Axis::Rotation, 0));
        odometry.update(&report(Axis::Translation, 0));
        let quarter = (35_000.0 * std::f64::consts::FRAC_PI_2).round() as i32;
        odometry.update(&report(Axis::Rotation, quarter));
        odometry.update(&report(Axis::Translation, 103_000));
        let pose = odometry.pose();
        assert!(pose.x_m.abs() < 1e-4, "{pose:?}");
        assert!((pose.y_m - 1.0).abs() < 1e-9);
        assert!((pose.heading_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-4);
    }

    #[test]
    fn counts_wrapping_around_give_a_small_step() {
        let mut odometry = OdometryIntegrator::new(OdometryConversion::B21R);
        odometry.update(&report(Axis::Rotation, i32::MIN + 10));
        odometry.update(&report(Axis::Translation, i32::MAX - 50_000));
        odometry.update(&report(Axis::Translation, i32::MIN + 52_999));
        assert!((odometry.pose().x_m - 1.0).abs() < 1e-12);
        odometry.update(&report(Axis::Rotation, i32::MAX - 9));
        assert!((odometry.pose().heading_rad + 20.0 / 35_000.0).abs() < 1e-12);
    }
}
