//! Scan-to-map matching: where a scan fits best in the map built so far.
//!
//! Our own, because no maintained Rust crate matches a 2D scan against a growing map (the
//! ICP crates match point sets to point sets, which drifts the way odometry does). Two
//! steps, after Olson's correlative matcher and Hector SLAM's refinement:
//!
//! 1. **Search**: every heading in a window around the guess, and for each every
//!    translation on a grid of cells, scored by the sum of the likelihood field (a
//!    Gaussian around each occupied cell, [`crate::grid`]) under the scan's points, less a
//!    wide Gaussian prior on the distance from the guess; first
//!    every second cell, then around the best one every cell. Exhaustive within its
//!    window, so a bad guess within it cannot trap it in a local optimum.
//! 2. **Refine**: Gauss-Newton on the bilinearly interpolated field, for a pose finer than
//!    a cell.
//!
//! The match's score is the mean field under the points (0 to 1): how much of the scan
//! lands on walls already mapped. Below [`MatchOptions::min_score`] it is no match.

use lewis_geometry::{Pose2, Vec2, wrap_angle};

use crate::grid::Grid;

/// Where to search and what to accept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchOptions {
    /// Half the side of the square of translations searched, in m.
    pub window_m: f64,
    /// Half the range of headings searched, in rad.
    pub window_rad: f64,
    /// The step between headings searched, in rad.
    pub step_rad: f64,
    /// The least score of a match.
    pub min_score: f64,
}

impl MatchOptions {
    /// Around a guess from odometry or localisation: a step's odometry error is small.
    #[must_use]
    pub fn with_odometry() -> Self {
        Self {
            window_m: 0.3,
            window_rad: 6f64.to_radians(),
            step_rad: 0.5f64.to_radians(),
            min_score: 0.35,
        }
    }

    /// Around a guess from the last motion alone (no odometry): a wider window.
    #[must_use]
    pub fn without_odometry() -> Self {
        Self {
            window_m: 0.4,
            window_rad: 15f64.to_radians(),
            step_rad: 0.5f64.to_radians(),
            min_score: 0.35,
        }
    }
}

/// A match found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// The robot's pose.
    pub pose: Pose2,
    /// The mean field under the points, 0 to 1.
    pub score: f64,
}

/// The points of a scan worth matching: returns at least `spacing_m` apart, at most
/// `max_points` (evenly thinned), in the robot frame. Thinning keeps the search's cost
/// bounded while long walls still pin the pose.
#[must_use]
pub fn thin(points: &[Vec2], spacing_m: f64, max_points: usize) -> Vec<Vec2> {
    let mut kept: Vec<Vec2> = Vec::with_capacity(points.len());
    for &p in points {
        if kept.last().is_none_or(|&q| (p - q).norm() >= spacing_m) {
            kept.push(p);
        }
    }
    if kept.len() > max_points && max_points > 0 {
        let stride = kept.len() as f64 / max_points as f64;
        kept = (0..max_points)
            .filter_map(|i| kept.get((i as f64 * stride) as usize).copied())
            .collect();
    }
    kept
}

/// The best pose of `points` (robot frame) in `grid` near `guess`, or `None` when the
/// best is below the options' score (or the scan has too few points).
#[must_use]
pub fn match_scan(
    grid: &Grid,
    points: &[Vec2],
    guess: Pose2,
    options: &MatchOptions,
) -> Option<Match> {
    if points.len() < 10 {
        return None;
    }
    let (field, width, height, lo) = grid.field_view();
    if width == 0 {
        return None;
    }
    let size = grid.metres_per_cell();
    let lookup = |c: i64, r: i64| -> u32 {
        let (c, r) = (c - lo[0], r - lo[1]);
        if c < 0 || r < 0 {
            return 0;
        }
        // both non-negative here
        let (c, r) = (c as usize, r as usize);
        if c < width && r < height {
            u32::from(field[r * width + c])
        } else {
            0
        }
    };
    // saturating casts of small finite values
    let reach = (options.window_m / size).ceil() as i64;
    let turns = (options.window_rad / options.step_rad).round() as i64;
    let mut cells = vec![[0_i64; 2]; points.len()];
    // A prior on the guess: a candidate pays for its distance from it, a Gaussian twice as
    // wide as the window (an eighth of a perfect score at the window's edge). Where the
    // scan pins nothing (along a corridor) the guess wins instead of an arbitrary tie.
    let full = 255.0 * points.len() as f64;
    let sigma_m = 2.0 * options.window_m;
    let sigma_rad = 2.0 * options.window_rad;
    let prior = |dx: i64, dy: i64, dtheta: f64| -> f64 {
        let d2 = ((dx * dx + dy * dy) as f64) * size * size;
        full * 0.5 * (d2 / (sigma_m * sigma_m) + dtheta * dtheta / (sigma_rad * sigma_rad))
    };
    let mut best = (f64::NEG_INFINITY, 0.0_f64, 0_i64, 0_i64);
    for k in -turns..=turns {
        let dtheta = k as f64 * options.step_rad;
        let (s, c) = (guess.heading_rad + dtheta).sin_cos();
        for (cell, p) in cells.iter_mut().zip(points) {
            let w = Vec2::new(guess.x_m + c * p.x - s * p.y, guess.y_m + s * p.x + c * p.y);
            *cell = [(w.x / size).floor() as i64, (w.y / size).floor() as i64];
        }
        let score_at = |dx: i64, dy: i64| -> f64 {
            let sum: u32 = cells
                .iter()
                .map(|cell| lookup(cell[0] + dx, cell[1] + dy))
                .sum();
            f64::from(sum) - prior(dx, dy, dtheta)
        };
        // Every second cell over the window, then every cell around the best of those.
        let mut local = (f64::NEG_INFINITY, 0_i64, 0_i64);
        let mut dy = -reach;
        while dy <= reach {
            let mut dx = -reach;
            while dx <= reach {
                let v = score_at(dx, dy);
                if v > local.0 {
                    local = (v, dx, dy);
                }
                dx += 2;
            }
            dy += 2;
        }
        let (_, cx, cy) = local;
        for dy in cy - 1..=cy + 1 {
            for dx in cx - 1..=cx + 1 {
                let v = score_at(dx, dy);
                if v > local.0 {
                    local = (v, dx, dy);
                }
            }
        }
        if local.0 > best.0 {
            best = (local.0, dtheta, local.1, local.2);
        }
    }
    let coarse = Pose2::new(
        guess.x_m + best.2 as f64 * size,
        guess.y_m + best.3 as f64 * size,
        wrap_angle(guess.heading_rad + best.1),
    );
    let refined = refine(grid, points, coarse);
    let pose = match refined {
        Some(p)
            if (p.position() - coarse.position()).norm() <= 2.0 * size
                && wrap_angle(p.heading_rad - coarse.heading_rad).abs()
                    <= 2.0 * options.step_rad =>
        {
            p
        }
        _ => coarse,
    };
    let score = mean_field(grid, points, pose);
    (score >= options.min_score).then_some(Match { pose, score })
}

/// The field at world point `p`, bilinearly interpolated between cell centres (0 to 1), and
/// its gradient per m.
fn sample(grid: &Grid, p: Vec2) -> (f64, Vec2) {
    let size = grid.metres_per_cell();
    let gx = p.x / size - 0.5;
    let gy = p.y / size - 0.5;
    let (x0, y0) = (gx.floor(), gy.floor());
    let (fx, fy) = (gx - x0, gy - y0);
    // saturating casts of finite floors
    let (c, r) = (x0 as i64, y0 as i64);
    let v = |dc: i64, dr: i64| f64::from(grid.field([c + dc, r + dr])) / 255.0;
    let (v00, v10, v01, v11) = (v(0, 0), v(1, 0), v(0, 1), v(1, 1));
    let value = (1.0 - fy) * ((1.0 - fx) * v00 + fx * v10) + fy * ((1.0 - fx) * v01 + fx * v11);
    let dx = ((1.0 - fy) * (v10 - v00) + fy * (v11 - v01)) / size;
    let dy = ((1.0 - fx) * (v01 - v00) + fx * (v11 - v10)) / size;
    (value, Vec2::new(dx, dy))
}

fn mean_field(grid: &Grid, points: &[Vec2], pose: Pose2) -> f64 {
    let sum: f64 = points
        .iter()
        .map(|&p| sample(grid, pose.transform_point(p)).0)
        .sum();
    sum / points.len().max(1) as f64
}

/// Gauss-Newton steps maximising the interpolated field under the points.
fn refine(grid: &Grid, points: &[Vec2], start: Pose2) -> Option<Pose2> {
    let mut pose = start;
    for _ in 0..8 {
        let (s, c) = pose.heading_rad.sin_cos();
        let mut h = [[0.0_f64; 3]; 3];
        let mut b = [0.0_f64; 3];
        for &p in points {
            let w = pose.transform_point(p);
            let (value, grad) = sample(grid, w);
            let dtheta = grad.x * (-s * p.x - c * p.y) + grad.y * (c * p.x - s * p.y);
            let j = [grad.x, grad.y, dtheta];
            let residual = 1.0 - value;
            for row in 0..3 {
                b[row] += j[row] * residual;
                for col in 0..3 {
                    h[row][col] += j[row] * j[col];
                }
            }
        }
        let step = solve3(h, b)?;
        pose = Pose2::new(
            pose.x_m + step[0],
            pose.y_m + step[1],
            wrap_angle(pose.heading_rad + step[2]),
        );
        if step[0].hypot(step[1]) < 1e-4 && step[2].abs() < 1e-4 {
            break;
        }
    }
    Some(pose)
}

/// Solves `h x = b` for a 3x3 `h` by Cramer's rule; `None` when it is (nearly) singular
/// (a scan of one straight wall leaves a direction free).
fn solve3(h: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(h);
    let scale = h[0][0].abs() + h[1][1].abs() + h[2][2].abs();
    if !d.is_finite() || d.abs() <= 1e-9 * scale.powi(3) || scale == 0.0 {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = h;
        for row in 0..3 {
            m[row][k] = b[row];
        }
        *xk = det(m) / d;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::OccupancyRule;
    use crate::run::Scan;

    /// A 360-degree scan from `pose` in a 6 m x 4 m room with a pillar, ray cast by hand.
    fn room_scan(pose: Pose2) -> Scan {
        let n = 720_u32;
        let step = std::f64::consts::TAU / f64::from(n);
        let walls = |p: Vec2, d: Vec2| -> f64 {
            let mut best = f64::INFINITY;
            // walls x = -3, x = 3, y = -2, y = 2
            for (wall, axis) in [(-3.0, 0), (3.0, 0), (-2.0, 1), (2.0, 1)] {
                let (o, v) = if axis == 0 { (p.x, d.x) } else { (p.y, d.y) };
                if v.abs() > 1e-12 {
                    let t = (wall - o) / v;
                    if t > 0.0 {
                        best = best.min(t);
                    }
                }
            }
            // a pillar of radius 0.3 at (1, 0.5)
            let c = Vec2::new(1.0, 0.5);
            let oc = p - c;
            let bq = oc.dot(d);
            let disc = bq * bq - (oc.dot(oc) - 0.09);
            if disc >= 0.0 {
                let t = -bq - disc.sqrt();
                if t > 0.0 {
                    best = best.min(t);
                }
            }
            best
        };
        let ranges = (0..n)
            .map(|i| {
                let bearing = -std::f64::consts::PI + step * f64::from(i);
                walls(
                    pose.position(),
                    Vec2::from_angle(pose.heading_rad + bearing),
                ) as f32
            })
            .collect();
        Scan {
            time_ns: 0,
            ranges_m: ranges,
            first_bearing_rad: -std::f64::consts::PI,
            step_rad: step,
            mount_m: Vec2::new(0.0, 0.0),
            max_range_m: 20.0,
            recorded_pose: None,
        }
    }

    fn check(true_pose: Pose2, guess: Pose2, options: &MatchOptions) {
        let mut grid = Grid::new(0.05, OccupancyRule::default());
        grid.insert(
            &room_scan(Pose2::new(0.0, 0.0, 0.0)),
            Pose2::new(0.0, 0.0, 0.0),
        )
        .unwrap_or_default();
        let scan = room_scan(true_pose);
        let points = thin(&scan.points_in_robot(), 0.05, 300);
        let found = match_scan(&grid, &points, guess, options);
        let Some(found) = found else {
            panic!("no match of {true_pose:?} from {guess:?}");
        };
        let error_m = (found.pose.position() - true_pose.position()).norm();
        let error_rad = wrap_angle(found.pose.heading_rad - true_pose.heading_rad).abs();
        assert!(
            error_m < 0.02 && error_rad < 0.005,
            "found {found:?} for {true_pose:?}: {error_m} m, {error_rad} rad off"
        );
    }

    #[test]
    fn a_known_offset_is_recovered() {
        let truth = Pose2::new(0.4, -0.3, 0.1);
        check(
            truth,
            Pose2::new(0.2, -0.15, 0.02),
            &MatchOptions::with_odometry(),
        );
    }

    #[test]
    fn a_wider_offset_is_recovered_without_odometry() {
        let truth = Pose2::new(-0.5, 0.2, -0.2);
        check(
            truth,
            Pose2::new(-0.2, 0.0, 0.0),
            &MatchOptions::without_odometry(),
        );
    }

    #[test]
    fn a_scan_of_another_place_is_no_match() {
        let mut grid = Grid::new(0.05, OccupancyRule::default());
        grid.insert(
            &room_scan(Pose2::new(0.0, 0.0, 0.0)),
            Pose2::new(0.0, 0.0, 0.0),
        )
        .unwrap_or_default();
        let scan = room_scan(Pose2::new(0.0, 0.0, 0.0));
        let points = thin(&scan.points_in_robot(), 0.05, 300);
        let far = Pose2::new(40.0, 40.0, 0.0);
        assert_eq!(
            match_scan(&grid, &points, far, &MatchOptions::with_odometry()),
            None
        );
    }
}
