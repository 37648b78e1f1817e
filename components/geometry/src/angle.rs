//! The one angle convention: angles are wrapped into (-pi, pi], the range of `atan2`, so that a
//! bearing from [`Vec2::angle`](crate::Vec2::angle) is already in it.

use std::f64::consts::{PI, TAU};

/// The angle wrapped into (-pi, pi]. A non-finite angle comes back as it is.
#[must_use]
pub fn wrap_angle(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() {
        return angle_rad;
    }
    let wrapped = (angle_rad + PI).rem_euclid(TAU) - PI;
    // rem_euclid can round up to TAU itself, and -pi belongs at the other end.
    if wrapped <= -PI {
        wrapped + TAU
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

    #[test]
    fn angles_wrap_into_the_half_open_interval() {
        check_wrap(0.0, 0.0);
        check_wrap(PI, PI);
        check_wrap(-PI, PI);
        check_wrap(3.0 * PI / 2.0, -PI / 2.0);
        check_wrap(-5.0 * PI / 2.0, -PI / 2.0);
        check_wrap(7.0, 7.0 - 2.0 * PI);
        // The RFlex odometry's cases.
        check_wrap(3.0 * PI, PI);
        check_wrap(0.5, 0.5);
    }
}
