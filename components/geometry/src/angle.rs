//! The one angle convention: angles are wrapped into [-pi, pi).
//!
//! It is the simulator's, kept for all: its poses and every Distance's `min_bearing` have been
//! published in it since the first recordings (a reading straight behind says -pi, and so does
//! a robot facing exactly west), and they must not change. Motion and the RFlex odometry used
//! (-pi, pi], which differs only at exactly +-pi: a heading error of exactly half a turn is now
//! turned clockwise. Note that `atan2` ([`Vec2::angle`](crate::Vec2::angle)) gives pi itself.

use std::f64::consts::{PI, TAU};

/// The angle wrapped into [-pi, pi). A non-finite angle comes back as it is.
#[must_use]
pub fn wrap_angle(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let wrapped = (angle_rad + PI).rem_euclid(TAU) - PI;
    // rem_euclid can round up to TAU itself.
    if wrapped >= PI {
        wrapped - TAU
    } else {
        wrapped
    }
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

    /// The cases of the simulator's, motion's and the RFlex odometry's former functions; at
    /// exactly +-pi the latter two expected pi.
    #[test]
    fn angles_wrap_into_the_half_open_interval() {
        check_wrap(0.0, 0.0);
        check_wrap(PI, -PI);
        check_wrap(-PI, -PI);
        check_wrap(3.0 * PI, -PI);
        check_wrap(3.0 * PI / 2.0, -PI / 2.0);
        check_wrap(-5.0 * PI / 2.0, -PI / 2.0);
        check_wrap(7.0, 7.0 - 2.0 * PI);
        check_wrap(0.5, 0.5);
    }

    #[test]
    fn non_finite_angles_come_back_as_they_are() {
        assert_eq!(wrap_angle(f64::INFINITY), f64::INFINITY);
        assert!(wrap_angle(f64::NAN).is_nan());
    }
}
