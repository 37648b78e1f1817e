//! The occupancy grid being built: per cell, how often a beam ended in it (seen occupied)
//! and how often one passed through it (seen free), and from those counts the static map.
//!
//! Counts rather than log-odds, because the question asked of a cell is the share of
//! looks that saw it occupied: a wall is seen occupied whenever it is seen; a person who
//! walked by was seen occupied once or twice and free many times, and is left out.
//!
//! The grid grows as the run goes (its bounds are not known before the poses are), and
//! keeps beside the counts the scan matcher's likelihood field ([`crate::matcher`]).

use lewis_geometry::{Pose2, Vec2};

use crate::run::Scan;

/// When a cell counts as a static wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OccupancyRule {
    /// The fewest looks that ended in it.
    pub min_hits: u16,
    /// The least share of its looks that ended in it (0 to 1).
    pub occupied_share: f64,
    /// A cell seen occupied but below the share is "left out" (something that moved) when
    /// at least this many looks saw it free.
    pub min_free_looks: u16,
}

impl Default for OccupancyRule {
    /// One hit, 40% of the looks: a wall seen at a grazing angle is crossed by beams that
    /// end just behind it, so the share of a real wall is below one; a lower share keeps
    /// the fringe of walls and thickens them (measured on the CARMEN seattle and the
    /// Hokuyo logs: a quarter gave a held-out median of 4.1 and 4.0 cm, 40% 3.3 and 3.5).
    fn default() -> Self {
        Self {
            min_hits: 1,
            occupied_share: 0.4,
            min_free_looks: 4,
        }
    }
}

/// Radius of the matcher's kernel around an occupied cell, in cells.
const KERNEL_CELLS: i64 = 4;
/// Its width (standard deviation), in cells.
const KERNEL_SIGMA_CELLS: f64 = 1.5;

/// How far from a wall a cell must be to be left out as something that moved, in cells.
const FRINGE_CELLS: i64 = 2;

/// Neighbouring returns at most this far apart are one surface, in m.
const SURFACE_GAP_M: f64 = 0.2;

/// The most cells a grid may hold: 6 bytes each, 360 MB (a 380 m square at 5 cm). A run
/// that needs more has poses far off (or wants a coarser cell), and is refused rather than
/// let run the machine out of memory.
pub const MAX_CELLS: i64 = 60_000_000;

/// A grid that would grow beyond [`MAX_CELLS`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("the scans span {width_m:.0} m x {height_m:.0} m, more than a map holds at this cell size")]
pub struct TooBig {
    /// The width it would need, in m.
    pub width_m: f64,
    /// The height it would need, in m.
    pub height_m: f64,
}

/// A cell's place in the grid: column and row from the world origin, floor(x / size).
pub type Cell = [i64; 2];

/// The counts grid, growing to fit. Cells are squares of `metres_per_cell`; cell `[0, 0]`
/// has its lower-left corner at the world's origin.
#[derive(Debug, Clone)]
pub struct Grid {
    metres_per_cell: f64,
    rule: OccupancyRule,
    /// The cell stored first (lowest column and row).
    lo: Cell,
    width: usize,
    height: usize,
    hits: Vec<u16>,
    misses: Vec<u16>,
    /// The matcher's likelihood field, 0 to 255.
    field: Vec<u8>,
    /// Whether the cell's kernel is in the field.
    stamped: Vec<bool>,
    kernel: Vec<(i64, i64, u8)>,
}

impl Grid {
    /// An empty grid of square cells of `metres_per_cell`.
    #[must_use]
    pub fn new(metres_per_cell: f64, rule: OccupancyRule) -> Self {
        let mut kernel = Vec::new();
        for dy in -KERNEL_CELLS..=KERNEL_CELLS {
            for dx in -KERNEL_CELLS..=KERNEL_CELLS {
                let d2 = (dx * dx + dy * dy) as f64;
                let v = 255.0 * (-d2 / (2.0 * KERNEL_SIGMA_CELLS * KERNEL_SIGMA_CELLS)).exp();
                if v >= 1.0 {
                    // 1 to 255 by construction
                    kernel.push((dx, dy, v.round() as u8));
                }
            }
        }
        Self {
            metres_per_cell,
            rule,
            lo: [0, 0],
            width: 0,
            height: 0,
            hits: Vec::new(),
            misses: Vec::new(),
            field: Vec::new(),
            stamped: Vec::new(),
            kernel,
        }
    }

    /// The side of a cell, in m.
    #[must_use]
    pub fn metres_per_cell(&self) -> f64 {
        self.metres_per_cell
    }

    /// The cell holding world point `p`.
    #[must_use]
    pub fn cell_of(&self, p: Vec2) -> Cell {
        // saturating casts of finite floors; points are finite (checked by the caller)
        [
            (p.x / self.metres_per_cell).floor() as i64,
            (p.y / self.metres_per_cell).floor() as i64,
        ]
    }

    /// Bytes held, for the memory figure.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.hits.len() * 6
    }

    fn index(&self, cell: Cell) -> Option<usize> {
        let c = usize::try_from(cell[0] - self.lo[0]).ok()?;
        let r = usize::try_from(cell[1] - self.lo[1]).ok()?;
        (c < self.width && r < self.height).then(|| r * self.width + c)
    }

    /// The counts of `cell`: (seen occupied, seen free).
    #[must_use]
    pub fn counts(&self, cell: Cell) -> (u16, u16) {
        self.index(cell)
            .map_or((0, 0), |i| (self.hits[i], self.misses[i]))
    }

    fn occupied_counts(&self, hits: u16, misses: u16) -> bool {
        hits >= self.rule.min_hits
            && f64::from(hits) >= self.rule.occupied_share * (f64::from(hits) + f64::from(misses))
    }

    /// Whether `cell` is a static wall.
    #[must_use]
    pub fn is_occupied(&self, cell: Cell) -> bool {
        let (h, m) = self.counts(cell);
        self.occupied_counts(h, m)
    }

    /// Whether `cell` was seen occupied, but free in most looks, away from any wall:
    /// something that moved. The fringe of a wall (seen free by beams grazing it, occupied
    /// by the beams that end on it) is not: that is noise of the wall, not a passer-by.
    #[must_use]
    pub fn is_left_out(&self, cell: Cell) -> bool {
        let (h, m) = self.counts(cell);
        if h == 0 || self.occupied_counts(h, m) || m < self.rule.min_free_looks {
            return false;
        }
        let r = FRINGE_CELLS;
        !(-r..=r).any(|dy| (-r..=r).any(|dx| self.is_occupied([cell[0] + dx, cell[1] + dy])))
    }

    /// Whether any beam ended in or crossed `cell`.
    #[must_use]
    pub fn is_observed(&self, cell: Cell) -> bool {
        let (h, m) = self.counts(cell);
        h > 0 || m > 0
    }

    /// The lowest and highest observed cells, or `None` before any scan.
    #[must_use]
    pub fn observed_bounds(&self) -> Option<(Cell, Cell)> {
        let mut bounds: Option<(Cell, Cell)> = None;
        for r in 0..self.height {
            for c in 0..self.width {
                let i = r * self.width + c;
                if self.hits[i] > 0 || self.misses[i] > 0 {
                    // indices are below the grid's size, far below i64's range
                    let cell = [self.lo[0] + c as i64, self.lo[1] + r as i64];
                    bounds = Some(match bounds {
                        None => (cell, cell),
                        Some((lo, hi)) => (
                            [lo[0].min(cell[0]), lo[1].min(cell[1])],
                            [hi[0].max(cell[0]), hi[1].max(cell[1])],
                        ),
                    });
                }
            }
        }
        bounds
    }

    /// The matcher's field at `cell`, 0 to 255 (0 outside).
    #[must_use]
    pub fn field(&self, cell: Cell) -> u8 {
        self.index(cell).map_or(0, |i| self.field[i])
    }

    /// The field as the matcher reads it: the stored cells, their row length, and the
    /// first cell.
    pub(crate) fn field_view(&self) -> (&[u8], usize, usize, Cell) {
        (&self.field, self.width, self.height, self.lo)
    }

    /// Grows the storage to hold every cell from `lo` to `hi`, with a margin so that the
    /// grid is not copied for every scan.
    fn ensure(&mut self, lo: Cell, hi: Cell) -> Result<(), TooBig> {
        let inside = self.width > 0
            && lo[0] >= self.lo[0]
            && lo[1] >= self.lo[1]
            && hi[0] < self.lo[0] + self.width as i64
            && hi[1] < self.lo[1] + self.height as i64;
        if inside {
            return Ok(());
        }
        const MARGIN: i64 = 128;
        let (old_lo, old_w, old_h) = (self.lo, self.width, self.height);
        let (mut new_lo, mut new_hi) = (
            [lo[0] - MARGIN, lo[1] - MARGIN],
            [hi[0] + MARGIN, hi[1] + MARGIN],
        );
        if old_w > 0 {
            new_lo = [new_lo[0].min(old_lo[0]), new_lo[1].min(old_lo[1])];
            new_hi = [
                new_hi[0].max(old_lo[0] + old_w as i64 - 1),
                new_hi[1].max(old_lo[1] + old_h as i64 - 1),
            ];
        }
        let (w, h) = (new_hi[0] - new_lo[0] + 1, new_hi[1] - new_lo[1] + 1);
        if w.saturating_mul(h) > MAX_CELLS {
            return Err(TooBig {
                width_m: w as f64 * self.metres_per_cell,
                height_m: h as f64 * self.metres_per_cell,
            });
        }
        // positive and below MAX_CELLS
        let (w, h) = (w as usize, h as usize);
        let mut hits = vec![0; w * h];
        let mut misses = vec![0; w * h];
        let mut field = vec![0; w * h];
        let mut stamped = vec![false; w * h];
        for r in 0..old_h {
            let src = r * old_w;
            // the old grid lies inside the new one
            let dst = ((old_lo[1] - new_lo[1]) as usize + r) * w + (old_lo[0] - new_lo[0]) as usize;
            hits[dst..dst + old_w].copy_from_slice(&self.hits[src..src + old_w]);
            misses[dst..dst + old_w].copy_from_slice(&self.misses[src..src + old_w]);
            field[dst..dst + old_w].copy_from_slice(&self.field[src..src + old_w]);
            stamped[dst..dst + old_w].copy_from_slice(&self.stamped[src..src + old_w]);
        }
        self.lo = new_lo;
        self.width = w;
        self.height = h;
        self.hits = hits;
        self.misses = misses;
        self.field = field;
        self.stamped = stamped;
        Ok(())
    }

    /// Adds `scan` taken at robot pose `pose`: every return's end cell seen occupied, the
    /// cells its beam crossed seen free. Beams without a return say nothing (glass, a
    /// black surface, or nothing within range: free space is not certain).
    ///
    /// # Errors
    /// When the grid would grow beyond [`MAX_CELLS`] (nothing is added then).
    pub fn insert(&mut self, scan: &Scan, pose: Pose2) -> Result<(), TooBig> {
        let sensor = pose.transform_point(scan.mount_m);
        if !sensor.is_finite() {
            return Ok(());
        }
        let mut ends: Vec<Cell> = Vec::with_capacity(scan.ranges_m.len());
        // Neighbouring returns close together, on a surface facing the sensor, are one
        // surface: the cells between them are walls too. Without this, a wall seen only
        // from far, where beams are a cell or more apart, is a dotted line that other
        // scans' beams pass through.
        let mut surfaces: Vec<(Cell, Cell)> = Vec::new();
        let mut previous: Option<(usize, Vec2, Vec2)> = None;
        let start = self.cell_of(sensor);
        let (mut lo, mut hi) = (start, start);
        for (i, &r) in scan.ranges_m.iter().enumerate() {
            if !scan.is_return(r) {
                continue;
            }
            let end =
                sensor + Vec2::from_angle(pose.heading_rad + scan.bearing_rad(i)) * f64::from(r);
            if !end.is_finite() {
                continue;
            }
            let cell = self.cell_of(end);
            let dir = Vec2::from_angle(pose.heading_rad + scan.bearing_rad(i));
            if let Some((j, p, _)) = previous
                && j + 1 == i
            {
                let gap = end - p;
                let length = gap.norm();
                // Facing: the gap runs across the beam, not along it (an edge between a
                // near and a far surface runs along the beams).
                if length <= SURFACE_GAP_M && gap.dot(dir).abs() <= 0.7 * length {
                    surfaces.push((self.cell_of(p), cell));
                }
            }
            previous = Some((i, end, dir));
            lo = [lo[0].min(cell[0]), lo[1].min(cell[1])];
            hi = [hi[0].max(cell[0]), hi[1].max(cell[1])];
            ends.push(cell);
        }
        self.ensure(lo, hi)?;
        for (a, b) in surfaces {
            self.fill(a, b);
        }
        for end in ends {
            self.trace(start, end);
            if let Some(i) = self.index(end) {
                self.hits[i] = self.hits[i].saturating_add(1);
                if !self.stamped[i] && self.occupied_counts(self.hits[i], self.misses[i]) {
                    self.stamp(end, i);
                }
            }
        }
        Ok(())
    }

    /// Marks the cells from `from` up to (not including) `to` seen free: Bresenham's line.
    fn trace(&mut self, from: Cell, to: Cell) {
        let (dx, dy) = ((to[0] - from[0]).abs(), -(to[1] - from[1]).abs());
        let (sx, sy) = ((to[0] - from[0]).signum(), (to[1] - from[1]).signum());
        let (mut x, mut y, mut err) = (from[0], from[1], dx + dy);
        while [x, y] != to {
            if let Some(i) = self.index([x, y]) {
                self.misses[i] = self.misses[i].saturating_add(1);
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// Marks the cells strictly between `a` and `b` seen occupied (a surface between two
    /// returns). They get no kernel in the matcher's field: the matcher leans on readings.
    fn fill(&mut self, a: Cell, b: Cell) {
        let (dx, dy) = ((b[0] - a[0]).abs(), -(b[1] - a[1]).abs());
        let (sx, sy) = ((b[0] - a[0]).signum(), (b[1] - a[1]).signum());
        let (mut x, mut y, mut err) = (a[0], a[1], dx + dy);
        while [x, y] != b {
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
            if [x, y] != b
                && let Some(i) = self.index([x, y])
            {
                self.hits[i] = self.hits[i].saturating_add(1);
            }
        }
    }

    /// Puts the kernel of the occupied cell `cell` (at index `i`) into the field. Cells that
    /// are later seen free often enough to leave the map keep their kernel: the field only
    /// guides the matcher, and a person who stood still long enough to be mapped is
    /// something the matcher may lean on for as long as they stood.
    fn stamp(&mut self, cell: Cell, i: usize) {
        self.stamped[i] = true;
        for k in 0..self.kernel.len() {
            let (dx, dy, v) = self.kernel[k];
            if let Some(j) = self.index([cell[0] + dx, cell[1] + dy]) {
                self.field[j] = self.field[j].max(v);
            }
        }
    }

    /// How many cells are static walls, and how many were left out as things that moved.
    #[must_use]
    pub fn census(&self) -> (u64, u64) {
        let (mut occupied, mut left_out) = (0, 0);
        for r in 0..self.height {
            for c in 0..self.width {
                let i = r * self.width + c;
                if self.occupied_counts(self.hits[i], self.misses[i]) {
                    occupied += 1;
                } else if self.hits[i] > 0 {
                    // indices are below the grid's size, far below i64's range
                    let cell = [self.lo[0] + c as i64, self.lo[1] + r as i64];
                    left_out += u64::from(self.is_left_out(cell));
                }
            }
        }
        (occupied, left_out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scan of `n` beams over 180 degrees, every beam at `range_m`.
    pub(crate) fn scan(ranges_m: Vec<f32>) -> Scan {
        let n = ranges_m.len();
        Scan {
            time_ns: 0,
            ranges_m,
            first_bearing_rad: -std::f64::consts::FRAC_PI_2,
            step_rad: std::f64::consts::PI / (n - 1) as f64,
            mount_m: Vec2::new(0.0, 0.0),
            max_range_m: 8.0,
            recorded_pose: None,
        }
    }

    #[test]
    fn a_beam_marks_its_end_occupied_and_its_way_free() {
        let mut grid = Grid::new(0.1, OccupancyRule::default());
        // One beam straight ahead (bearing 0) of 1.05 m from (0.05, 0.05).
        let mut s = scan(vec![8.0, 1.0, 8.0]);
        s.ranges_m[1] = 1.0;
        grid.insert(&s, Pose2::new(0.05, 0.05, 0.0)).unwrap();
        assert!(grid.is_occupied([10, 0]));
        assert_eq!(grid.counts([10, 0]), (1, 0));
        for c in 0..10 {
            assert_eq!(grid.counts([c, 0]), (0, 1), "cell {c}");
            assert!(!grid.is_occupied([c, 0]));
        }
        // No-return beams (8 m, the max) say nothing.
        assert!(!grid.is_observed([0, 20]));
    }

    #[test]
    fn a_cell_seen_free_far_more_often_than_occupied_is_left_out() {
        let mut grid = Grid::new(0.1, OccupancyRule::default());
        let mut person = scan(vec![8.0, 1.0, 8.0]);
        person.ranges_m[1] = 1.0;
        grid.insert(&person, Pose2::new(0.05, 0.05, 0.0)).unwrap();
        let mut wall = scan(vec![8.0, 3.0, 8.0]);
        wall.ranges_m[1] = 3.0;
        for _ in 0..9 {
            grid.insert(&wall, Pose2::new(0.05, 0.05, 0.0)).unwrap();
        }
        assert!(grid.is_left_out([10, 0]));
        assert!(!grid.is_occupied([10, 0]));
        assert!(grid.is_occupied([30, 0]));
        assert_eq!(grid.census(), (1, 1));
    }

    #[test]
    fn neighbouring_returns_on_a_wall_close_the_gap_between_them() {
        let mut grid = Grid::new(0.02, OccupancyRule::default());
        let mut s = scan(vec![2.0, 2.0, 2.0]);
        s.first_bearing_rad = -0.05;
        s.step_rad = 0.05;
        grid.insert(&s, Pose2::new(0.0, 0.0, 0.0)).unwrap();
        // The returns are 5 cells apart; the cells between them are walls.
        for rows in [-4..=-1, 1..=4] {
            assert!(
                rows.clone()
                    .all(|r| (99..=100).any(|c| grid.is_occupied([c, r]))),
                "rows {rows:?}"
            );
        }
        // A near and a far return side by side are not one surface.
        let mut edge = Grid::new(0.02, OccupancyRule::default());
        let mut s = scan(vec![1.0, 1.15, 8.0]);
        s.first_bearing_rad = 0.0;
        s.step_rad = 0.001;
        edge.insert(&s, Pose2::new(0.0, 0.0, 0.0)).unwrap();
        assert!(!(51..=56).any(|c| edge.is_occupied([c, 0])));
    }

    #[test]
    fn the_grid_grows_without_losing_counts() {
        let mut grid = Grid::new(0.05, OccupancyRule::default());
        let mut s = scan(vec![8.0, 2.0, 8.0]);
        s.ranges_m[1] = 2.0;
        grid.insert(&s, Pose2::new(0.0, 0.0, 0.0)).unwrap();
        grid.insert(&s, Pose2::new(-30.0, 40.0, 1.0)).unwrap();
        assert!(grid.is_occupied(grid.cell_of(Vec2::new(2.001, 0.001))));
        let far = Pose2::new(-30.0, 40.0, 1.0).transform_point(Vec2::new(2.0, 0.0));
        assert!(grid.is_occupied(grid.cell_of(far)));
        assert!(grid.field(grid.cell_of(far)) == 255);
    }
}
