//! The building's axes, learned from what the range finder sees: the walls and corridors of
//! a building are square to each other, so the directions of the straight stretches in the
//! scans, taken modulo 90 degrees, agree on one angle. The programs put their turn targets
//! on those axes rather than on the odometry frame's, which match the building only when the
//! robot started square to it (and drift from it as the odometry does).
//!
//! Echoes are kept in a grid of 10 cm cells in the odometry frame (each cell the mean of its
//! echoes, weighted, forgetting with a 15 s time constant), so that the walls of several
//! scans add up. Every half second each cell with enough neighbours within 0.5 m fits a
//! line to them; the cells whose neighbourhood is straight vote for its direction modulo 90
//! degrees, and the axis is the strongest direction, refined by the mean of its voters.
//! People and furniture are round or short, and vote little.
//!
//! Only a dense range finder teaches (a laser: 60 beams or more). A sonar ring's echoes,
//! each the nearest in a 25 degree cone and placed on the transducer's axis, draw a wall as
//! several parallel lines a few centimetres apart; tried in the simulated corridor, the
//! estimate wandered by 20 degrees. With no dense scan yet, the axes are the ones the program
//! was told to assume ([`BuildingAxes::assume`]): SignFollower and QueueStander assume the
//! heading they started with, which the state before them left on an axis (DoorNavigator on
//! the door's normal, from the door's jambs; SignFollower on the turn a sign asked for).

use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};

use lewis_geometry::{Pose2, Vec2, range_readings, wrap_angle};
use lewis_interfaces::msg::RangeFinder;

/// The grid's cell, in m.
const CELL_M: f64 = 0.1;
/// Echoes further than this are not kept, in m: far ones are sparse and noisy.
const MAX_RANGE_M: f64 = 6.0;
/// Cells further than this from the robot are dropped, in m.
const KEEP_M: f64 = 10.0;
/// How fast a cell is forgotten, in s (its weight falls by e in this time).
const FORGET_S: f64 = 15.0;
/// A cell lighter than this is dropped.
const MIN_WEIGHT: f64 = 0.05;
/// The neighbourhood a cell's line is fitted to, in cells (0.5 m).
const NEIGHBOURHOOD: i32 = 5;
/// A neighbourhood needs this many cells to fit a line.
const MIN_NEIGHBOURS: usize = 5;
/// A neighbourhood is straight when its spread across is below this share of its spread
/// along (the ratio of the covariance's eigenvalues).
const STRAIGHT_RATIO: f64 = 0.1;
/// Directions within this of the strongest one are its voters, in rad (4 degrees).
const VOTER_RAD: f64 = 0.07;
/// Histogram bins over 90 degrees.
const BINS: usize = 90;
/// The axes are known once this much wall (in cells, 10 cm each) agrees on them: 1.5 m.
const MIN_SUPPORT: f64 = 15.0;
/// A scan with fewer beams than this teaches nothing (see the module's documentation).
const MIN_BEAMS: usize = 60;
/// Echoes seen while the robot turns faster than this are not kept, in rad/s: a turning
/// sonar ring draws arcs, which are locally straight in the wrong directions (and a scan's
/// points are placed with a pose that is a little late).
const MAX_TURN_RATE: f64 = 0.15;
/// The wall met behind a point is fitted over the cells this near where it was met, in m.
const WALL_FIT_M: f64 = 0.3;
/// How often the axes are estimated again, in ns.
const ESTIMATE_EVERY_NS: i64 = 500_000_000;

/// A cell's echoes: their weighted sum and weight.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Cell {
    sum: Vec2,
    weight: f64,
}

impl Cell {
    fn mean(&self) -> Vec2 {
        self.sum * (1.0 / self.weight)
    }
}

/// The axes, as last estimated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axes {
    /// One axis' direction in the odometry frame, in [-pi/4, pi/4); the others are it plus
    /// multiples of 90 degrees.
    pub angle_rad: f64,
    /// How much wall agrees on it, in cells of 10 cm.
    pub support: f64,
}

/// The building's axes in the odometry frame, learned from range scans.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BuildingAxes {
    cells: BTreeMap<(i32, i32), Cell>,
    assumed: Option<f64>,
    last_ns: Option<i64>,
    /// The pose of the last scan, and when it was seen.
    last_pose: Option<(i64, Pose2)>,
    estimated_ns: Option<i64>,
    axes: Option<Axes>,
}

impl BuildingAxes {
    /// Axes known beforehand, along `angle_rad` (odometry): from a map, or in a test.
    #[must_use]
    pub fn along(angle_rad: f64) -> Self {
        Self {
            axes: Some(Axes {
                angle_rad: wrap_quarter(angle_rad),
                support: f64::INFINITY,
            }),
            ..Self::default()
        }
    }

    /// Takes a scan made at `now_ns` by a robot at `pose` (odometry).
    pub fn observe(&mut self, now_ns: i64, pose: Pose2, scan: &RangeFinder) {
        if scan.ranges.len() < MIN_BEAMS {
            return;
        }
        let turning = self.last_pose.is_some_and(|(at, last)| {
            let dt_s = (now_ns - at) as f64 * 1e-9;
            dt_s > 0.0
                && wrap_angle(pose.heading_rad - last.heading_rad).abs() / dt_s > MAX_TURN_RATE
        });
        self.last_pose = Some((now_ns, pose));
        if turning {
            self.observe_points(now_ns, pose.position(), &[]);
            return;
        }
        let points: Vec<Vec2> = range_readings(scan)
            .iter()
            .filter(|r| r.distance_m > 0.05 && r.distance_m < MAX_RANGE_M)
            .map(|r| pose.transform_point(Vec2::from_angle(r.bearing_rad) * r.distance_m))
            .collect();
        self.observe_points(now_ns, pose.position(), &points);
    }

    /// Takes echoes at `points` (odometry), seen at `now_ns` from `robot`.
    pub fn observe_points(&mut self, now_ns: i64, robot: Vec2, points: &[Vec2]) {
        let dt_s = self
            .last_ns
            .map_or(0.0, |last| (now_ns - last).max(0) as f64 * 1e-9);
        self.last_ns = Some(now_ns);
        if dt_s > 0.0 {
            let keep = (-dt_s / FORGET_S).exp();
            self.cells.retain(|&(i, j), cell| {
                cell.sum = cell.sum * keep;
                cell.weight *= keep;
                cell.weight >= MIN_WEIGHT && centre(i, j).distance(robot) <= KEEP_M
            });
        }
        for &p in points {
            if !(p.x.is_finite() && p.y.is_finite()) {
                continue;
            }
            let cell = self.cells.entry(key(p)).or_default();
            cell.sum = cell.sum + p;
            cell.weight += 1.0;
        }
        if self
            .estimated_ns
            .is_none_or(|at| now_ns - at >= ESTIMATE_EVERY_NS)
        {
            self.estimated_ns = Some(now_ns);
            self.axes = self.estimate().or(self.axes);
        }
    }

    /// Until axes are learned, takes `angle_rad` (odometry) for one of them.
    pub fn assume(&mut self, angle_rad: f64) {
        self.assumed = Some(wrap_quarter(angle_rad));
    }

    /// The axes learned, once enough wall was seen.
    #[must_use]
    pub fn axes(&self) -> Option<Axes> {
        self.axes
    }

    /// Whether the axes in use are learned (rather than assumed, or unknown).
    #[must_use]
    pub fn learned(&self) -> bool {
        self.axes.is_some()
    }

    /// The axis in use: the learned one, else the assumed one.
    fn angle(&self) -> Option<f64> {
        self.axes.map(|a| a.angle_rad).or(self.assumed)
    }

    /// `heading` (odometry) put on the nearest axis when within `snap_rad` of it; as it is
    /// when it is not, or the axes are not known yet.
    #[must_use]
    pub fn snap(&self, heading: f64, snap_rad: f64) -> f64 {
        let Some(angle) = self.angle() else {
            return heading;
        };
        let axis = nearest_axis(angle, heading);
        if wrap_angle(heading - axis).abs() < snap_rad {
            axis
        } else {
            heading
        }
    }

    /// The axis direction nearest `heading` (odometry), if the axes are known.
    #[must_use]
    pub fn nearest(&self, heading: f64) -> Option<f64> {
        self.angle().map(|a| nearest_axis(a, heading))
    }

    /// The direction (modulo 180 degrees) of the straight wall just behind `p` as seen from
    /// `from` (both odometry): the first wall the line of sight meets within `reach_m` past
    /// `p`, from the cells kept. That is the wall a sign at `p` hangs on; a sign on a post
    /// beside a wall has none behind it (the side wall is met far beyond, if at all).
    #[must_use]
    pub fn wall_behind(&self, from: Vec2, p: Vec2, reach_m: f64) -> Option<f64> {
        let seen = p - from;
        let length = seen.norm();
        if length.is_nan() || length <= 1e-6 {
            return None;
        }
        let dir = seen * (1.0 / length);
        // Half-cell steps, each looking at its cell's 3 x 3 block, so that a ray slipping
        // between two cells of a wall still meets it.
        let step = CELL_M / 2.0;
        let steps = (reach_m / step).ceil() as i32;
        let hit = (0..=steps)
            .map(|k| p + dir * (f64::from(k) * step))
            .find(|&q| {
                let (i, j) = key(q);
                (i - 1..=i + 1).any(|a| (j - 1..=j + 1).any(|b| self.cells.contains_key(&(a, b))))
            })?;
        self.wall_at(hit, WALL_FIT_M)
    }

    /// The direction (modulo 180 degrees) of the straight wall round `p`: the mean of the
    /// lines fitted at the cells within `radius_m`.
    fn wall_at(&self, p: Vec2, radius_m: f64) -> Option<f64> {
        let (ci, cj) = key(p);
        let reach = (radius_m / CELL_M).ceil() as i32;
        let (mut c, mut s, mut n) = (0.0, 0.0, 0);
        for i in ci - reach..=ci + reach {
            for (&(a, b), _) in self.cells.range((i, cj - reach)..=(i, cj + reach)) {
                if centre(a, b).distance(p) <= radius_m
                    && let Some(angle) = self.line_at(a, b)
                {
                    c += (2.0 * angle).cos();
                    s += (2.0 * angle).sin();
                    n += 1;
                }
            }
        }
        (n >= MIN_NEIGHBOURS).then(|| s.atan2(c) / 2.0)
    }

    /// The axes from the cells now: the strongest direction of the straight neighbourhoods.
    fn estimate(&self) -> Option<Axes> {
        let mut votes: Vec<(f64, f64)> = Vec::new();
        for (&(i, j), cell) in &self.cells {
            if let Some(angle) = self.line_at(i, j) {
                votes.push((angle, cell.weight.min(1.0)));
            }
        }
        let mut histogram = [0.0; BINS];
        for &(angle, weight) in &votes {
            histogram[bin(angle)] += weight;
        }
        // Smoothed over 5 degrees, round the 90 degrees.
        let smoothed = |b: usize| -> f64 {
            (0..5)
                .map(|k| histogram[(b + BINS + k - 2) % BINS])
                .sum::<f64>()
        };
        let peak = (0..BINS).max_by(|&a, &b| smoothed(a).total_cmp(&smoothed(b)))?;
        let peak_angle = (peak as f64 + 0.5) * FRAC_PI_2 / BINS as f64;
        // The mean of the voters near the peak, as angles times four (where 90 degrees
        // apart is the same).
        let (mut c, mut s, mut support) = (0.0, 0.0, 0.0);
        for &(angle, weight) in &votes {
            if wrap_quarter(angle - peak_angle).abs() <= VOTER_RAD {
                c += weight * (4.0 * angle).cos();
                s += weight * (4.0 * angle).sin();
                support += weight;
            }
        }
        (support >= MIN_SUPPORT).then(|| Axes {
            angle_rad: wrap_quarter(s.atan2(c) / 4.0),
            support,
        })
    }

    /// The direction of the line fitted to the cells round cell (i, j), when they are many
    /// and straight.
    fn line_at(&self, i: i32, j: i32) -> Option<f64> {
        let mut points = Vec::new();
        for a in i - NEIGHBOURHOOD..=i + NEIGHBOURHOOD {
            let column = self
                .cells
                .range((a, j - NEIGHBOURHOOD)..=(a, j + NEIGHBOURHOOD));
            for (&(_, b), cell) in column {
                if (a - i).pow(2) + (b - j).pow(2) <= NEIGHBOURHOOD.pow(2) {
                    points.push(cell.mean());
                }
            }
        }
        if points.len() < MIN_NEIGHBOURS {
            return None;
        }
        let n = points.len() as f64;
        let mean = points.iter().fold(Vec2::new(0.0, 0.0), |acc, p| acc + *p) * (1.0 / n);
        let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
        for p in &points {
            let d = *p - mean;
            xx += d.x * d.x;
            yy += d.y * d.y;
            xy += d.x * d.y;
        }
        let half_trace = (xx + yy) / 2.0;
        let root = (((xx - yy) / 2.0).powi(2) + xy * xy).sqrt();
        let (along, across) = (half_trace + root, half_trace - root);
        (along > 0.0 && across <= STRAIGHT_RATIO * along).then(|| 0.5 * (2.0 * xy).atan2(xx - yy))
    }
}

/// The cell of a point.
fn key(p: Vec2) -> (i32, i32) {
    ((p.x / CELL_M).floor() as i32, (p.y / CELL_M).floor() as i32)
}

/// The centre of cell (i, j).
fn centre(i: i32, j: i32) -> Vec2 {
    Vec2::new((f64::from(i) + 0.5) * CELL_M, (f64::from(j) + 0.5) * CELL_M)
}

/// An angle modulo 90 degrees, in [-pi/4, pi/4).
fn wrap_quarter(angle: f64) -> f64 {
    (angle + FRAC_PI_4).rem_euclid(FRAC_PI_2) - FRAC_PI_4
}

/// The histogram bin of a direction modulo 90 degrees.
fn bin(angle: f64) -> usize {
    let b = (angle.rem_euclid(FRAC_PI_2) / FRAC_PI_2 * BINS as f64) as usize;
    b.min(BINS - 1)
}

/// The direction `axis + k * 90 degrees` nearest `heading`.
fn nearest_axis(axis: f64, heading: f64) -> f64 {
    wrap_angle(axis + ((heading - axis) / FRAC_PI_2).round() * FRAC_PI_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The echoes of a robot at `robot` in a corridor along `angle`, 3 m wide, seen every
    /// 0.5 degrees out to 6 m, with a person standing in it.
    fn corridor(angle: f64, robot: Vec2) -> Vec<Vec2> {
        let along = Vec2::from_angle(angle);
        let across = along.perpendicular();
        let mut points = Vec::new();
        for k in -60..=60 {
            let t = f64::from(k) * 0.05;
            points.push(robot + along * t + across * 1.5);
            points.push(robot + along * t - across * 1.5);
        }
        let person = robot + along * 2.0 + across * 0.3;
        for k in 0..12 {
            points.push(person + Vec2::from_angle(f64::from(k) * 0.5) * 0.2);
        }
        points
    }

    fn learned(angle: f64) -> BuildingAxes {
        let mut axes = BuildingAxes::default();
        for step in 0..4 {
            let robot = Vec2::new(0.3, 0.1) + Vec2::from_angle(angle) * (f64::from(step) * 0.2);
            axes.observe_points(
                i64::from(step) * ESTIMATE_EVERY_NS,
                robot,
                &corridor(angle, robot),
            );
        }
        axes
    }

    #[test]
    fn a_corridor_gives_its_direction_whatever_the_robot_started_at() {
        for degrees in [0.0_f64, 10.0, 30.0, 44.0, -45.0, 135.0, -100.0] {
            let angle = degrees.to_radians();
            let axes = learned(angle).axes().expect("a corridor is enough");
            assert!(
                wrap_quarter(axes.angle_rad - angle).abs() < 0.5_f64.to_radians(),
                "{degrees} deg: {axes:?}"
            );
        }
    }

    #[test]
    fn headings_snap_to_the_learned_axes_not_the_odometry_frame() {
        let axes = learned(30_f64.to_radians());
        let snapped = axes.snap(10_f64.to_radians(), 0.45);
        assert!((snapped - 30_f64.to_radians()).abs() < 0.01, "{snapped}");
        let snapped = axes.snap(100_f64.to_radians(), 0.45);
        assert!((snapped - 120_f64.to_radians()).abs() < 0.01, "{snapped}");
        // Far from every axis: kept.
        assert_eq!(axes.snap(75_f64.to_radians(), 0.1), 75_f64.to_radians());
        // Nothing seen: nothing learned, nothing snapped.
        let mut blind = BuildingAxes::default();
        assert_eq!(blind.axes(), None);
        assert_eq!(blind.snap(0.3, 0.45), 0.3);
        // Assumed until learned.
        blind.assume(0.2);
        assert!((blind.snap(0.3, 0.45) - 0.2).abs() < 1e-12);
        assert!(!blind.learned());
    }

    #[test]
    fn scattered_echoes_teach_nothing() {
        let mut axes = BuildingAxes::default();
        let mut rng = lewis_service::Rng::new(7);
        let points: Vec<Vec2> = (0..400)
            .map(|_| Vec2::new(rng.uniform(-4.0, 4.0), rng.uniform(-4.0, 4.0)))
            .collect();
        axes.observe_points(0, Vec2::new(0.0, 0.0), &points);
        assert_eq!(axes.axes(), None);
    }

    #[test]
    fn what_is_left_behind_is_forgotten() {
        let mut axes = learned(0.0);
        assert!(!axes.cells.is_empty());
        axes.observe_points(120 * 1_000_000_000, Vec2::new(0.0, 0.0), &[]);
        assert!(axes.cells.is_empty(), "{} cells", axes.cells.len());
        // The axes last learned stay until others are.
        assert!(axes.axes().is_some());
    }
}
