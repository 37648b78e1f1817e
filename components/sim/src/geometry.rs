//! The three shapes the world is made of (circles, oriented rectangles, segments), with ray
//! intersection and nearest points.

use lewis_geometry::Vec2;

/// Where a ray meets a shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Distance from the ray's origin along its (unit) direction, in m.
    pub range_m: f64,
    /// The surface normal at the hit, a unit vector facing the ray's origin.
    pub normal: Vec2,
}

/// A shape of the world, seen from above.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A disc (a pillar, a person).
    Circle {
        /// Centre.
        centre: Vec2,
        /// Radius, in m.
        radius_m: f64,
    },
    /// A rectangle turned by some angle (a wall, a desk, a box, a closed door).
    Rect {
        /// Centre.
        centre: Vec2,
        /// Unit vector along the rectangle's length.
        axis: Vec2,
        /// Half of the length, in m.
        half_length_m: f64,
        /// Half of the width, in m.
        half_width_m: f64,
    },
    /// A line segment with no thickness (a sign board).
    Segment {
        /// One end.
        a: Vec2,
        /// The other end.
        b: Vec2,
    },
}

impl Shape {
    /// A rectangle of `length_m` by `width_m` centred at `centre`, its length along
    /// `heading_rad`.
    #[must_use]
    pub fn rect(centre: Vec2, length_m: f64, width_m: f64, heading_rad: f64) -> Self {
        Self::Rect {
            centre,
            axis: Vec2::from_angle(heading_rad),
            half_length_m: length_m / 2.0,
            half_width_m: width_m / 2.0,
        }
    }

    /// A rectangle of width `width_m` centred on the segment from `a` to `b`.
    #[must_use]
    pub fn thick_segment(a: Vec2, b: Vec2, width_m: f64) -> Self {
        let d = b - a;
        let length = d.norm();
        let axis = if length > 0.0 {
            d * (1.0 / length)
        } else {
            Vec2::new(1.0, 0.0)
        };
        Self::Rect {
            centre: (a + b) * 0.5,
            axis,
            half_length_m: length / 2.0,
            half_width_m: width_m / 2.0,
        }
    }

    /// The smallest axis-aligned box holding the shape: (min corner, max corner).
    #[must_use]
    pub fn bounds(&self) -> (Vec2, Vec2) {
        match *self {
            Self::Circle { centre, radius_m } => (
                centre - Vec2::new(radius_m, radius_m),
                centre + Vec2::new(radius_m, radius_m),
            ),
            Self::Rect {
                centre,
                axis,
                half_length_m,
                half_width_m,
            } => {
                let ex = axis.x.abs() * half_length_m + axis.y.abs() * half_width_m;
                let ey = axis.y.abs() * half_length_m + axis.x.abs() * half_width_m;
                (centre - Vec2::new(ex, ey), centre + Vec2::new(ex, ey))
            }
            Self::Segment { a, b } => (
                Vec2::new(a.x.min(b.x), a.y.min(b.y)),
                Vec2::new(a.x.max(b.x), a.y.max(b.y)),
            ),
        }
    }

    /// The first point where the ray from `origin` along the unit vector `dir` meets the
    /// shape within `max_range_m`. A ray starting inside a solid shape hits it at range 0.
    #[must_use]
    pub fn ray_hit(&self, origin: Vec2, dir: Vec2, max_range_m: f64) -> Option<RayHit> {
        let hit = match *self {
            Self::Circle { centre, radius_m } => ray_circle(origin, dir, centre, radius_m),
            Self::Rect {
                centre,
                axis,
                half_length_m,
                half_width_m,
            } => ray_rect(origin, dir, centre, axis, half_length_m, half_width_m),
            Self::Segment { a, b } => ray_segment(origin, dir, a, b),
        }?;
        (hit.range_m <= max_range_m).then_some(hit)
    }

    /// The point of the shape nearest to `p` (`p` itself when inside a solid shape).
    #[must_use]
    pub fn nearest_point(&self, p: Vec2) -> Vec2 {
        match *self {
            Self::Circle { centre, radius_m } => {
                let d = p - centre;
                let len = d.norm();
                if len <= radius_m {
                    p
                } else {
                    centre + d * (radius_m / len)
                }
            }
            Self::Rect {
                centre,
                axis,
                half_length_m,
                half_width_m,
            } => {
                let d = p - centre;
                let side = axis.perpendicular();
                let u = d.dot(axis).clamp(-half_length_m, half_length_m);
                let v = d.dot(side).clamp(-half_width_m, half_width_m);
                centre + axis * u + side * v
            }
            Self::Segment { a, b } => {
                let ab = b - a;
                let len2 = ab.dot(ab);
                let t = if len2 > 0.0 {
                    ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                a + ab * t
            }
        }
    }
}

fn ray_circle(origin: Vec2, dir: Vec2, centre: Vec2, radius: f64) -> Option<RayHit> {
    let oc = origin - centre;
    let c = oc.dot(oc) - radius * radius;
    if c <= 0.0 {
        let normal = if oc.norm() > 0.0 {
            oc * (1.0 / oc.norm())
        } else {
            -dir
        };
        return Some(RayHit {
            range_m: 0.0,
            normal,
        });
    }
    let b = oc.dot(dir);
    if b >= 0.0 {
        return None; // outside and moving away
    }
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    let p = origin + dir * t;
    let normal = (p - centre) * (1.0 / radius);
    Some(RayHit { range_m: t, normal })
}

fn ray_rect(
    origin: Vec2,
    dir: Vec2,
    centre: Vec2,
    axis: Vec2,
    half_length: f64,
    half_width: f64,
) -> Option<RayHit> {
    let side = axis.perpendicular();
    let d = origin - centre;
    // The ray in the rectangle's frame.
    let o = [d.dot(axis), d.dot(side)];
    let r = [dir.dot(axis), dir.dot(side)];
    let half = [half_length, half_width];
    let mut t_enter = f64::NEG_INFINITY;
    let mut t_exit = f64::INFINITY;
    let mut enter_axis = 0;
    let mut enter_sign = 1.0;
    for k in 0..2 {
        if r[k] == 0.0 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let t1 = (-half[k] - o[k]) / r[k];
        let t2 = (half[k] - o[k]) / r[k];
        let (near, far) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if near > t_enter {
            t_enter = near;
            enter_axis = k;
            // The face entered is the one facing against the ray.
            enter_sign = if r[k] > 0.0 { -1.0 } else { 1.0 };
        }
        t_exit = t_exit.min(far);
    }
    if t_enter > t_exit || t_exit < 0.0 {
        return None;
    }
    let local_normal = if enter_axis == 0 { axis } else { side };
    if t_enter < 0.0 {
        return Some(RayHit {
            range_m: 0.0,
            normal: -dir,
        });
    }
    Some(RayHit {
        range_m: t_enter,
        normal: local_normal * enter_sign,
    })
}

fn ray_segment(origin: Vec2, dir: Vec2, a: Vec2, b: Vec2) -> Option<RayHit> {
    let ab = b - a;
    let denom = dir.cross(ab);
    if denom.abs() < 1e-12 {
        return None; // parallel: a board seen edge-on has no width
    }
    let ao = a - origin;
    let t = ao.cross(ab) / denom;
    let s = ao.cross(dir) / denom;
    if t < 0.0 || !(0.0..=1.0).contains(&s) {
        return None;
    }
    let len = ab.norm();
    let mut normal = ab.perpendicular() * (1.0 / len);
    if normal.dot(dir) > 0.0 {
        normal = -normal;
    }
    Some(RayHit { range_m: t, normal })
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    fn check_hit(shape: Shape, origin: Vec2, angle: f64, expected: Option<(f64, Vec2)>) {
        let hit = shape.ray_hit(origin, Vec2::from_angle(angle), 100.0);
        match (hit, expected) {
            (None, None) => {}
            (Some(h), Some((range, normal))) => {
                assert!((h.range_m - range).abs() < 1e-9, "{shape:?}: range {h:?}");
                assert!((h.normal - normal).norm() < 1e-9, "{shape:?}: normal {h:?}");
            }
            (h, e) => panic!("{shape:?} from {origin:?} at {angle}: got {h:?}, expected {e:?}"),
        }
    }

    #[test]
    fn rays_meet_circles_rects_and_segments_where_expected() {
        let o = Vec2::new(0.0, 0.0);
        let circle = Shape::Circle {
            centre: Vec2::new(5.0, 0.0),
            radius_m: 1.0,
        };
        check_hit(circle, o, 0.0, Some((4.0, Vec2::new(-1.0, 0.0))));
        check_hit(circle, o, PI, None);
        check_hit(circle, o, 0.5, None);
        let rect = Shape::rect(Vec2::new(3.0, 0.0), 2.0, 4.0, 0.0);
        check_hit(rect, o, 0.0, Some((2.0, Vec2::new(-1.0, 0.0))));
        let turned = Shape::rect(Vec2::new(0.0, 3.0), 2.0, 4.0, PI / 2.0);
        check_hit(turned, o, PI / 2.0, Some((2.0, Vec2::new(0.0, -1.0))));
        let seg = Shape::Segment {
            a: Vec2::new(2.0, -1.0),
            b: Vec2::new(2.0, 1.0),
        };
        check_hit(seg, o, 0.0, Some((2.0, Vec2::new(-1.0, 0.0))));
        check_hit(
            seg,
            Vec2::new(4.0, 0.0),
            PI,
            Some((2.0, Vec2::new(1.0, 0.0))),
        );
        check_hit(seg, o, PI / 2.0, None);
    }

    #[test]
    fn a_ray_starting_inside_a_solid_hits_at_zero() {
        let rect = Shape::rect(Vec2::new(0.0, 0.0), 2.0, 2.0, 0.3);
        let hit = rect.ray_hit(Vec2::new(0.1, 0.1), Vec2::from_angle(1.0), 10.0);
        assert_eq!(hit.map(|h| h.range_m), Some(0.0));
    }
}
