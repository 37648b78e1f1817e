//! Where sensors sit on the robot: [`SensorMount`], and the B21r's sonar ring.

use std::f64::consts::TAU;

use lewis_interfaces::msg::Pose3D;

use crate::{Pose2, Vec2};

/// Where a sensor sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorMount {
    /// Position and heading in the robot frame.
    pub pose: Pose2,
    /// Height above the floor, in m.
    pub height_m: f64,
}

impl SensorMount {
    /// As the interface's Pose3D (no pitch, no roll).
    #[must_use]
    pub fn to_pose3d(self) -> Pose3D {
        Pose3D {
            x: self.pose.x_m,
            y: self.pose.y_m,
            z: self.height_m,
            theta: self.pose.heading_rad,
            phi: 0.0,
            psi: 0.0,
        }
    }
}

/// Transducers per ring on the B21r.
pub const B21R_RING_SIZE: usize = 24;
/// Transducers per RFlex sonar bank: the RFlex numbers a sonar `bank * 16 + k`.
pub const RFLEX_BANK_SIZE: usize = 16;

/// The B21r's 48 sonars: 24 around the enclosure (indices 0 to 23) and 24 around the base
/// (24 to 47), 15 degrees apart, index 0 and 24 facing straight ahead and the others
/// counter-clockwise. RFlex index `bank * 16 + k` is the same number, so bank 0 is the first
/// 16 enclosure sonars. The heights and the numbering direction are unverified against a
/// real robot: they are plausible, and a parameter.
#[must_use]
pub fn b21r_sonar_ring() -> Vec<SensorMount> {
    const RADIUS_M: f64 = 0.26;
    let ring = |height_m: f64| {
        (0..B21R_RING_SIZE).map(move |j| {
            let angle = TAU * j as f64 / B21R_RING_SIZE as f64;
            let at = Vec2::from_angle(angle) * RADIUS_M;
            SensorMount {
                pose: Pose2::new(at.x, at.y, angle),
                height_m,
            }
        })
    };
    ring(0.62).chain(ring(0.30)).collect()
}
