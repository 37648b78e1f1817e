//! The occupancy grid read from the map image, and ray casting through it.

use lewis_geometry::Vec2;

use crate::geometry::RayHit;

/// Pixels darker than this (luma, 0 to 255) are walls.
pub const WALL_LUMA_THRESHOLD: u8 = 128;

/// A grid of square cells, each free or occupied (a wall). Cell (0, 0) is the bottom-left
/// one (the image's bottom row); everything outside the grid counts as occupied, so rays
/// and robots never leave the map.
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    width_cells: usize,
    height_cells: usize,
    metres_per_cell: f64,
    origin: Vec2,
    occupied: Vec<bool>,
}

impl OccupancyGrid {
    /// A grid from a predicate on cells `(column, row)`, row 0 at the bottom.
    #[must_use]
    pub fn from_fn(
        width_cells: usize,
        height_cells: usize,
        metres_per_cell: f64,
        origin: Vec2,
        mut occupied: impl FnMut(usize, usize) -> bool,
    ) -> Self {
        let mut cells = Vec::with_capacity(width_cells * height_cells);
        for row in 0..height_cells {
            for column in 0..width_cells {
                cells.push(occupied(column, row));
            }
        }
        Self {
            width_cells,
            height_cells,
            metres_per_cell,
            origin,
            occupied: cells,
        }
    }

    /// A grid from a greyscale image (top row first, as images are stored): dark pixels are
    /// walls.
    #[must_use]
    pub fn from_luma(image: &image::GrayImage, metres_per_cell: f64, origin: Vec2) -> Self {
        let (w, h) = image.dimensions();
        let (w, h) = (w as usize, h as usize);
        Self::from_fn(w, h, metres_per_cell, origin, |column, row| {
            // Row 0 of the grid is the image's last row.
            // both below the image's u32 size
            let pixel = image.get_pixel(column as u32, (h - 1 - row) as u32);
            pixel.0[0] < WALL_LUMA_THRESHOLD
        })
    }

    /// Width, in cells.
    #[must_use]
    pub fn width_cells(&self) -> usize {
        self.width_cells
    }

    /// Height, in cells.
    #[must_use]
    pub fn height_cells(&self) -> usize {
        self.height_cells
    }

    /// The side of a cell, in m.
    #[must_use]
    pub fn metres_per_cell(&self) -> f64 {
        self.metres_per_cell
    }

    /// The world position of the grid's bottom-left corner.
    #[must_use]
    pub fn origin(&self) -> Vec2 {
        self.origin
    }

    /// The world position of the grid's top-right corner.
    #[must_use]
    pub fn far_corner(&self) -> Vec2 {
        // grids are far smaller than 2^52 cells
        let size = Vec2::new(
            self.width_cells as f64 * self.metres_per_cell,
            self.height_cells as f64 * self.metres_per_cell,
        );
        self.origin + size
    }

    /// Whether cell (column, row) is a wall; cells outside the grid are.
    #[must_use]
    pub fn is_occupied(&self, column: i64, row: i64) -> bool {
        match (usize::try_from(column), usize::try_from(row)) {
            (Ok(c), Ok(r)) if c < self.width_cells && r < self.height_cells => {
                self.occupied[r * self.width_cells + c]
            }
            _ => true,
        }
    }

    /// The cell holding world point `p`.
    #[must_use]
    pub fn cell_of(&self, p: Vec2) -> (i64, i64) {
        let g = (p - self.origin) * (1.0 / self.metres_per_cell);
        // saturating casts of finite floors
        (g.x.floor() as i64, g.y.floor() as i64)
    }

    /// The first wall along the ray from `origin` in the unit direction `dir`, within
    /// `max_range_m`: a grid traversal visiting every cell the ray crosses, in order
    /// (Amanatides and Woo, 1987).
    #[must_use]
    pub fn cast_ray(&self, origin: Vec2, dir: Vec2, max_range_m: f64) -> Option<RayHit> {
        if ![origin.x, origin.y, dir.x, dir.y]
            .iter()
            .all(|v| v.is_finite())
        {
            return None; // a ray from nowhere sees nothing
        }
        let (mut column, mut row) = self.cell_of(origin);
        if self.is_occupied(column, row) {
            return Some(RayHit {
                range_m: 0.0,
                normal: -dir,
            });
        }
        let size = self.metres_per_cell;
        let local = origin - self.origin;
        let step_x: i64 = if dir.x > 0.0 { 1 } else { -1 };
        let step_y: i64 = if dir.y > 0.0 { 1 } else { -1 };
        // cell indices are small
        let boundary = |cell: i64, step: i64| (cell + i64::from(step > 0)) as f64 * size;
        // Distance along the ray to the next vertical and horizontal cell boundary, and
        // the distance between two such boundaries.
        let (mut t_max_x, t_delta_x) = if dir.x == 0.0 {
            (f64::INFINITY, f64::INFINITY)
        } else {
            (
                (boundary(column, step_x) - local.x) / dir.x,
                size / dir.x.abs(),
            )
        };
        let (mut t_max_y, t_delta_y) = if dir.y == 0.0 {
            (f64::INFINITY, f64::INFINITY)
        } else {
            (
                (boundary(row, step_y) - local.y) / dir.y,
                size / dir.y.abs(),
            )
        };
        loop {
            let (t, normal) = if t_max_x < t_max_y {
                column += step_x;
                let t = t_max_x;
                t_max_x += t_delta_x;
                (t, Vec2::new(-step_x as f64, 0.0))
            } else {
                row += step_y;
                let t = t_max_y;
                t_max_y += t_delta_y;
                (t, Vec2::new(0.0, -step_y as f64))
            };
            if t > max_range_m {
                return None;
            }
            if self.is_occupied(column, row) {
                return Some(RayHit {
                    range_m: t.max(0.0),
                    normal,
                });
            }
        }
    }

    /// Calls `visit` with the nearest point of every wall cell within `radius_m` of `p`.
    pub fn for_each_wall_point_within(&self, p: Vec2, radius_m: f64, mut visit: impl FnMut(Vec2)) {
        let (c0, r0) = self.cell_of(p - Vec2::new(radius_m, radius_m));
        let (c1, r1) = self.cell_of(p + Vec2::new(radius_m, radius_m));
        let size = self.metres_per_cell;
        for row in r0..=r1 {
            for column in c0..=c1 {
                if !self.is_occupied(column, row) {
                    continue;
                }
                let lo = self.origin + Vec2::new(column as f64 * size, row as f64 * size);
                let nearest = Vec2::new(p.x.clamp(lo.x, lo.x + size), p.y.clamp(lo.y, lo.y + size));
                if (nearest - p).norm() <= radius_m {
                    visit(nearest);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 m x 10 m room of 0.1 m cells with a wall column at x in [6.0, 6.1).
    fn room() -> OccupancyGrid {
        OccupancyGrid::from_fn(100, 100, 0.1, Vec2::new(0.0, 0.0), |c, _| c == 60)
    }

    fn check(origin: (f64, f64), angle: f64, expected_range: Option<f64>) {
        let hit = room().cast_ray(Vec2::new(origin.0, origin.1), Vec2::from_angle(angle), 20.0);
        match (hit, expected_range) {
            (None, None) => {}
            (Some(h), Some(r)) => assert!((h.range_m - r).abs() < 1e-9, "got {h:?}, want {r}"),
            (h, e) => panic!("from {origin:?} at {angle}: got {h:?}, expected {e:?}"),
        }
    }

    #[test]
    fn a_ray_stops_at_the_first_wall_cell() {
        check((1.05, 5.05), 0.0, Some(4.95));
        check(
            (1.0, 5.0),
            std::f64::consts::FRAC_PI_4,
            Some(5.0 * 2f64.sqrt()),
        );
        // Backwards it runs to the map's edge, which counts as a wall.
        check((1.05, 5.05), std::f64::consts::PI, Some(1.05));
    }

    #[test]
    fn a_ray_shorter_than_the_gap_hits_nothing() {
        let hit = room().cast_ray(Vec2::new(1.0, 5.0), Vec2::new(1.0, 0.0), 4.0);
        assert_eq!(hit, None);
    }

    #[test]
    fn a_ray_starting_in_a_wall_hits_at_zero() {
        check((6.05, 5.0), 1.0, Some(0.0));
    }

    #[test]
    fn wall_points_near_a_point_are_the_cells_nearest_points() {
        let mut points = Vec::new();
        room().for_each_wall_point_within(Vec2::new(5.8, 5.05), 0.25, |p| points.push(p));
        assert!(!points.is_empty());
        assert!(points.iter().all(|p| (p.x - 6.0).abs() < 1e-9));
    }
}
