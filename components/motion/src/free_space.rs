//! Straight-line reachability for a round robot among obstacle points: how far the robot's
//! disc can travel in each direction, and the reachable point closest to a goal (the
//! paper's greedy choice). Everything here is in the odometry frame.

use lewis_geometry::{Vec2, wrap_angle};
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// How far a disc of `radius_m` centred at `from` can move along the unit vector `dir`
/// before it touches `point`: infinite when it never does, 0 when it already overlaps the
/// point and `dir` brings it closer (moving away from an overlap is allowed, so a robot
/// that finds itself too close can back off).
#[must_use]
pub fn disc_hit_distance(from: Vec2, dir: Vec2, radius_m: f64, point: Vec2) -> f64 {
    let rel = point - from;
    let along = rel.dot(dir);
    if along <= 0.0 {
        return f64::INFINITY;
    }
    let lateral = rel.cross(dir).abs();
    if lateral >= radius_m {
        return f64::INFINITY;
    }
    if rel.norm_below(radius_m) {
        return 0.0;
    }
    (along - (radius_m * radius_m - lateral * lateral).sqrt()).max(0.0)
}

/// What the latest reading says is known: each beam's end point (odometry frame) and
/// half width. Directions no beam covers are only trusted up to `unseen_reach_m`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Coverage {
    /// (end point in the odometry frame, half width in rad) per beam.
    pub wedges: Vec<(Vec2, f64)>,
    /// How far the robot may plan into directions no beam covers, in m.
    pub unseen_reach_m: f64,
}

impl Coverage {
    /// How far the reading sees from `from` along `direction_rad`; `min_half_width_rad`
    /// widens narrow beams so that neighbouring beams leave no gaps.
    #[must_use]
    pub fn reach_m(&self, from: Vec2, direction_rad: f64, min_half_width_rad: f64) -> f64 {
        let seen = self
            .wedges
            .iter()
            .filter(|(end, half)| {
                wrap_angle(direction_rad - (*end - from).angle()).abs()
                    <= half.max(min_half_width_rad)
            })
            .map(|(end, _)| end.distance(from))
            .fold(f64::NEG_INFINITY, f64::max);
        if seen.is_finite() {
            seen
        } else {
            self.unseen_reach_m
        }
    }
}

/// The free distance of a disc in one direction: the first obstacle touched, and no further
/// than the reading sees.
#[must_use]
pub fn free_distance_m(
    from: Vec2,
    direction_rad: f64,
    radius_m: f64,
    points: &[Vec2],
    coverage: &Coverage,
    min_half_width_rad: f64,
) -> f64 {
    let dir = Vec2::from_angle(direction_rad);
    points
        .iter()
        .map(|&p| disc_hit_distance(from, dir, radius_m, p))
        .fold(
            coverage.reach_m(from, direction_rad, min_half_width_rad),
            f64::min,
        )
}

/// Indices of the grid directions (k * 2pi / n) within `half_rad` of `centre_rad`.
fn grid_indices(centre_rad: f64, half_rad: f64, n: usize) -> impl Iterator<Item = usize> {
    let step = TAU / n as f64;
    let (lo, hi) = if half_rad >= PI {
        (0, n.saturating_sub(1) as i64)
    } else {
        let lo = ((centre_rad - half_rad) / step).ceil() as i64;
        let hi = ((centre_rad + half_rad) / step).floor() as i64;
        (lo, hi.min(lo + n as i64 - 1))
    };
    (lo..=hi).map(move |k| k.rem_euclid(n as i64) as usize)
}

/// A point reachable by a straight line, as the greedy choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The point, odometry frame.
    pub point: Vec2,
    /// Its distance to the goal by the cost used (straight line, or around obstacles), in m.
    pub cost_m: f64,
    /// Its straight-line distance to the goal, in m.
    pub goal_distance_m: f64,
}

impl Candidate {
    /// The candidate at `point`, its goal distance measured only when the cost does not
    /// settle the comparison with `best`: most points of a step are worse than the best by
    /// cost alone, and the distance (a `hypot`) is then not needed. The candidate is
    /// returned when it is better than `best`.
    fn at_if_better(point: Vec2, goal: Vec2, cost_m: f64, best: &Self) -> Option<Self> {
        // Lower cost first; among equal costs (a grid cell), nearer the goal.
        if cost_m < best.cost_m - 1e-9 {
            return Some(Self {
                point,
                cost_m,
                goal_distance_m: point.distance(goal),
            });
        }
        if cost_m <= best.cost_m + 1e-9 {
            let goal_distance_m = point.distance(goal);
            if goal_distance_m < best.goal_distance_m - 1e-9 {
                return Some(Self {
                    point,
                    cost_m,
                    goal_distance_m,
                });
            }
        }
        None
    }
}

/// Free distance in `n` evenly spaced directions (direction k at k * 2pi / n rad).
#[must_use]
pub fn free_distances(
    from: Vec2,
    radius_m: f64,
    points: &[Vec2],
    coverage: &Coverage,
    n: usize,
) -> Vec<f64> {
    let step = TAU / n as f64;
    let mut free = vec![coverage.unseen_reach_m; n];
    let mut seen = vec![false; n];
    // Each point tries the few directions its disc can touch; their unit vectors are the
    // same every time, so they are worked out once rather than per point and direction.
    let directions: Vec<Vec2> = (0..n).map(|k| Vec2::from_angle(k as f64 * step)).collect();
    for (end, half) in &coverage.wedges {
        let rel = *end - from;
        let reach = rel.norm();
        for k in grid_indices(rel.angle(), half.max(step / 2.0), n) {
            free[k] = if seen[k] { free[k].max(reach) } else { reach };
            seen[k] = true;
        }
    }
    for &p in points {
        let rel = p - from;
        let distance = rel.norm();
        let half = if distance <= radius_m {
            FRAC_PI_2
        } else {
            (radius_m / distance).asin()
        };
        for k in grid_indices(rel.angle(), half, n) {
            free[k] = free[k].min(disc_hit_distance(from, directions[k], radius_m, p));
        }
    }
    free
}

/// The reachable point closest to the goal by `cost` (a point's distance to the goal:
/// straight, or around known obstacles): the goal itself when the straight line to it is
/// free; otherwise, along each of `n` directions, points of the free segment every
/// `sample_m` (and the one nearest the goal), the best of them. Ties go to the lower
/// direction index, so the choice is deterministic.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn closest_reachable(
    from: Vec2,
    goal: Vec2,
    radius_m: f64,
    points: &[Vec2],
    coverage: &Coverage,
    n: usize,
    sample_m: f64,
    cost: &dyn Fn(Vec2) -> f64,
) -> Candidate {
    let step = TAU / n as f64;
    let to_goal = goal - from;
    if to_goal.norm() == 0.0
        || free_distance_m(
            from,
            to_goal.angle(),
            radius_m,
            points,
            coverage,
            step / 2.0,
        ) >= to_goal.norm()
    {
        return Candidate {
            point: goal,
            cost_m: 0.0,
            goal_distance_m: 0.0,
        };
    }
    let mut best = Candidate {
        point: from,
        cost_m: cost(from),
        goal_distance_m: from.distance(goal),
    };
    for (k, free_m) in free_distances(from, radius_m, points, coverage, n)
        .into_iter()
        .enumerate()
    {
        if free_m <= 0.0 {
            continue;
        }
        let dir = Vec2::from_angle(k as f64 * step);
        let nearest_goal = to_goal.dot(dir).clamp(0.0, free_m);
        let mut consider = |s: f64| {
            let point = from + dir * s;
            if let Some(better) = Candidate::at_if_better(point, goal, cost(point), &best) {
                best = better;
            }
        };
        consider(nearest_goal);
        consider(free_m);
        if sample_m > 0.0 {
            let mut s = sample_m;
            while s < free_m {
                consider(s);
                s += sample_m;
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(x: f64, y0: f64, y1: f64) -> Vec<Vec2> {
        (0..=100)
            .map(|i| Vec2::new(x, y0 + (y1 - y0) * f64::from(i) / 100.0))
            .collect()
    }

    fn open(reach: f64) -> Coverage {
        Coverage {
            wedges: Vec::new(),
            unseen_reach_m: reach,
        }
    }

    #[test]
    fn a_disc_stops_short_of_a_point_ahead_by_its_radius() {
        let d = disc_hit_distance(
            Vec2::default(),
            Vec2::new(1.0, 0.0),
            0.5,
            Vec2::new(2.0, 0.0),
        );
        assert!((d - 1.5).abs() < 1e-12);
        let passing = disc_hit_distance(
            Vec2::default(),
            Vec2::new(1.0, 0.0),
            0.5,
            Vec2::new(2.0, 0.6),
        );
        assert!(passing.is_infinite());
        let behind = disc_hit_distance(
            Vec2::default(),
            Vec2::new(1.0, 0.0),
            0.5,
            Vec2::new(-0.2, 0.0),
        );
        assert!(
            behind.is_infinite(),
            "backing away from an overlap is allowed"
        );
        let overlap = disc_hit_distance(
            Vec2::default(),
            Vec2::new(1.0, 0.0),
            0.5,
            Vec2::new(0.2, 0.1),
        );
        assert!(overlap.abs() < 1e-12);
    }

    #[test]
    fn the_goal_itself_is_chosen_when_nothing_is_in_the_way() {
        let goal = Vec2::new(3.0, 1.0);
        let best = closest_reachable(
            Vec2::default(),
            goal,
            0.3,
            &wall(5.0, -1.0, 1.0),
            &open(10.0),
            180,
            0.1,
            &|p| p.distance(goal),
        );
        assert!(best.goal_distance_m < 1e-9, "{best:?}");
    }

    #[test]
    fn a_narrow_wall_in_the_way_sends_the_robot_past_one_of_its_ends_by_straight_distance() {
        let points = wall(2.0, -0.6, 0.6);
        let goal = Vec2::new(4.0, 0.0);
        let best = closest_reachable(
            Vec2::default(),
            goal,
            0.3,
            &points,
            &open(10.0),
            180,
            0.1,
            &|p| p.distance(goal),
        );
        assert!(best.point.y.abs() > 1.0 && best.point.x > 1.0, "{best:?}");
        let free = free_distance_m(
            Vec2::default(),
            best.point.angle(),
            0.3,
            &points,
            &open(10.0),
            0.0,
        );
        assert!(free >= best.point.norm() - 1e-9);
    }

    #[test]
    fn grid_and_single_direction_free_distances_agree() {
        let points = wall(2.0, -1.0, 1.0);
        let coverage = open(6.0);
        let grid = free_distances(Vec2::new(0.1, 0.2), 0.3, &points, &coverage, 72);
        for (k, free) in grid.iter().enumerate() {
            let direction = f64::from(u32::try_from(k).unwrap()) * TAU / 72.0;
            let single =
                free_distance_m(Vec2::new(0.1, 0.2), direction, 0.3, &points, &coverage, 0.0);
            assert!(
                (free - single).abs() < 1e-9,
                "direction {k}: {free} vs {single}"
            );
        }
    }
}
