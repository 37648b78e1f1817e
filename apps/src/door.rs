//! DoorNavigator: through the open door ahead.
//!
//! A doorway is a gap in the scan: beams much longer than the two beams beside them (the
//! jambs), the jambs at least `--door-width` apart. The program picks the doorway nearest
//! ahead, goes to a point 0.8 m before its centre on its normal, then 1.5 m past it, and
//! finishes (0) once the odometry is 1 m past the door line. With no doorway in sight it
//! turns in 45 degree steps; after a full turn it goes towards a direction sign it read (the
//! lobby's stands beside its door), else towards the middle of what it saw (a start in a
//! corner sees the far side of the room at the laser's edge), and looks again, twice; after
//! that, or a minute, it gives up (4).

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{RangeFinder, SignArrow, Signs};
use lewis_service::{Context, Input};

use crate::common::driver::{Driver, moving_service};
use crate::common::exit;
use crate::common::watch::DEFAULT_STALE_NS;
use crate::sign::SignBook;

/// What DoorNavigator asks the broker for.
pub const REQUIRES: &[&str] = &["RangeFinder", "Egomotion", "Mover", "Signs"];

/// A beam is "much longer" than a jamb by this much, in m.
const DEPTH_M: f64 = 0.8;
/// The widest gap taken for a door, in m: anything wider is open space.
const MAX_DOOR_WIDTH_M: f64 = 2.5;
/// The approach point, before the door's centre on its normal, in m.
const APPROACH_M: f64 = 0.8;
/// The goal past the door, in m.
const PAST_M: f64 = 1.5;
/// Done once this far past the door line, in m.
const DONE_PAST_M: f64 = 1.0;
/// A sighting within this of the door followed refines it, in m.
const SAME_DOOR_M: f64 = 0.6;
/// Doorways further off the heading than this are not "ahead", in rad.
const AHEAD_RAD: f64 = 1.2;
/// The approach point counts as reached within this, in m.
const REACHED_M: f64 = 0.25;
/// Turns of 45 degrees before giving up: a full turn.
const SEARCH_TURNS: u32 = 8;
/// Scans without a doorway before turning.
const SCANS_BEFORE_TURN: u32 = 10;
/// Moves to the middle of what it saw before giving up.
const SEARCH_MOVES: u32 = 2;
/// A move goes at most this far, in m.
const MOVE_M: f64 = 3.0;
/// A move towards a sign stops this far before it, in m.
const BEFORE_SIGN_M: f64 = 1.5;
/// The middle of what it saw is not worth going to when nearer than this, in m.
const MIN_MOVE_M: f64 = 0.8;

/// DoorNavigator's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DoorConfig {
    /// The narrowest gap taken for a door, in m.
    pub min_width_m: f64,
    /// How long an input may be silent, in ns.
    pub stale_ns: i64,
    /// When it gives up, in ns from its start.
    pub timeout_ns: i64,
}

impl Default for DoorConfig {
    fn default() -> Self {
        Self {
            min_width_m: 0.9,
            stale_ns: DEFAULT_STALE_NS,
            timeout_ns: 60_000_000_000,
        }
    }
}

/// A doorway seen in a scan, in the frame of the scan's points (the robot's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Doorway {
    /// The jamb at the lower bearing.
    pub a: Vec2,
    /// The jamb at the higher bearing.
    pub b: Vec2,
}

impl Doorway {
    /// Its centre.
    #[must_use]
    pub fn centre(&self) -> Vec2 {
        (self.a + self.b) * 0.5
    }

    /// Its width, in m.
    #[must_use]
    pub fn width(&self) -> f64 {
        self.a.distance(self.b)
    }

    /// The unit normal of the door line pointing away from `from` (through the door).
    #[must_use]
    pub fn normal_from(&self, from: Vec2) -> Vec2 {
        let along = self.b - self.a;
        let n = along.perpendicular() * (1.0 / along.norm().max(1e-9));
        if n.dot(self.centre() - from) >= 0.0 {
            n
        } else {
            -n
        }
    }
}

/// Each beam of a scan: its end point in the robot frame, its range, and whether it saw
/// nothing (max range).
fn beams(scan: &RangeFinder) -> Vec<(Vec2, f64, bool)> {
    let n = scan.ranges.len();
    (0..n)
        .filter_map(|i| {
            let (x, y, theta) = if scan.uniform {
                let k = i as f64;
                (
                    scan.x_offset + k * scan.x_separation,
                    scan.y_offset + k * scan.y_separation,
                    scan.theta_offset + k * scan.theta_separation,
                )
            } else {
                let p = scan.sensor_positions.get(i)?;
                (p.x, p.y, p.theta)
            };
            let raw = scan.ranges[i];
            let far = !raw.is_finite() || raw >= scan.max_range * 0.995;
            let range = if far { scan.max_range } else { raw.max(0.0) };
            let point = Vec2::new(x, y) + Vec2::from_angle(theta) * range;
            Some((point, range, far))
        })
        .collect()
}

/// The doorways of a scan at least `min_width_m` wide (see the module documentation), in
/// the order of their bearings.
#[must_use]
pub fn find_doorways(scan: &RangeFinder, min_width_m: f64) -> Vec<Doorway> {
    let beams = beams(scan);
    let mut found = Vec::new();
    let mut i = 0;
    while i + 2 < beams.len() {
        let (a, ra, a_far) = beams[i];
        if a_far || beams[i + 1].1 <= ra + DEPTH_M {
            i += 1;
            continue;
        }
        // A rising edge at i: the gap ends where a beam comes back near.
        let Some(j) =
            (i + 2..beams.len()).find(|&j| !beams[j].2 && beams[j - 1].1 > beams[j].1 + DEPTH_M)
        else {
            break;
        };
        let (b, rb, _) = beams[j];
        let floor = ra.max(rb) + DEPTH_M * 0.5;
        let deep = beams[i + 1..j].iter().all(|(_, r, _)| *r > floor);
        let door = Doorway { a, b };
        if deep && (min_width_m..=MAX_DOOR_WIDTH_M).contains(&door.width()) {
            found.push(door);
        }
        i = j;
    }
    found
}

/// The doorway nearest ahead of the robot (at the origin, facing +x), if any is ahead.
#[must_use]
pub fn nearest_ahead(doorways: &[Doorway]) -> Option<Doorway> {
    doorways
        .iter()
        .filter(|d| d.centre().angle().abs() < AHEAD_RAD)
        .min_by(|x, y| {
            let score = |d: &Doorway| d.centre().angle().abs() + 0.05 * d.centre().norm();
            score(x).total_cmp(&score(y))
        })
        .copied()
}

/// Where the program is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// No door yet: looking, and turning after a while; `moves` moves made.
    Search {
        scans_without: u32,
        turns: u32,
        moves: u32,
    },
    /// No door all around: to `goal`, the middle of what it saw, to look again from there.
    Relocate { goal: Vec2, moves: u32 },
    /// To the point before the door (odometry frame).
    Approach { centre: Vec2, normal: Vec2 },
    /// Through it.
    Through { centre: Vec2, normal: Vec2 },
}

/// The DoorNavigator program.
#[derive(Debug)]
pub struct DoorNavigator {
    config: DoorConfig,
    driver: Driver,
    phase: Phase,
    /// The direction signs read (odometry): a hint of where the way out is.
    signs: SignBook,
    /// The weighted sum of the middle of each beam's area since the search last moved
    /// (odometry), and the weight.
    seen: (Vec2, f64),
}

impl DoorNavigator {
    /// The program with its settings.
    #[must_use]
    pub fn new(config: DoorConfig) -> Self {
        Self {
            driver: Driver::new(&["RangeFinder", "Egomotion"], config.stale_ns),
            config,
            phase: Phase::Search {
                scans_without: 0,
                turns: 0,
                moves: 0,
            },
            signs: SignBook::default(),
            seen: (Vec2::default(), 0.0),
        }
    }

    fn on_scan(&mut self, ctx: &mut Context<'_>, scan: &RangeFinder) {
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        let seen = nearest_ahead(&find_doorways(scan, self.config.min_width_m)).map(|d| {
            let centre = pose.transform_point(d.centre());
            let normal = d.normal_from(Vec2::default()).rotated(pose.heading_rad);
            (centre, normal)
        });
        if let Phase::Search { .. } = self.phase {
            // The centroid of the area seen: each beam a thin triangle of area r^2 / 2,
            // whose centroid is 2/3 of the way out.
            for (point, range, _) in beams(scan) {
                let weight = range * range;
                let out = pose.transform_point(point * (2.0 / 3.0));
                self.seen.0 = self.seen.0 + out * weight;
                self.seen.1 += weight;
            }
        }
        match self.phase {
            Phase::Search {
                scans_without,
                turns,
                moves,
            } => {
                if let Some((centre, normal)) = seen {
                    ctx.info(&format!(
                        "a doorway at {:.2},{:.2} (odometry): going to it",
                        centre.x, centre.y
                    ));
                    self.phase = Phase::Approach { centre, normal };
                    self.driver.mover.goto(ctx, centre - normal * APPROACH_M);
                } else {
                    self.phase = Phase::Search {
                        scans_without: scans_without + 1,
                        turns,
                        moves,
                    };
                }
            }
            Phase::Approach { centre, normal } => {
                if let Some((c, n)) = seen
                    && c.distance(centre) < SAME_DOOR_M
                {
                    // Nearer sightings are better ones: follow them, smoothly.
                    let centre = centre * 0.7 + c * 0.3;
                    let mixed = normal * 0.7 + n * 0.3;
                    let normal = mixed * (1.0 / mixed.norm().max(1e-9));
                    self.phase = Phase::Approach { centre, normal };
                    self.driver.mover.goto(ctx, centre - normal * APPROACH_M);
                }
            }
            Phase::Relocate { .. } | Phase::Through { .. } => {}
        }
    }

    fn other_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        match input.interface {
            "RangeFinder" => {
                if let Ok(scan) = input.decode::<RangeFinder>() {
                    self.on_scan(ctx, &scan);
                }
            }
            "Signs" => {
                if let (Ok(signs), Some(pose)) =
                    (input.decode::<Signs>(), self.driver.odometry.pose())
                {
                    self.signs.read(pose, &signs);
                }
            }
            _ => {}
        }
    }

    /// After a whole turn without a doorway: towards the nearest direction sign read, else
    /// the middle of what it saw; or gives up.
    fn search_elsewhere(&mut self, ctx: &mut Context<'_>, here: Vec2, moves: u32) {
        let (sum, weight) = std::mem::take(&mut self.seen);
        if moves >= SEARCH_MOVES {
            self.driver
                .finish(ctx, exit::GAVE_UP, "no doorway all around");
            return;
        }
        let sign = self
            .signs
            .settled()
            .filter(|(_, _, arrow)| *arrow != SignArrow::Desk)
            .map(|(_, track, _)| track.position)
            .filter(|p| p.distance(here) > BEFORE_SIGN_M + MIN_MOVE_M)
            .min_by(|a, b| a.distance(here).total_cmp(&b.distance(here)));
        let goal = if let Some(sign) = sign {
            let goal = sign + (here - sign) * (BEFORE_SIGN_M / here.distance(sign));
            ctx.info(&format!(
                "no doorway all around: looking again from {:.2},{:.2} (odometry), before the direction sign at {:.2},{:.2}",
                goal.x, goal.y, sign.x, sign.y
            ));
            goal
        } else {
            let off = sum * (1.0 / weight.max(1e-9)) - here;
            if weight <= 0.0 || off.norm() < MIN_MOVE_M {
                self.driver
                    .finish(ctx, exit::GAVE_UP, "no doorway all around");
                return;
            }
            let goal = here + off * (off.norm().min(MOVE_M) / off.norm());
            ctx.info(&format!(
                "no doorway all around: looking again from {:.2},{:.2} (odometry), nearer the middle of the room",
                goal.x, goal.y
            ));
            goal
        };
        self.phase = Phase::Relocate {
            goal,
            moves: moves + 1,
        };
        self.driver.mover.goto(ctx, goal);
    }

    fn step(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let started = *self.driver.started_ns.get_or_insert(now);
        if let Some(lost) = self.driver.watch.lost(now) {
            self.driver
                .finish(ctx, exit::INPUT_LOST, &format!("no {lost} for too long"));
            return;
        }
        if now - started > self.config.timeout_ns {
            self.driver
                .finish(ctx, exit::GAVE_UP, "not through a door in time");
            return;
        }
        self.driver.mover.tick(ctx);
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        match self.phase {
            Phase::Search {
                scans_without,
                turns,
                moves,
            } => {
                if scans_without >= SCANS_BEFORE_TURN
                    && (self.driver.mover.wanted().is_none() || self.driver.mover.arrived())
                {
                    if turns >= SEARCH_TURNS {
                        self.search_elsewhere(ctx, pose.position(), moves);
                        return;
                    }
                    self.driver.mover.rotate(ctx, std::f64::consts::FRAC_PI_4);
                    self.phase = Phase::Search {
                        scans_without: 0,
                        turns: turns + 1,
                        moves,
                    };
                }
            }
            Phase::Relocate { goal, moves } => {
                if pose.position().distance(goal) < REACHED_M || self.driver.mover.arrived() {
                    self.phase = Phase::Search {
                        scans_without: 0,
                        turns: 0,
                        moves,
                    };
                    self.driver.mover.stop(ctx);
                }
            }
            Phase::Approach { centre, normal } => {
                let target = centre - normal * APPROACH_M;
                if pose.position().distance(target) < REACHED_M || self.driver.mover.arrived() {
                    ctx.info("before the door: going through");
                    self.phase = Phase::Through { centre, normal };
                    self.driver.mover.goto(ctx, centre + normal * PAST_M);
                }
            }
            Phase::Through { .. } => {}
        }
        if let Phase::Approach { centre, normal } | Phase::Through { centre, normal } = self.phase
            && (pose.position() - centre).dot(normal) >= DONE_PAST_M
        {
            self.driver.finish(ctx, exit::SUCCESS, "through the door");
        }
    }
}

moving_service!(DoorNavigator);

#[cfg(test)]
mod tests {
    use super::*;

    /// A 181-beam scan over 180 degrees from `ranges(bearing)`.
    fn scan(ranges: impl Fn(f64) -> f64) -> RangeFinder {
        let n = 181;
        let step = std::f64::consts::PI / 180.0;
        RangeFinder {
            range_count: n,
            ranges: (0..n)
                .map(|i| ranges(-std::f64::consts::FRAC_PI_2 + f64::from(i) * step))
                .collect(),
            max_range: 8.0,
            uniform: true,
            theta_offset: -std::f64::consts::FRAC_PI_2,
            theta_separation: step,
            ..RangeFinder::default()
        }
    }

    /// A wall across at x = `wall_x` with a gap from y0 to y1, and nothing beyond it.
    fn wall_with_gap(wall_x: f64, y0: f64, y1: f64) -> RangeFinder {
        scan(|bearing| {
            let y = wall_x * bearing.tan();
            if bearing.abs() < 1.5 && (y0..=y1).contains(&y) {
                8.0
            } else if bearing.abs() < 1.5 {
                (wall_x / bearing.cos()).min(8.0)
            } else {
                8.0
            }
        })
    }

    #[test]
    fn a_gap_in_a_wall_is_a_doorway_with_its_jambs_and_normal() {
        let doors = find_doorways(&wall_with_gap(4.0, -0.5, 1.0), 0.9);
        assert_eq!(doors.len(), 1, "{doors:?}");
        let door = doors[0];
        assert!((door.width() - 1.5).abs() < 0.15, "{door:?}");
        assert!(
            door.centre().distance(Vec2::new(4.0, 0.25)) < 0.1,
            "{door:?}"
        );
        let n = door.normal_from(Vec2::default());
        assert!(n.distance(Vec2::new(1.0, 0.0)) < 0.05, "{n:?}");
        assert_eq!(nearest_ahead(&doors), Some(door));
    }

    #[test]
    fn narrow_gaps_and_open_space_are_not_doors() {
        assert!(find_doorways(&wall_with_gap(4.0, 0.0, 0.6), 0.9).is_empty());
        assert!(find_doorways(&wall_with_gap(4.0, -2.0, 2.0), 0.9).is_empty());
        assert!(find_doorways(&scan(|_| 8.0), 0.9).is_empty());
        assert!(find_doorways(&scan(|_| 3.0), 0.9).is_empty());
    }

    #[test]
    fn of_two_doorways_the_one_nearest_ahead_is_taken() {
        let left = Doorway {
            a: Vec2::new(2.0, 2.0),
            b: Vec2::new(1.0, 2.5),
        };
        let ahead = Doorway {
            a: Vec2::new(4.0, -0.6),
            b: Vec2::new(4.0, 0.6),
        };
        assert_eq!(nearest_ahead(&[left, ahead]), Some(ahead));
        let behind = Doorway {
            a: Vec2::new(-4.0, -0.6),
            b: Vec2::new(-4.0, 0.6),
        };
        assert_eq!(nearest_ahead(&[behind]), None);
    }
}
