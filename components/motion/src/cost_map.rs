//! The path length to the goal around the obstacles known so far, on a local grid: what
//! "closest to the goal" means for the greedy choice. Where nothing known is in the way it
//! is the straight-line distance, as in the paper; with a wall in between it is the way
//! around, so the greedy choice does not stop in front of the wall (a local minimum of the
//! straight-line distance). Unknown space counts as free.

use lewis_geometry::Vec2;
use std::f64::consts::SQRT_2;

/// Pending cells of the flood, in a ring of buckets of costs (see [`GoalCostMap::flood`]):
/// the longest step spans less than 3 buckets, so 4 would do; 8 leaves room.
const RING: usize = 8;

/// Path lengths to a goal over a grid around the robot and the goal.
///
/// One map can be rebuilt at every step ([`GoalCostMap::rebuild`]): its buffers are kept, so
/// that a step allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct GoalCostMap {
    origin: Vec2,
    cell_m: f64,
    width: usize,
    height: usize,
    /// Row by row, with a border of one cell all round (see [`GoalCostMap::index`]).
    cost_m: Vec<f64>,
    /// Cells not closed by an obstacle, bordered like `cost_m` (scratch of `rebuild`).
    open: Vec<bool>,
    /// (cost, cell) pending in the flood, by bucket (scratch of `flood`).
    ring: [Vec<(f64, usize)>; RING],
}

impl PartialEq for GoalCostMap {
    /// The same grid with the same costs (the scratch buffers do not count).
    fn eq(&self, other: &Self) -> bool {
        self.origin == other.origin
            && self.cell_m == other.cell_m
            && self.width == other.width
            && self.height == other.height
            && self.cost_m == other.cost_m
    }
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
        let mut map = Self::default();
        map.rebuild(
            goal,
            robot,
            obstacles,
            blocked_radius_m,
            cell_m,
            margin_m,
            max_cells,
        );
        map
    }

    /// What [`Self::build`] makes, in this map's buffers.
    #[allow(clippy::too_many_arguments)]
    pub fn rebuild(
        &mut self,
        goal: Vec2,
        robot: Vec2,
        obstacles: &[Vec2],
        blocked_radius_m: f64,
        cell_m: f64,
        margin_m: f64,
        max_cells: usize,
    ) {
        let lo = Vec2::new(
            goal.x.min(robot.x) - margin_m,
            goal.y.min(robot.y) - margin_m,
        );
        let hi = Vec2::new(
            goal.x.max(robot.x) + margin_m,
            goal.y.max(robot.y) + margin_m,
        );
        let span = hi - lo;
        let cell_m = cell_m.max((span.x * span.y / max_cells.max(1) as f64).sqrt());
        let (width, height) = (
            ((span.x / cell_m).ceil() as usize).max(1),
            ((span.y / cell_m).ceil() as usize).max(1),
        );
        self.origin = lo;
        self.cell_m = cell_m;
        self.width = width;
        self.height = height;
        let cells = (width + 2) * (height + 2);
        self.cost_m.clear();
        self.cost_m.resize(cells, f64::INFINITY);
        let mut open = std::mem::take(&mut self.open);
        open.clear();
        open.resize(cells, true);
        // The border is closed: the flood never leaves the grid.
        let row = width + 2;
        open[..row].fill(false);
        open[(height + 1) * row..].fill(false);
        for y in 1..=height {
            open[y * row] = false;
            open[y * row + row - 1] = false;
        }
        let reach = (blocked_radius_m / cell_m).ceil() as i64;
        let stencil = Stencil::new(blocked_radius_m, cell_m, reach);
        let (last_x, last_y) = (width as i64 - 1, height as i64 - 1);
        for &p in obstacles {
            let Some((cx, cy)) = self.cell_of(p, reach) else {
                continue;
            };
            for (dy, row) in (-reach..=reach).zip(&stencil.rows) {
                let y = cy + dy;
                if y < 0 || y > last_y {
                    continue;
                }
                let y = y as usize;
                if let Some(inner) = row.inside {
                    let (from, to) = ((cx - inner).max(0), (cx + inner).min(last_x));
                    if from <= to {
                        let (from, to) = (self.index(from as usize, y), self.index(to as usize, y));
                        open[from..=to].fill(false);
                    }
                }
                let inner = row.inside.unwrap_or(-1);
                let sides = [
                    (cx - row.unsure, cx - inner - 1),
                    (cx + inner + 1, cx + row.unsure),
                ];
                for (from, to) in sides {
                    for x in from.max(0)..=to.min(last_x) {
                        let x = x as usize;
                        let index = self.index(x, y);
                        // Decided by squares, mostly; the same answer as comparing the
                        // hypot distance, which a profile found costly here.
                        if open[index] && (self.centre(x, y) - p).norm_at_most(blocked_radius_m) {
                            open[index] = false;
                        }
                    }
                }
            }
        }
        if let Some((gx, gy)) = self.cell_of(goal, 0) {
            self.flood(self.index(gx as usize, gy as usize), &open);
        }
        self.open = open;
    }

    /// The cell of a point, allowing `slack` cells outside the grid.
    fn cell_of(&self, p: Vec2, slack: i64) -> Option<(i64, i64)> {
        let rel = p - self.origin;
        let (x, y) = (
            (rel.x / self.cell_m).floor() as i64,
            (rel.y / self.cell_m).floor() as i64,
        );
        let inside = x >= -slack
            && y >= -slack
            && x < self.width as i64 + slack
            && y < self.height as i64 + slack;
        inside.then_some((x, y))
    }

    /// Where cell (x, y) of the grid is kept: row by row, after a border row, each row
    /// between two border cells.
    fn index(&self, x: usize, y: usize) -> usize {
        (y + 1) * (self.width + 2) + x + 1
    }

    fn centre(&self, x: usize, y: usize) -> Vec2 {
        let (x, y) = (x as f64, y as f64);
        self.origin + Vec2::new((x + 0.5) * self.cell_m, (y + 0.5) * self.cell_m)
    }

    /// Shortest paths from the goal's cell (open or not: a goal next to a wall still pulls),
    /// by Dial's algorithm rather than Dijkstra's binary heap: cells wait in buckets of
    /// half a cell of cost, and a step (at least a cell) always lands at least one bucket
    /// on, so every cell of the bucket being emptied already has its final cost and the
    /// order within a bucket does not matter. Each cost is then the least over the cell's
    /// neighbours of (neighbour's cost + step), computed with the same additions as
    /// Dijkstra's: the same bits whatever the order of the work.
    fn flood(&mut self, start: usize, open: &[bool]) {
        // A product, not a quotient (a profile found the division costly): rounding may put
        // a cell one bucket off, which a step of at least two buckets leaves harmless.
        let buckets_per_m = 2.0 / self.cell_m;
        let bucket_of = |cost: f64| (cost * buckets_per_m) as usize;
        let straight = self.cell_m;
        let diagonal = SQRT_2 * self.cell_m;
        // The border cells are closed, so the neighbours of a cell that can be entered are
        // all in the grid: steps are offsets, with no bounds to check.
        let row = self.width + 2;
        let steps = [
            (
                row.wrapping_neg() - 1,
                row.wrapping_neg(),
                usize::MAX,
                diagonal,
            ),
            (row.wrapping_neg(), 0, 0, straight),
            (row.wrapping_neg() + 1, row.wrapping_neg(), 1, diagonal),
            (usize::MAX, 0, 0, straight),
            (1, 0, 0, straight),
            (row - 1, row, usize::MAX, diagonal),
            (row, 0, 0, straight),
            (row + 1, row, 1, diagonal),
        ];
        for slot in &mut self.ring {
            slot.clear();
        }
        self.cost_m[start] = 0.0;
        self.ring[0].push((0.0, start));
        let mut pending = 1_usize;
        let mut current = 0_usize;
        while pending > 0 {
            let mut cells = std::mem::take(&mut self.ring[current % RING]);
            pending -= cells.len();
            for &(cost, index) in &cells {
                // Lowered since it was queued: its cheaper entry came first.
                if cost > self.cost_m[index] {
                    continue;
                }
                for &(offset, vertical, horizontal, step) in &steps {
                    let next = index.wrapping_add(offset);
                    // No cutting corners between two closed cells (for a diagonal step, the
                    // cells beside it are `index + vertical` and `index + horizontal`).
                    if !open[next]
                        || (vertical != 0
                            && !open[index.wrapping_add(vertical)]
                            && !open[index.wrapping_add(horizontal)])
                    {
                        continue;
                    }
                    let candidate = cost + step;
                    if candidate < self.cost_m[next] {
                        self.cost_m[next] = candidate;
                        let bucket = bucket_of(candidate);
                        debug_assert!(bucket > current && bucket < current + RING);
                        self.ring[bucket % RING].push((candidate, next));
                        pending += 1;
                    }
                }
            }
            cells.clear();
            self.ring[current % RING] = cells;
            current += 1;
        }
    }

    /// The path length from a point to the goal, in m: infinite outside the grid or where
    /// the goal cannot be reached.
    #[must_use]
    pub fn cost_m(&self, p: Vec2) -> f64 {
        match self.cell_of(p, 0) {
            Some((x, y)) => self.cost_m[self.index(x as usize, y as usize)],
            None => f64::INFINITY,
        }
    }

    /// The grid's cell size, in m.
    #[must_use]
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }
}

/// Which cells around an obstacle's cell can hold its closed cells, wherever in its cell the
/// obstacle is: the cell at offset (dx, dy) has its centre between `|dx| - 0.5` (at least
/// 0) and `|dx| + 0.5` cells from it along x, and so along y. Cells within the radius from
/// every place in the obstacle's cell are closed without a distance (a run of a row at
/// once), those beyond it from every place are never visited, and only the ring between
/// is measured: the same cells closed as measuring every cell of the square, for a third
/// of the measuring.
#[derive(Debug)]
struct Stencil {
    /// For each row offset from `-reach` to `reach`.
    rows: Vec<StencilRow>,
}

/// One row of a [`Stencil`]: its cells up to `inside` columns either side are surely
/// closed, those up to `unsure` either side (and beyond `inside`) must be measured.
#[derive(Debug, Clone, Copy)]
struct StencilRow {
    inside: Option<i64>,
    unsure: i64,
}

impl Stencil {
    /// A relative margin far wider than the rounding of a cell's centre and of
    /// [`Vec2::norm_at_most`]'s own band: what it leaves sure is sure.
    const MARGIN: f64 = 1e-6;

    fn new(radius_m: f64, cell_m: f64, reach: i64) -> Self {
        let radius_cells_squared = (radius_m / cell_m).powi(2);
        let usable = radius_cells_squared.is_normal() && radius_m > 0.0 && cell_m > 0.0;
        let distance = |dx: i64, dy: i64, toward: f64| {
            let along = |d: i64| (d.abs() as f64 + toward).max(0.0).powi(2);
            along(dx) + along(dy)
        };
        let rows = (-reach..=reach)
            .map(|dy| {
                if !usable {
                    return StencilRow {
                        inside: None,
                        unsure: reach,
                    };
                }
                let inside = (0..=reach)
                    .take_while(|&dx| {
                        distance(dx, dy, 0.5) < radius_cells_squared * (1.0 - Self::MARGIN)
                    })
                    .last();
                let unsure = (0..=reach)
                    .take_while(|&dx| {
                        distance(dx, dy, -0.5) <= radius_cells_squared * (1.0 + Self::MARGIN)
                    })
                    .last()
                    .unwrap_or(-1);
                StencilRow { inside, unsure }
            })
            .collect();
        Self { rows }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    /// The map as it was once built: hypot for every cell near an obstacle, Dijkstra with a
    /// binary heap. (origin, cell, width, height, costs row by row without a border.)
    #[allow(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss
    )]
    fn dijkstra(
        goal: Vec2,
        robot: Vec2,
        obstacles: &[Vec2],
        blocked_radius_m: f64,
        cell_m: f64,
        margin_m: f64,
        max_cells: usize,
    ) -> (Vec2, f64, usize, usize, Vec<f64>) {
        let lo = Vec2::new(
            goal.x.min(robot.x) - margin_m,
            goal.y.min(robot.y) - margin_m,
        );
        let hi = Vec2::new(
            goal.x.max(robot.x) + margin_m,
            goal.y.max(robot.y) + margin_m,
        );
        let span = hi - lo;
        let cell_m = cell_m.max((span.x * span.y / max_cells.max(1) as f64).sqrt());
        let w = ((span.x / cell_m).ceil() as usize).max(1);
        let h = ((span.y / cell_m).ceil() as usize).max(1);
        let cell_of = |p: Vec2| {
            let rel = p - lo;
            (
                (rel.x / cell_m).floor() as i64,
                (rel.y / cell_m).floor() as i64,
            )
        };
        let mut open = vec![true; w * h];
        let reach = (blocked_radius_m / cell_m).ceil() as i64;
        for &p in obstacles {
            let (cx, cy) = cell_of(p);
            for y in (cy - reach).max(0)..=(cy + reach).min(h as i64 - 1) {
                for x in (cx - reach).max(0)..=(cx + reach).min(w as i64 - 1) {
                    let centre =
                        lo + Vec2::new((x as f64 + 0.5) * cell_m, (y as f64 + 0.5) * cell_m);
                    if centre.distance(p) <= blocked_radius_m {
                        open[y as usize * w + x as usize] = false;
                    }
                }
            }
        }
        let mut cost = vec![f64::INFINITY; w * h];
        let (gx, gy) = cell_of(goal);
        let start = gy as usize * w + gx as usize;
        cost[start] = 0.0;
        let mut queue = BinaryHeap::new();
        queue.push(Reverse((0.0_f64.to_bits(), start)));
        while let Some(Reverse((bits, index))) = queue.pop() {
            let c = f64::from_bits(bits);
            if c > cost[index] {
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
                if !open[next] || (dx != 0 && dy != 0 && !open[y * w + nx] && !open[ny * w + x]) {
                    continue;
                }
                let step = if dx != 0 && dy != 0 { SQRT_2 } else { 1.0 } * cell_m;
                if c + step < cost[next] {
                    cost[next] = c + step;
                    queue.push(Reverse(((c + step).to_bits(), next)));
                }
            }
        }
        (lo, cell_m, w, h, cost)
    }

    #[test]
    fn costs_are_bit_for_bit_those_of_dijkstra_with_a_heap() {
        let mut rng = lewis_service::Rng::new(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_f64();
        // One map rebuilt again and again, as the avoider does.
        let mut map = GoalCostMap::default();
        let (mut reached, mut cells) = (0, 0);
        for case in 0..40 {
            let goal = Vec2::new(next() * 12.0, next() * 12.0);
            let robot = Vec2::new(next() * 12.0, next() * 12.0);
            // Walls (rows of close points) and scattered points.
            let mut obstacles = Vec::new();
            for _ in 0..6 {
                let (a, b) = (
                    Vec2::new(next() * 14.0 - 1.0, next() * 14.0 - 1.0),
                    Vec2::new(next() * 14.0 - 1.0, next() * 14.0 - 1.0),
                );
                for i in 0..100 {
                    obstacles.push(a + (b - a) * (f64::from(i) / 100.0));
                }
            }
            for _ in 0..200 {
                obstacles.push(Vec2::new(next() * 16.0 - 2.0, next() * 16.0 - 2.0));
            }
            let (max_cells, cell) = if case % 2 == 0 {
                (40_000, 0.1)
            } else {
                (2_000, 0.05)
            };
            let (origin, cell_m, width, height, costs) =
                dijkstra(goal, robot, &obstacles, 0.28, cell, 2.0, max_cells);
            map.rebuild(goal, robot, &obstacles, 0.28, cell, 2.0, max_cells);
            assert_eq!((map.origin, map.cell_m), (origin, cell_m));
            assert_eq!((map.width, map.height), (width, height));
            cells += width * height;
            for y in 0..height {
                for x in 0..width {
                    let expected = costs[y * width + x];
                    let got = map.cost_m[map.index(x, y)];
                    assert_eq!(
                        got.to_bits(),
                        expected.to_bits(),
                        "case {case}, cell ({x}, {y})"
                    );
                    reached += usize::from(expected.is_finite());
                }
            }
        }
        // Not a test of walled-in goals only.
        assert!(reached > cells / 5, "{reached} of {cells} cells reached");
    }

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
