//! The path length to the goal around the obstacles known so far, on a local grid: what
//! "closest to the goal" means for the greedy choice. Where nothing known is in the way it
//! is the straight-line distance, as in the paper; with a wall in between it is the way
//! around, so the greedy choice does not stop in front of the wall (a local minimum of the
//! straight-line distance). Unknown space counts as free.

use super::geometry::Vec2;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::f64::consts::SQRT_2;

/// Path lengths to a goal over a grid around the robot and the goal.
#[derive(Debug, Clone, PartialEq)]
pub struct GoalCostMap {
    origin: Vec2,
    cell_m: f64,
    width: usize,
    height: usize,
    cost_m: Vec<f64>,
}

impl GoalCostMap {
    /// Grid of at most `max_cells` cells of at least `cell_m`, covering the robot, the goal
    /// and `margin_m` around them; cells whose centre is within `blocked_radius_m` of an
    /// obstacle point are closed; costs are 8-connected path lengths from the goal.
    #[must_use]
    pub fn build(
        goal: Vec2,
        robot: Vec2,
        obstacles: &[Vec2],
        blocked_radius_m: f64,
        cell_m: f64,
        margin_m: f64,
        max_cells: usize,
    ) -> Self {
        let lo = Vec2::new(
            goal.x.min(robot.x) - margin_m,
            goal.y.min(robot.y) - margin_m,
        );
        let hi = Vec2::new(
            goal.x.max(robot.x) + margin_m,
            goal.y.max(robot.y) + margin_m,
        );
        let span = hi - lo;
        #[allow(clippy::cast_precision_loss)]
        let cell_m = cell_m.max((span.x * span.y / max_cells.max(1) as f64).sqrt());
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let (width, height) = (
            ((span.x / cell_m).ceil() as usize).max(1),
            ((span.y / cell_m).ceil() as usize).max(1),
        );
        let mut map = Self {
            origin: lo,
            cell_m,
            width,
            height,
            cost_m: vec![f64::INFINITY; width * height],
        };
        let mut open = vec![true; width * height];
        #[allow(clippy::cast_possible_truncation)]
        let reach = (blocked_radius_m / cell_m).ceil() as i64;
        for &p in obstacles {
            let Some((cx, cy)) = map.cell_of(p, reach) else {
                continue;
            };
            for y in (cy - reach).max(0)..=(cy + reach).min(height as i64 - 1) {
                for x in (cx - reach).max(0)..=(cx + reach).min(width as i64 - 1) {
                    #[allow(clippy::cast_sign_loss, clippy::cast_possible_truncation)]
                    let index = y as usize * width + x as usize;
                    if open[index] && map.centre(index).distance(p) <= blocked_radius_m {
                        open[index] = false;
                    }
                }
            }
        }
        if let Some((gx, gy)) = map.cell_of(goal, 0) {
            #[allow(clippy::cast_sign_loss, clippy::cast_possible_truncation)]
            map.flood(gy as usize * width + gx as usize, &open);
        }
        map
    }

    /// The cell of a point, allowing `slack` cells outside the grid.
    fn cell_of(&self, p: Vec2, slack: i64) -> Option<(i64, i64)> {
        let rel = p - self.origin;
        #[allow(clippy::cast_possible_truncation)]
        let (x, y) = (
            (rel.x / self.cell_m).floor() as i64,
            (rel.y / self.cell_m).floor() as i64,
        );
        #[allow(clippy::cast_possible_wrap)]
        let inside = x >= -slack
            && y >= -slack
            && x < self.width as i64 + slack
            && y < self.height as i64 + slack;
        inside.then_some((x, y))
    }

    fn centre(&self, index: usize) -> Vec2 {
        #[allow(clippy::cast_precision_loss)]
        let (x, y) = ((index % self.width) as f64, (index / self.width) as f64);
        self.origin + Vec2::new((x + 0.5) * self.cell_m, (y + 0.5) * self.cell_m)
    }

    /// Dijkstra from the goal's cell (open or not: a goal next to a wall still pulls).
    fn flood(&mut self, start: usize, open: &[bool]) {
        let mut queue = BinaryHeap::new();
        self.cost_m[start] = 0.0;
        // Non-negative finite f64 order like their bit patterns.
        queue.push(Reverse((0.0_f64.to_bits(), start)));
        let (w, h) = (self.width, self.height);
        while let Some(Reverse((bits, index))) = queue.pop() {
            let cost = f64::from_bits(bits);
            if cost > self.cost_m[index] {
                continue;
            }
            let (x, y) = (index % w, index / w);
            for (dx, dy) in [
                (-1, 0),
                (1, 0),
                (0, -1),
                (0, 1),
                (-1, -1),
                (1, -1),
                (-1, 1),
                (1, 1),
            ] {
                let (Some(nx), Some(ny)) = (x.checked_add_signed(dx), y.checked_add_signed(dy))
                else {
                    continue;
                };
                if nx >= w || ny >= h {
                    continue;
                }
                let next = ny * w + nx;
                // No cutting corners between two closed cells.
                if !open[next] || (dx != 0 && dy != 0 && !open[y * w + nx] && !open[ny * w + x]) {
                    continue;
                }
                let step = if dx != 0 && dy != 0 { SQRT_2 } else { 1.0 } * self.cell_m;
                let candidate = cost + step;
                if candidate < self.cost_m[next] {
                    self.cost_m[next] = candidate;
                    queue.push(Reverse((candidate.to_bits(), next)));
                }
            }
        }
    }

    /// The path length from a point to the goal, in m: infinite outside the grid or where
    /// the goal cannot be reached.
    #[must_use]
    pub fn cost_m(&self, p: Vec2) -> f64 {
        match self.cell_of(p, 0) {
            #[allow(clippy::cast_sign_loss, clippy::cast_possible_truncation)]
            Some((x, y)) => self.cost_m[y as usize * self.width + x as usize],
            None => f64::INFINITY,
        }
    }

    /// The grid's cell size, in m.
    #[must_use]
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn with_nothing_in_the_way_the_cost_is_about_the_straight_distance() {
        let map = GoalCostMap::build(
            Vec2::new(4.0, 0.0),
            Vec2::default(),
            &[],
            0.3,
            0.1,
            1.0,
            10_000,
        );
        let cost = map.cost_m(Vec2::new(0.0, 0.0));
        assert!((cost - 4.0).abs() < 0.3, "{cost}");
    }

    #[test]
    fn a_wall_makes_the_way_around_cheaper_than_the_face_of_the_wall() {
        let wall: Vec<Vec2> = (0..=60)
            .map(|i| Vec2::new(2.0, -1.5 + f64::from(i) * 0.05))
            .collect();
        let map = GoalCostMap::build(
            Vec2::new(4.0, 0.0),
            Vec2::default(),
            &wall,
            0.3,
            0.1,
            2.0,
            10_000,
        );
        let face = map.cost_m(Vec2::new(1.6, 0.0));
        let past_the_end = map.cost_m(Vec2::new(2.1, 1.9));
        assert!(past_the_end < face, "{past_the_end} vs {face}");
        assert!(map.cost_m(Vec2::new(50.0, 0.0)).is_infinite());
    }
}
