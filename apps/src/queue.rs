//! QueueStander: joins the queue in front of the registration desk and moves up with it.
//!
//! The desk is where its sign is (remembered in the odometry frame once read). The queue
//! stands on the desk's normal, taken as the direction from the desk to the robot put on the
//! nearest axis of the building, learned from the scans (see [`crate::common::axes`]; the
//! desk is square to the hall). Each scan places the
//! people near that line; the robot's place is 1.1 m behind the last person ahead of it
//! (0.8 m between them), or 1 m before the desk when nobody is. It finishes (0) there, at
//! the head. It stops whenever anything is nearer than 0.6 m in front, and gives up (4)
//! after `--timeout`.

use lewis_geometry::{Vec2, range_readings, wrap_angle};
use lewis_interfaces::msg::{RangeFinder, SignArrow, Signs};
use lewis_service::{Context, Input};

use crate::common::axes::BuildingAxes;
use crate::common::driver::{Driver, moving_service};
use crate::common::exit;
use crate::common::watch::DEFAULT_STALE_NS;
use crate::sign::SignBook;

/// What QueueStander asks the broker for.
pub const REQUIRES: &[&str] = &["Signs", "RangeFinder", "Egomotion", "Mover"];

/// The head of the queue stands this far before the desk's sign, in m.
const HEAD_M: f64 = 1.0;
/// The robot's centre stays this far behind the person ahead's nearest point, in m
/// (0.8 m between them and the robot's radius).
const BEHIND_M: f64 = 1.1;
/// Scan points this near the queue's line are the queue, in m: the desk's sign need not be
/// right above the line the people stand on.
const LINE_HALF_WIDTH_M: f64 = 1.3;
/// Points nearer the desk than this along the line are the desk, in m.
const DESK_DEPTH_M: f64 = 0.5;
/// The queue is not longer than this, in m.
const QUEUE_LENGTH_M: f64 = 12.0;
/// Nothing may be nearer than this in front, in m from the robot's centre.
const MIN_FRONT_M: f64 = 0.6;
/// "In front": within this of the heading, in rad.
const FRONT_RAD: f64 = 0.8;
/// The place counts as reached within this, in m.
const REACHED_M: f64 = 0.25;
/// How long it waits for the building's axes before it takes the queue's line as it sees
/// it, in ns.
const AXES_WAIT_NS: i64 = 3_000_000_000;

/// QueueStander's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct QueueConfig {
    /// How long an input may be silent, in ns.
    pub stale_ns: i64,
    /// When it gives up, in ns from its start.
    pub timeout_ns: i64,
}

impl Default for QueueConfig {
    fn default() -> Self {
        Self {
            stale_ns: DEFAULT_STALE_NS,
            timeout_ns: 180_000_000_000,
        }
    }
}

/// The queue's line: from the desk's sign along the desk's normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QueueLine {
    /// The desk's sign (odometry).
    pub desk: Vec2,
    /// Unit direction from the desk along the queue.
    pub along: Vec2,
}

impl QueueLine {
    /// The line of a desk seen from `robot`: the direction to the robot, on the building's
    /// nearest axis (as it is while no axis is known).
    #[must_use]
    pub fn new(desk: Vec2, robot: Vec2, axes: &BuildingAxes) -> Self {
        let angle = (robot - desk).angle();
        Self {
            desk,
            along: Vec2::from_angle(axes.nearest(angle).unwrap_or(angle)),
        }
    }

    /// How far along the line `point` is, and how far off it.
    #[must_use]
    pub fn place(&self, point: Vec2) -> (f64, f64) {
        let rel = point - self.desk;
        (
            rel.dot(self.along),
            rel.dot(self.along.perpendicular()).abs(),
        )
    }

    /// The robot's place at `robot`, with `points` (odometry) seen: behind the nearest
    /// person ahead of it, or at the head.
    #[must_use]
    pub fn place_for(&self, robot: Vec2, points: &[Vec2]) -> Vec2 {
        let (mine, _) = self.place(robot);
        let ahead = points
            .iter()
            .map(|p| self.place(*p))
            .filter(|(along, off)| {
                *off < LINE_HALF_WIDTH_M
                    && *along > DESK_DEPTH_M
                    && *along < QUEUE_LENGTH_M
                    && *along < mine - 0.3
            })
            .map(|(along, _)| along)
            .fold(f64::NEG_INFINITY, f64::max);
        let at = if ahead.is_finite() {
            (ahead + BEHIND_M).max(HEAD_M)
        } else {
            HEAD_M
        };
        self.desk + self.along * at
    }
}

/// The QueueStander program.
#[derive(Debug)]
pub struct QueueStander {
    config: QueueConfig,
    driver: Driver,
    book: SignBook,
    line: Option<QueueLine>,
    axes: BuildingAxes,
    /// The latest scan's points (odometry).
    points: Vec<Vec2>,
    front_clear: bool,
    start_heading: Option<f64>,
}

impl QueueStander {
    /// The program with its settings.
    #[must_use]
    pub fn new(config: QueueConfig) -> Self {
        Self {
            driver: Driver::new(&["Signs", "RangeFinder", "Egomotion"], config.stale_ns),
            config,
            book: SignBook::default(),
            line: None,
            axes: BuildingAxes::default(),
            points: Vec::new(),
            front_clear: true,
            start_heading: None,
        }
    }

    fn on_signs(&mut self, ctx: &mut Context<'_>, signs: &Signs) {
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        for sign in &signs.signs {
            let local = Vec2::new(sign.position.x, sign.position.y);
            if sign.arrow.parse::<SignArrow>() == Ok(SignArrow::Desk) && sign.confidence >= 0.5 {
                self.book
                    .observe(pose.transform_point(local), SignArrow::Desk);
            }
        }
        let waited = self
            .driver
            .started_ns
            .is_some_and(|at| ctx.now() - at > AXES_WAIT_NS);
        if self.line.is_none()
            && (self.axes.learned() || waited)
            && let Some((_, track, _)) = self.book.settled().next()
        {
            let line = QueueLine::new(track.position, pose.position(), &self.axes);
            let axis = if self.axes.learned() {
                "on the building's axis"
            } else {
                "no axis learned from the scans yet: on the axis of the heading it started with"
            };
            ctx.info(&format!(
                "the desk at {:.2},{:.2} (odometry): joining its queue, along {:.0} deg ({axis})",
                line.desk.x,
                line.desk.y,
                line.along.angle().to_degrees()
            ));
            self.line = Some(line);
        }
    }

    fn on_scan(&mut self, ctx: &Context<'_>, scan: &RangeFinder) {
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        if self.start_heading.is_none() {
            self.start_heading = Some(pose.heading_rad);
            self.axes.assume(pose.heading_rad);
        }
        self.axes.observe(ctx.now(), pose, scan);
        // The queue's line follows the axis as it is learned better.
        if let Some(line) = &mut self.line
            && let Some(axis) = self.axes.nearest(line.along.angle())
        {
            line.along = Vec2::from_angle(axis);
        }
        let readings = range_readings(scan);
        self.front_clear = !readings
            .iter()
            .any(|r| r.bearing_rad.abs() < FRONT_RAD && r.distance_m < MIN_FRONT_M);
        self.points = readings
            .iter()
            .map(|r| pose.transform_point(Vec2::from_angle(r.bearing_rad) * r.distance_m))
            .collect();
    }

    fn other_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let _ = match input.interface {
            "Signs" => input
                .decode()
                .map(|signs: Signs| self.on_signs(ctx, &signs)),
            "RangeFinder" => input
                .decode()
                .map(|scan: RangeFinder| self.on_scan(ctx, &scan)),
            _ => Ok(()),
        };
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
                .finish(ctx, exit::GAVE_UP, "not at the head of the queue in time");
            return;
        }
        self.driver.mover.tick(ctx);
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        let here = pose.position();
        let Some(line) = self.line else {
            // The desk's sign out of sight: on along the heading it started with, slowly
            // finding it (the previous state saw it).
            let heading = *self.start_heading.get_or_insert(pose.heading_rad);
            if now - started > 1_500_000_000 {
                self.driver
                    .mover
                    .goto(ctx, here + Vec2::from_angle(heading) * 1.0);
            }
            return;
        };
        let place = line.place_for(here, &self.points);
        let head = line.desk + line.along * HEAD_M;
        if here.distance(head) < REACHED_M.max(0.3) && place.distance(head) < 0.05 {
            self.driver
                .finish(ctx, exit::SUCCESS, "at the head of the queue");
            return;
        }
        let towards = (place - here).angle();
        let blocked_ahead =
            !self.front_clear && wrap_angle(towards - pose.heading_rad).abs() < FRONT_RAD;
        if blocked_ahead || here.distance(place) < REACHED_M {
            self.driver.mover.stop(ctx);
        } else {
            self.driver.mover.goto(ctx, place);
        }
    }
}

moving_service!(QueueStander);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_queue_line_is_the_axis_nearest_the_way_the_desk_was_seen() {
        let square = BuildingAxes::along(0.0);
        let line = QueueLine::new(Vec2::new(15.0, 21.0), Vec2::new(23.0, 23.2), &square);
        assert!(line.along.distance(Vec2::new(1.0, 0.0)) < 1e-9, "{line:?}");
        let (along, off) = line.place(Vec2::new(17.0, 21.5));
        assert!((along - 2.0).abs() < 1e-9 && (off - 0.5).abs() < 1e-9);
        // The robot started at 45 degrees to the building: the building's axis.
        let turned = BuildingAxes::along(-45_f64.to_radians());
        let line = QueueLine::new(Vec2::new(0.0, 0.0), Vec2::new(5.0, -1.0), &turned);
        let expected = Vec2::from_angle(-45_f64.to_radians());
        assert!(line.along.distance(expected) < 1e-9, "{line:?}");
    }

    #[test]
    fn the_robot_stands_behind_the_last_person_ahead_or_at_the_head() {
        let line = QueueLine::new(
            Vec2::new(0.0, 0.0),
            Vec2::new(8.0, 1.0),
            &BuildingAxes::along(0.0),
        );
        let robot = Vec2::new(7.0, 0.5);
        // Two people at 1.0 and 1.8 along, the desk's edge at 0, someone off the line.
        let people = [
            Vec2::new(0.0, 0.3),
            Vec2::new(0.75, 0.1),
            Vec2::new(1.55, -0.1),
            Vec2::new(4.0, 2.0),
        ];
        let place = line.place_for(robot, &people);
        assert!(place.distance(Vec2::new(2.65, 0.0)) < 1e-9, "{place:?}");
        // Nobody left: the head, 1 m before the desk.
        let place = line.place_for(Vec2::new(2.65, 0.0), &[Vec2::new(0.0, 0.2)]);
        assert!(place.distance(Vec2::new(1.0, 0.0)) < 1e-9, "{place:?}");
        // People behind the robot do not count.
        let place = line.place_for(Vec2::new(1.2, 0.0), &[Vec2::new(3.0, 0.0)]);
        assert!(place.distance(Vec2::new(1.0, 0.0)) < 1e-9, "{place:?}");
    }
}
