//! The one plane vector of the component crates.

use std::ops::{Add, Mul, Neg, Sub};

use lewis_interfaces::msg::Point2D;

/// A point or a direction in the plane, in metres.
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

    /// The unit vector at `angle_rad` from the x axis.
    #[must_use]
    #[inline]
    pub fn from_angle(angle_rad: f64) -> Self {
        // `sin_cos` is `(sin, cos)`, bit for bit: the simulator's rays and the motion
        // services' directions, which used one or the other, stay the same.
        let (sin, cos) = angle_rad.sin_cos();
        Self::new(cos, sin)
    }

    /// Euclidean length.
    #[must_use]
    #[inline]
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    /// Dot product.
    #[must_use]
    #[inline]
    pub fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// The z component of the cross product: positive when `other` is counter-clockwise.
    #[must_use]
    #[inline]
    pub fn cross(self, other: Self) -> f64 {
        self.x * other.y - self.y * other.x
    }

    /// Its angle from the x axis, in (-pi, pi].
    #[must_use]
    #[inline]
    pub fn angle(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// This vector turned a quarter turn counter-clockwise.
    #[must_use]
    #[inline]
    pub fn perpendicular(self) -> Self {
        Self::new(-self.y, self.x)
    }

    /// Distance to another point.
    #[must_use]
    #[inline]
    pub fn distance(self, other: Self) -> f64 {
        (self - other).norm()
    }

    /// Whether the length is at most `radius_m`: the same answer as `self.norm() <=
    /// radius_m`, without the cost of `hypot` unless the length is within a relative 1e-9 of
    /// the radius. The squared length is off by a few ulps at most, far inside that band,
    /// so outside it the comparison cannot go the other way; inside it, and where squares
    /// would overflow or underflow, `hypot` decides.
    #[must_use]
    #[inline]
    pub fn norm_at_most(self, radius_m: f64) -> bool {
        match self.compare_norm(radius_m) {
            Some(ordering) => ordering.is_le(),
            None => self.norm() <= radius_m,
        }
    }

    /// Whether the length is less than `radius_m`: the same answer as `self.norm() <
    /// radius_m` (see [`Self::norm_at_most`]).
    #[must_use]
    #[inline]
    pub fn norm_below(self, radius_m: f64) -> bool {
        match self.compare_norm(radius_m) {
            Some(ordering) => ordering.is_lt(),
            None => self.norm() < radius_m,
        }
    }

    /// The length against `radius_m` from squares, when they settle it.
    #[inline]
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
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The vector rotated counter-clockwise by `angle_rad`.
    #[must_use]
    #[inline]
    pub fn rotated(self, angle_rad: f64) -> Self {
        let (sin, cos) = angle_rad.sin_cos();
        self.rotated_by(sin, cos)
    }

    /// The vector rotated counter-clockwise by the angle whose sine and cosine are given.
    #[inline]
    #[must_use]
    pub fn rotated_by(self, sin: f64, cos: f64) -> Self {
        Self::new(cos * self.x - sin * self.y, sin * self.x + cos * self.y)
    }
}

impl Add for Vec2 {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Self::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl Sub for Vec2 {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Self::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl Mul<f64> for Vec2 {
    type Output = Self;
    #[inline]
    fn mul(self, rhs: f64) -> Self {
        Self::new(self.x * rhs, self.y * rhs)
    }
}

impl Neg for Vec2 {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y)
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

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut rng = lewis_service::Rng::new(0x2545_f491_4f6c_dd1d);
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
}
