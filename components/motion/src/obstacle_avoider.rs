//! ObstacleAvoider: the Mover interface around obstacles, by the paper's greedy strategy.
//!
//! It continually computes the points reachable from the robot by straight lines (the
//! robot's disc, grown by a clearance, touching no obstacle) and heads for the one closest
//! to the goal. Closest is measured around the obstacles known (see [`super::cost_map`]):
//! the straight-line distance when nothing known is in the way, as in the paper, and the
//! way around a wall when one is, so that the robot does not stop in front of it. It never commands the wheels: each step yields at most one
//! [`MoverRequest`] for a VectorMover (a new waypoint, a stop), which [`super::AvoiderDrive`]
//! carries out on a VectorMover it owns, or a service adapter sends to a separate
//! `vector_mover` service.
//!
//! Readings arrive in the robot frame and are placed in the odometry frame with the pose the
//! robot had when they were taken; goals and poses are in the odometry frame. Obstacles are
//! remembered for a short time, so that a sparse sonar ring or a laser that does not see
//! behind the robot still knows what it just passed.

use super::cost_map::GoalCostMap;
use super::free_space::{
    Candidate, Coverage, closest_reachable, disc_hit_distance, free_distance_m,
};
use super::mover::{
    ConfigError, GoalError, GoalId, MoverRequest, MoverStatus, VelocityCommand, answer_command,
    require_non_negative, require_positive,
};
use super::scan::{RangeScan, ScanError};
use lewis_geometry::{RobotToOdom, Vec2, pose_is_finite, position, wrap_angle};
use lewis_interfaces::msg::{
    Distance, Mover, MoverCommand, MoverReply, Point2D, Pose2D, RangeFinder,
};
use std::collections::{BTreeMap, VecDeque};
use std::f64::consts::TAU;

/// The geometry, timing and tolerances of an ObstacleAvoider.
#[derive(Debug, Clone, PartialEq)]
pub struct ObstacleAvoiderConfig {
    /// The robot's radius, in m (a B21r: 0.26).
    pub robot_radius_m: f64,
    /// Extra room kept between the robot and any obstacle, in m.
    pub clearance_m: f64,
    /// Directions tried around the robot at each step.
    pub direction_count: usize,
    /// Points tried along each direction are this far apart, in m.
    pub candidate_spacing_m: f64,
    /// Cell size of the grid on which the way around known obstacles is measured, in m.
    pub cost_cell_m: f64,
    /// That grid covers the robot and the goal and this much around them, in m.
    pub cost_margin_m: f64,
    /// And has at most this many cells (larger cells when the goal is far).
    pub cost_max_cells: usize,
    /// How far the robot may plan into directions the last reading did not cover (behind
    /// a forward laser), in m: far enough to turn towards them, not to drive blind.
    pub unseen_reach_m: f64,
    /// Readings older than this stop the robot (fail safe), in ns.
    pub max_reading_age_ns: i64,
    /// Without fresh readings for this long the goal fails, in ns.
    pub fail_after_ns: i64,
    /// Without getting `progress_m` closer to the goal for this long, the goal is blocked,
    /// in ns.
    pub no_progress_timeout_ns: i64,
    /// What counts as getting closer, in m.
    pub progress_m: f64,
    /// A blocked goal is taken up again when the goal itself comes into reach, or a
    /// reachable point is this much closer to it (straight line) than the robot ever got,
    /// in m.
    pub resume_gain_m: f64,
    /// The current waypoint is kept while still reachable and no more than this further
    /// from the goal than the best one, in m (keeps the VectorMover's goal steady).
    pub waypoint_hysteresis_m: f64,
    /// A new goto is sent to the VectorMover only when the waypoint moved this much, in m.
    pub waypoint_resend_m: f64,
    /// A translate stops (blocked) when the free distance along it falls below this, in m.
    pub translate_lookahead_m: f64,
    /// How far along the way to its waypoint the reflex ([`ObstacleAvoider::react`]) looks
    /// for an obstacle in a new reading, in m: the braking distance from full speed (0.25 m
    /// for a B21r) with room to spare; what lies further is the next step's to plan around.
    pub reflex_lookahead_m: f64,
    /// How long obstacles are remembered, in ns.
    pub memory_ns: i64,
    /// When the way to a goal is shut (the way round is longer than the straight line by
    /// `detour_margin_m` and a tenth), the robot stands and waits this long before it goes
    /// round, in ns (0: it goes round at once). A person across a corridor walks on; and
    /// with only a few seconds of memory, the way round may lead back through what the
    /// avoider has forgotten (unknown space counts as free).
    pub detour_wait_ns: i64,
    /// How much longer than the straight line the way round must be for the way to count
    /// as shut, in m (besides a tenth of the straight line, for the grid's steps).
    pub detour_margin_m: f64,
    /// At most this many readings are remembered (the bound of the memory).
    pub memory_readings: usize,
    /// Obstacle points along a reading's arc are at most this far apart, in m.
    pub arc_point_spacing_m: f64,
    /// And at most this many per reading.
    pub max_points_per_beam: usize,
    /// Half the cone of a non-uniform RangeFinder's transducers (sonar), in rad.
    pub non_uniform_half_width_rad: f64,
    /// A goto or translate is reached within this distance, in m (no less than the
    /// VectorMover's tolerance).
    pub position_tolerance_m: f64,
    /// A rotate is reached within this angle, in rad (no less than the VectorMover's).
    pub heading_tolerance_rad: f64,
}

impl Default for ObstacleAvoiderConfig {
    fn default() -> Self {
        Self {
            robot_radius_m: 0.26,
            clearance_m: 0.12,
            direction_count: 180,
            candidate_spacing_m: 0.1,
            cost_cell_m: 0.1,
            cost_margin_m: 4.0,
            cost_max_cells: 40_000,
            unseen_reach_m: 0.5,
            max_reading_age_ns: 500_000_000,
            fail_after_ns: 30_000_000_000,
            no_progress_timeout_ns: 15_000_000_000,
            progress_m: 0.05,
            resume_gain_m: 0.5,
            waypoint_hysteresis_m: 0.1,
            waypoint_resend_m: 0.05,
            translate_lookahead_m: 0.3,
            reflex_lookahead_m: 0.6,
            memory_ns: 5_000_000_000,
            detour_wait_ns: 8_000_000_000,
            detour_margin_m: 1.5,
            memory_readings: 64,
            arc_point_spacing_m: 0.05,
            max_points_per_beam: 24,
            non_uniform_half_width_rad: 0.2,
            position_tolerance_m: 0.07,
            heading_tolerance_rad: 0.03,
        }
    }
}

impl ObstacleAvoiderConfig {
    /// Checks that every value is in range.
    ///
    /// # Errors
    /// The first field out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        require_positive("robot_radius_m", self.robot_radius_m)?;
        require_non_negative("clearance_m", self.clearance_m)?;
        require_non_negative("unseen_reach_m", self.unseen_reach_m)?;
        require_non_negative("progress_m", self.progress_m)?;
        require_non_negative("resume_gain_m", self.resume_gain_m)?;
        require_non_negative("waypoint_hysteresis_m", self.waypoint_hysteresis_m)?;
        require_non_negative("waypoint_resend_m", self.waypoint_resend_m)?;
        require_non_negative("translate_lookahead_m", self.translate_lookahead_m)?;
        require_non_negative("reflex_lookahead_m", self.reflex_lookahead_m)?;
        require_positive("arc_point_spacing_m", self.arc_point_spacing_m)?;
        require_positive("candidate_spacing_m", self.candidate_spacing_m)?;
        require_positive("cost_cell_m", self.cost_cell_m)?;
        require_non_negative("cost_margin_m", self.cost_margin_m)?;
        require_non_negative("detour_margin_m", self.detour_margin_m)?;
        if self.detour_wait_ns < 0 {
            return Err(ConfigError {
                field: "detour_wait_ns",
                value: self.detour_wait_ns as f64,
                expected: ">= 0 ns",
            });
        }
        require_non_negative(
            "non_uniform_half_width_rad",
            self.non_uniform_half_width_rad,
        )?;
        require_positive("position_tolerance_m", self.position_tolerance_m)?;
        require_positive("heading_tolerance_rad", self.heading_tolerance_rad)?;
        for (field, value) in [
            ("max_reading_age_ns", self.max_reading_age_ns),
            ("fail_after_ns", self.fail_after_ns),
            ("no_progress_timeout_ns", self.no_progress_timeout_ns),
            ("memory_ns", self.memory_ns),
        ] {
            if value <= 0 {
                return Err(ConfigError {
                    field,
                    value: value as f64,
                    expected: "> 0 ns",
                });
            }
        }
        for (field, value) in [
            ("direction_count", self.direction_count),
            ("memory_readings", self.memory_readings),
            ("max_points_per_beam", self.max_points_per_beam),
            ("cost_max_cells", self.cost_max_cells),
        ] {
            if value == 0 {
                return Err(ConfigError {
                    field,
                    value: value as f64,
                    expected: "at least 1",
                });
            }
        }
        Ok(())
    }

    /// The radius kept free around the robot's centre: radius plus clearance, in m.
    #[must_use]
    pub fn keep_out_radius_m(&self) -> f64 {
        self.robot_radius_m + self.clearance_m
    }

    /// The disc the reflex keeps free along the way: radius plus half the clearance, in m.
    /// Smaller than the keep-out radius the steps plan with, so that the reflex stops for
    /// what is new in a reading (a person stepping in), not for the planning margin.
    #[must_use]
    pub fn reflex_radius_m(&self) -> f64 {
        self.robot_radius_m + self.clearance_m / 2.0
    }
}

/// Why an ObstacleAvoider holds the robot still.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum HoldReason {
    /// No reading newer than the age limit (fail safe).
    StaleReadings,
    /// No straight-line point gets the robot closer to the goal (dead end, or the way is
    /// shut for now).
    NoProgress,
    /// A translate's straight line is obstructed.
    PathObstructed,
}

/// A reading that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ObserveError {
    /// The reading itself is malformed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// The pose given for the reading is not finite.
    #[error(
        "the pose given for a range reading is not finite: {0:?}; pass the Egomotion pose of when it was taken"
    )]
    PoseNotFinite(Pose2D),
}

/// One remembered reading, in the odometry frame.
#[derive(Debug, Clone)]
struct Reading {
    /// Told apart from every other reading of the avoider (counts up).
    serial: u64,
    stamp_ns: i64,
    /// The cells of its obstacle points (the avoider's `cells`), each as often as
    /// it has points there.
    cells: Vec<Cell>,
    coverage: Coverage,
}

/// A small cell of the odometry frame, by its integer coordinates.
type Cell = (i64, i64);

#[derive(Debug, Clone, Copy, PartialEq)]
enum Goal {
    Point {
        goal: Vec2,
    },
    Turn {
        requested_rad: f64,
        turned_rad: f64,
        last_heading_rad: Option<f64>,
    },
    Line {
        distance_m: f64,
        start: Option<(Vec2, f64)>,
    },
}

/// The output of one ObstacleAvoider step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AvoiderStep {
    /// What to ask of the VectorMover now, if anything changed.
    pub request: Option<MoverRequest>,
    /// The status after this step.
    pub status: MoverStatus,
}

/// The paper's ObstacleAvoider: greedy waypoints around obstacles, through a VectorMover.
#[derive(Debug, Clone)]
pub struct ObstacleAvoider {
    config: ObstacleAvoiderConfig,
    next_id: GoalId,
    goal_id: Option<GoalId>,
    goal: Option<Goal>,
    goal_pose: Pose2D,
    accepted_ns: Option<i64>,
    status: MoverStatus,
    hold: Option<HoldReason>,
    readings: VecDeque<Reading>,
    /// The serial of the next reading.
    next_serial: u64,
    /// The remembered points, one per small cell (successive readings of the same wall
    /// would otherwise pile up): each cell's point from the newest reading that has one
    /// (the first of that reading's points in the cell), with that reading's serial. Kept
    /// up to date as readings come and go, so that a step does not sort every point
    /// remembered (a profile of replay found that sort a third of the time); ordered by
    /// cell, so that `points` comes out in the same order every time.
    cells: BTreeMap<Cell, (u64, Vec2)>,
    /// The points of `cells`, in their order, rebuilt when a step needs them.
    points: Vec<Vec2>,
    /// `cells` changed since `points` was built: scans come faster than steps (37.5 Hz
    /// against 10 Hz on the B21r), so the points are copied out once per step, not per scan.
    points_stale: bool,
    /// The goal cost map of the last step, kept for its buffers.
    cost_map: GoalCostMap,
    waypoint: Option<Vec2>,
    sent: Option<MoverRequest>,
    best_distance_m: f64,
    progress_since_ns: Option<i64>,
    /// When the goal's way was first seen shut (see
    /// [`ObstacleAvoiderConfig::detour_wait_ns`]).
    shut_since_ns: Option<i64>,
    distance_to_goal_m: f64,
}

impl ObstacleAvoider {
    /// An avoider with no goal and no readings.
    ///
    /// # Errors
    /// A configuration value out of range.
    pub fn new(config: ObstacleAvoiderConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            next_id: GoalId::FIRST,
            goal_id: None,
            goal: None,
            goal_pose: Pose2D::default(),
            accepted_ns: None,
            status: MoverStatus::Idle,
            hold: None,
            readings: VecDeque::new(),
            next_serial: 0,
            cells: BTreeMap::new(),
            points: Vec::new(),
            points_stale: false,
            cost_map: GoalCostMap::default(),
            waypoint: None,
            sent: None,
            best_distance_m: f64::INFINITY,
            progress_since_ns: None,
            shut_since_ns: None,
            distance_to_goal_m: 0.0,
        })
    }

    /// The configuration it was built with.
    #[must_use]
    pub fn config(&self) -> &ObstacleAvoiderConfig {
        &self.config
    }

    /// Go to a point of the odometry frame, around obstacles. Replaces any goal.
    ///
    /// # Errors
    /// A coordinate is not finite; the current goal is kept.
    pub fn goto(&mut self, x_m: f64, y_m: f64) -> Result<GoalId, GoalError> {
        let x_m = GoalError::check("goto", "x", x_m)?;
        let y_m = GoalError::check("goto", "y", y_m)?;
        self.goal_pose = Pose2D {
            x: x_m,
            y: y_m,
            theta: 0.0,
        };
        Ok(self.accept(Goal::Point {
            goal: Vec2::new(x_m, y_m),
        }))
    }

    /// Turn in place by `angle_rad` relative to the current heading (a round robot can
    /// always turn, so this needs no readings).
    ///
    /// # Errors
    /// The angle is not finite; the current goal is kept.
    pub fn rotate(&mut self, angle_rad: f64) -> Result<GoalId, GoalError> {
        let angle_rad = GoalError::check("rotate", "angle", angle_rad)?;
        Ok(self.accept(Goal::Turn {
            requested_rad: angle_rad,
            turned_rad: 0.0,
            last_heading_rad: None,
        }))
    }

    /// Drive straight along the current heading (backwards when negative), stopping
    /// (blocked) when the line is obstructed.
    ///
    /// # Errors
    /// The distance is not finite; the current goal is kept.
    pub fn translate(&mut self, distance_m: f64) -> Result<GoalId, GoalError> {
        let distance_m = GoalError::check("translate", "distance", distance_m)?;
        Ok(self.accept(Goal::Line {
            distance_m,
            start: None,
        }))
    }

    /// Drop the goal; the next step asks the VectorMover to stop.
    pub fn stop(&mut self) {
        self.goal_id = None;
        self.goal = None;
        self.status = MoverStatus::Idle;
        self.hold = None;
        self.waypoint = None;
        self.distance_to_goal_m = 0.0;
    }

    /// Carries out a request; the goal id for goto, rotate and translate.
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn request(&mut self, request: MoverRequest) -> Result<Option<GoalId>, GoalError> {
        match request {
            MoverRequest::Goto { x_m, y_m } => self.goto(x_m, y_m).map(Some),
            MoverRequest::Rotate { angle_rad } => self.rotate(angle_rad).map(Some),
            MoverRequest::Translate { distance_m } => self.translate(distance_m).map(Some),
            MoverRequest::Stop => {
                self.stop();
                Ok(None)
            }
        }
    }

    /// Carries out a Mover command and builds its reply (headers left empty).
    ///
    /// # Errors
    /// An argument is not finite.
    pub fn handle(&mut self, command: &MoverCommand) -> Result<MoverReply, GoalError> {
        answer_command(command, |request| self.request(request))
    }

    fn accept(&mut self, goal: Goal) -> GoalId {
        let id = self.next_id;
        self.next_id = id.next();
        self.goal_id = Some(id);
        self.goal = Some(goal);
        self.accepted_ns = None;
        self.status = MoverStatus::Moving;
        self.hold = None;
        self.waypoint = None;
        // Whatever the VectorMover was doing belongs to the old goal: ask again.
        self.sent = None;
        self.best_distance_m = f64::INFINITY;
        self.progress_since_ns = None;
        self.shut_since_ns = None;
        id
    }

    /// Takes in a RangeFinder reading (laser or sonar, uniform or not), taken at
    /// `stamp_ns` when the robot was at `pose_in_odom`.
    ///
    /// # Errors
    /// The reading is malformed or the pose is not finite; the reading is then ignored.
    pub fn observe_range_finder(
        &mut self,
        reading: &RangeFinder,
        pose_in_odom: &Pose2D,
        stamp_ns: i64,
    ) -> Result<(), ObserveError> {
        let scan = RangeScan::from_range_finder(reading, self.config.non_uniform_half_width_rad)?;
        self.observe_scan(&scan, pose_in_odom, stamp_ns)
    }

    /// Takes in a Distance reading, taken at `stamp_ns` when the robot was at `pose_in_odom`.
    ///
    /// # Errors
    /// The reading is malformed or the pose is not finite; the reading is then ignored.
    pub fn observe_distance(
        &mut self,
        reading: &Distance,
        pose_in_odom: &Pose2D,
        stamp_ns: i64,
    ) -> Result<(), ObserveError> {
        let scan = RangeScan::from_distance(reading)?;
        self.observe_scan(&scan, pose_in_odom, stamp_ns)
    }

    /// Takes in a reading already turned into beams. A reading older than the newest one
    /// remembered is ignored.
    ///
    /// # Errors
    /// The pose is not finite.
    pub fn observe_scan(
        &mut self,
        scan: &RangeScan,
        pose_in_odom: &Pose2D,
        stamp_ns: i64,
    ) -> Result<(), ObserveError> {
        if !pose_is_finite(pose_in_odom) {
            return Err(ObserveError::PoseNotFinite(pose_in_odom.clone()));
        }
        if self
            .readings
            .back()
            .is_some_and(|newest| newest.stamp_ns > stamp_ns)
        {
            return Ok(());
        }
        let config = &self.config;
        let serial = self.next_serial;
        self.next_serial += 1;
        let cell_m = config.arc_point_spacing_m / 2.0;
        let to_odom = RobotToOdom::new(pose_in_odom);
        let mut cells = Vec::new();
        for p in scan
            .beams()
            .iter()
            .flat_map(|beam| {
                beam.obstacle_points(config.arc_point_spacing_m, config.max_points_per_beam)
            })
            .map(|p| to_odom.apply(p))
        {
            let cell = cell_of(p, cell_m);
            cells.push(cell);
            // This reading is the newest: its first point in a cell takes the cell over.
            let entry = self.cells.entry(cell).or_insert((serial, p));
            if entry.0 != serial {
                *entry = (serial, p);
            }
        }
        let wedges = scan
            .beams()
            .iter()
            .map(|beam| {
                let end = beam.origin + Vec2::from_angle(beam.bearing_rad) * beam.range_m;
                (to_odom.apply(end), beam.half_width_rad)
            })
            .collect();
        let coverage = Coverage {
            wedges,
            unseen_reach_m: config.unseen_reach_m,
        };
        self.readings.push_back(Reading {
            serial,
            stamp_ns,
            cells,
            coverage,
        });
        while self.readings.len() > self.config.memory_readings {
            self.forget_oldest_reading();
        }
        self.points_stale = true;
        Ok(())
    }

    /// Drops the oldest reading and the points only it still accounts for.
    fn forget_oldest_reading(&mut self) {
        let Some(oldest) = self.readings.pop_front() else {
            return;
        };
        for cell in &oldest.cells {
            // A newer reading with a point in the cell took it over: that point stays.
            if self
                .cells
                .get(cell)
                .is_some_and(|&(serial, _)| serial == oldest.serial)
            {
                self.cells.remove(cell);
            }
        }
        self.points_stale = true;
    }

    /// Copies out the remembered points if they changed since the last time.
    fn refresh_points(&mut self) {
        if self.points_stale {
            self.points.clear();
            self.points
                .extend(self.cells.values().map(|&(_, point)| point));
            self.points_stale = false;
        }
    }

    fn forget_old_readings(&mut self, now_ns: i64) {
        // The newest reading is kept whatever its age: it is what says the data are stale.
        while self.readings.len() > 1
            && self
                .readings
                .front()
                .is_some_and(|r| now_ns.saturating_sub(r.stamp_ns) > self.config.memory_ns)
        {
            self.forget_oldest_reading();
        }
    }

    fn newest_coverage(&self) -> Coverage {
        self.readings.back().map_or_else(
            || Coverage {
                wedges: Vec::new(),
                unseen_reach_m: 0.0,
            },
            |r| r.coverage.clone(),
        )
    }

    /// How far a disc of `radius_m` can move from `pose_in_odom` along `direction_rad`
    /// (odometry frame) before touching a remembered obstacle or leaving what the newest
    /// reading covers, in m. For a speed governor over the VectorMover (with a radius
    /// between the robot's and [`ObstacleAvoiderConfig::keep_out_radius_m`], so that the
    /// governor stops real intrusions, not the grazing of the planning margin).
    pub fn free_distance_m(
        &mut self,
        pose_in_odom: &Pose2D,
        direction_rad: f64,
        radius_m: f64,
    ) -> f64 {
        self.refresh_points();
        let coverage = self.newest_coverage();
        let min_half = TAU / self.config.direction_count as f64 / 2.0;
        free_distance_m(
            position(pose_in_odom),
            direction_rad,
            radius_m,
            &self.points,
            &coverage,
            min_half,
        )
    }

    /// Forgets what was last asked of the VectorMover, so that the next step asks again.
    /// Call it when the VectorMover stops pursuing the avoider's request on its own
    /// (arrived, blocked, restarted) while the avoider still has a goal.
    pub fn resend(&mut self) {
        self.sent = None;
    }

    /// The reflex, for every new reading as it comes, between steps: whether the motion
    /// under way is still safe with this reading alone. It is when no obstacle of the
    /// reading lies within [`ObstacleAvoiderConfig::reflex_radius_m`] of the straight way
    /// to the current waypoint (a goto's, or a translate's end), over its first
    /// [`ObstacleAvoiderConfig::reflex_lookahead_m`] (a translate's: its
    /// `translate_lookahead_m`, as the steps check it). When it is not, the avoider drops
    /// the waypoint and asks the VectorMover to stop now: the next [`ObstacleAvoider::step`]
    /// plans around the obstacle and sends a new waypoint. The goal and the status are kept.
    ///
    /// It costs a pass over the reading's points (tens of microseconds for a laser scan),
    /// where a step costs milliseconds (it rebuilds the cost map), so it can run on every
    /// reading. It neither remembers the reading (the next step takes in the newest one)
    /// nor reads a clock: `pose_in_odom` is the pose of when the reading was taken, and
    /// the answer depends only on it, the reading and what the last step chose.
    pub fn react(&mut self, scan: &RangeScan, pose_in_odom: &Pose2D) -> Option<MoverRequest> {
        if self.status != MoverStatus::Moving
            || self.hold.is_some()
            || !pose_is_finite(pose_in_odom)
        {
            return None;
        }
        let lookahead_m = match self.goal? {
            Goal::Point { .. } => self.config.reflex_lookahead_m,
            Goal::Line { .. } => self.config.translate_lookahead_m,
            // A round robot turns in place without touching anything new.
            Goal::Turn { .. } => return None,
        };
        let waypoint = self.waypoint?;
        let here = position(pose_in_odom);
        let to_waypoint = waypoint - here;
        let distance_m = to_waypoint.norm();
        if distance_m <= self.config.position_tolerance_m {
            return None;
        }
        let direction = to_waypoint * (1.0 / distance_m);
        let length_m = distance_m.min(lookahead_m);
        let radius_m = self.config.reflex_radius_m();
        let config = &self.config;
        let to_odom = RobotToOdom::new(pose_in_odom);
        let blocked = scan
            .beams()
            .iter()
            .flat_map(|beam| {
                beam.obstacle_points(config.arc_point_spacing_m, config.max_points_per_beam)
            })
            .map(|p| to_odom.apply(p))
            .any(|p| disc_hit_distance(here, direction, radius_m, p) < length_m);
        if !blocked {
            return None;
        }
        self.waypoint = None;
        self.sent = Some(MoverRequest::Stop);
        Some(MoverRequest::Stop)
    }

    fn reading_age_ns(&self, now_ns: i64) -> i64 {
        let since = self
            .readings
            .back()
            .map(|r| r.stamp_ns)
            .or(self.accepted_ns)
            .unwrap_or(now_ns);
        now_ns.saturating_sub(since)
    }

    /// One step at `now_ns` with the robot at `pose_in_odom`: the new status and what to
    /// ask of the VectorMover. A pose that is not finite fails the goal.
    pub fn step(&mut self, pose_in_odom: &Pose2D, now_ns: i64) -> AvoiderStep {
        self.forget_old_readings(now_ns);
        self.refresh_points();
        if self.accepted_ns.is_none() && self.goal.is_some() {
            self.accepted_ns = Some(now_ns);
        }
        let wanted = if pose_is_finite(pose_in_odom) {
            self.decide(pose_in_odom, now_ns)
        } else {
            if self.goal.is_some() {
                self.fail();
            }
            Some(MoverRequest::Stop)
        };
        // After arrival the VectorMover finishes its own approach; otherwise no goal means rest.
        let at_rest = self.goal.is_none() && self.status != MoverStatus::Arrived;
        let wanted = wanted.or(if at_rest {
            Some(MoverRequest::Stop)
        } else {
            None
        });
        let request = match wanted {
            Some(request) if self.is_new(request) => {
                self.sent = Some(request);
                Some(request)
            }
            _ => None,
        };
        AvoiderStep {
            request,
            status: self.status,
        }
    }

    /// A request that differs from the last one sent (goto: by more than the resend
    /// distance).
    fn is_new(&self, request: MoverRequest) -> bool {
        match (self.sent, request) {
            (Some(MoverRequest::Goto { x_m, y_m }), MoverRequest::Goto { x_m: x, y_m: y }) => {
                Vec2::new(x_m, y_m).distance(Vec2::new(x, y)) > self.config.waypoint_resend_m
            }
            (Some(MoverRequest::Rotate { .. }), MoverRequest::Rotate { .. })
            | (Some(MoverRequest::Translate { .. }), MoverRequest::Translate { .. }) => false,
            (sent, request) => sent != Some(request),
        }
    }

    fn fail(&mut self) {
        self.status = MoverStatus::Failed;
        self.goal = None;
        self.hold = None;
        self.waypoint = None;
    }

    fn hold(&mut self, reason: HoldReason) -> Option<MoverRequest> {
        self.status = MoverStatus::Blocked;
        self.hold = Some(reason);
        Some(MoverRequest::Stop)
    }

    fn decide(&mut self, pose: &Pose2D, now_ns: i64) -> Option<MoverRequest> {
        let goal = self.goal?;
        let here = position(pose);
        let needs_readings = !matches!(goal, Goal::Turn { .. });
        if needs_readings {
            let age = self.reading_age_ns(now_ns);
            if age > self.config.fail_after_ns {
                self.fail();
                return Some(MoverRequest::Stop);
            }
            if age > self.config.max_reading_age_ns || self.readings.is_empty() {
                // Progress is not expected while the robot is held for want of data.
                self.progress_since_ns = None;
                if age > self.config.max_reading_age_ns {
                    return self.hold(HoldReason::StaleReadings);
                }
                return None;
            }
            if self.hold == Some(HoldReason::StaleReadings) {
                self.hold = None;
                self.status = MoverStatus::Moving;
                self.sent = None;
            }
        }
        match goal {
            Goal::Point { goal } => self.decide_point(here, goal, now_ns),
            Goal::Turn {
                requested_rad,
                turned_rad,
                last_heading_rad,
            } => {
                let turned =
                    turned_rad + last_heading_rad.map_or(0.0, |last| wrap_angle(pose.theta - last));
                self.goal = Some(Goal::Turn {
                    requested_rad,
                    turned_rad: turned,
                    last_heading_rad: Some(pose.theta),
                });
                if last_heading_rad.is_none() {
                    self.goal_pose = Pose2D {
                        x: pose.x,
                        y: pose.y,
                        theta: wrap_angle(pose.theta + requested_rad),
                    };
                }
                self.waypoint = Some(here);
                self.distance_to_goal_m = 0.0;
                let remaining = requested_rad - turned;
                if remaining.abs() <= self.config.heading_tolerance_rad {
                    self.status = MoverStatus::Arrived;
                    self.goal = None;
                    return None;
                }
                Some(MoverRequest::Rotate {
                    angle_rad: remaining,
                })
            }
            Goal::Line { distance_m, start } => {
                let (origin, heading) = start.unwrap_or((here, pose.theta));
                if start.is_none() {
                    self.goal = Some(Goal::Line {
                        distance_m,
                        start: Some((origin, heading)),
                    });
                    let end = origin + Vec2::from_angle(heading) * distance_m;
                    self.goal_pose = Pose2D {
                        x: end.x,
                        y: end.y,
                        theta: heading,
                    };
                }
                self.decide_line(here, origin, heading, distance_m)
            }
        }
    }

    fn decide_point(&mut self, here: Vec2, goal: Vec2, now_ns: i64) -> Option<MoverRequest> {
        let distance = here.distance(goal);
        self.distance_to_goal_m = distance;
        self.goal_pose.theta = (goal - here).angle();
        if distance <= self.config.position_tolerance_m {
            self.status = MoverStatus::Arrived;
            self.goal = None;
            self.waypoint = Some(goal);
            return None;
        }
        let radius = self.config.keep_out_radius_m();
        let coverage = self.newest_coverage();
        let config = &self.config;
        self.cost_map.rebuild(
            goal,
            here,
            &self.points,
            config.robot_radius_m.max(radius - config.cost_cell_m),
            config.cost_cell_m,
            config.cost_margin_m,
            config.cost_max_cells,
        );
        let map = &self.cost_map;
        let cost = |p: Vec2| map.cost_m(p);
        let best = closest_reachable(
            here,
            goal,
            radius,
            &self.points,
            &coverage,
            config.direction_count,
            config.candidate_spacing_m,
            &cost,
        );
        if best.goal_distance_m > 0.0
            && waits_for_the_way(
                &mut self.shut_since_ns,
                &self.config,
                (distance, cost(here)),
                now_ns,
            )
        {
            // Waiting is not a lack of progress.
            self.progress_since_ns = Some(now_ns);
            self.waypoint = None;
            return Some(MoverRequest::Stop);
        }
        if distance < self.best_distance_m - self.config.progress_m
            || self.progress_since_ns.is_none()
        {
            self.best_distance_m = self.best_distance_m.min(distance);
            self.progress_since_ns = Some(now_ns);
        }
        if self.hold == Some(HoldReason::NoProgress) {
            if best.goal_distance_m == 0.0
                || best.goal_distance_m < self.best_distance_m - self.config.resume_gain_m
            {
                self.hold = None;
                self.status = MoverStatus::Moving;
                self.progress_since_ns = Some(now_ns);
            } else {
                return Some(MoverRequest::Stop);
            }
        }
        if self
            .progress_since_ns
            .is_some_and(|since| now_ns.saturating_sub(since) >= self.config.no_progress_timeout_ns)
        {
            self.waypoint = None;
            return self.hold(HoldReason::NoProgress);
        }
        let waypoint = self.keep_or_switch(here, best, &coverage, &cost);
        self.waypoint = Some(waypoint);
        Some(MoverRequest::Goto {
            x_m: waypoint.x,
            y_m: waypoint.y,
        })
    }

    /// Keeps the current waypoint while it is still reachable and nearly as good as the best
    /// one, so that the VectorMover is not retargeted at every step.
    fn keep_or_switch(
        &self,
        here: Vec2,
        best: Candidate,
        coverage: &Coverage,
        cost: &dyn Fn(Vec2) -> f64,
    ) -> Vec2 {
        let Some(current) = self.waypoint else {
            return best.point;
        };
        let to_current = current - here;
        let reached = to_current.norm() <= self.config.position_tolerance_m;
        let min_half = TAU / self.config.direction_count as f64 / 2.0;
        let reachable = to_current.norm() == 0.0
            || free_distance_m(
                here,
                to_current.angle(),
                self.config.keep_out_radius_m(),
                &self.points,
                coverage,
                min_half,
            ) >= to_current.norm() - 1e-6;
        let good_enough = cost(current) <= best.cost_m + self.config.waypoint_hysteresis_m;
        if reachable && good_enough && !reached {
            current
        } else {
            best.point
        }
    }

    fn decide_line(
        &mut self,
        here: Vec2,
        origin: Vec2,
        heading: f64,
        distance_m: f64,
    ) -> Option<MoverRequest> {
        let direction = Vec2::from_angle(heading);
        let end = origin + direction * distance_m;
        let along = (end - here).dot(direction);
        self.distance_to_goal_m = along.abs();
        self.waypoint = Some(end);
        if along.abs() <= self.config.position_tolerance_m {
            self.status = MoverStatus::Arrived;
            self.goal = None;
            return None;
        }
        let motion_rad = if along >= 0.0 {
            heading
        } else {
            heading + std::f64::consts::PI
        };
        let coverage = self.newest_coverage();
        let min_half = TAU / self.config.direction_count as f64 / 2.0;
        let free = free_distance_m(
            here,
            motion_rad,
            self.config.keep_out_radius_m(),
            &self.points,
            &coverage,
            min_half,
        );
        let needed = along.abs().min(self.config.translate_lookahead_m);
        if free < needed {
            return self.hold(HoldReason::PathObstructed);
        }
        if self.hold == Some(HoldReason::PathObstructed) {
            self.hold = None;
            self.status = MoverStatus::Moving;
        }
        Some(MoverRequest::Translate { distance_m: along })
    }

    /// The status to publish.
    #[must_use]
    pub fn status(&self) -> MoverStatus {
        self.status
    }

    /// Why the robot is held (status blocked), if it is.
    #[must_use]
    pub fn hold_reason(&self) -> Option<HoldReason> {
        if self.status == MoverStatus::Blocked {
            self.hold
        } else {
            None
        }
    }

    /// The goal being pursued (or just ended), `None` after `stop` or before any goal.
    #[must_use]
    pub fn goal_id(&self) -> Option<GoalId> {
        self.goal_id
    }

    /// Where the robot is heading now (odometry frame), if anywhere.
    #[must_use]
    pub fn waypoint(&self) -> Option<Point2D> {
        self.waypoint.map(Point2D::from)
    }

    /// Distance still to go at the last step (0 for rotate), in m.
    #[must_use]
    pub fn distance_to_goal_m(&self) -> f64 {
        self.distance_to_goal_m
    }

    /// The obstacle points remembered at the last step, odometry frame (for display and
    /// tests).
    #[must_use]
    pub fn obstacle_points(&self) -> Vec<Point2D> {
        self.points.iter().copied().map(Point2D::from).collect()
    }

    /// The Mover publication (header left empty); `velocities` are those the VectorMover
    /// last commanded (its own publication's, or [`super::AvoiderDrive`]'s).
    #[must_use]
    pub fn publication(&self, velocities: VelocityCommand) -> Mover {
        Mover {
            goal_id: self.goal_id.map_or(0, GoalId::get),
            goal: if self.goal_id.is_some() {
                self.goal_pose.clone()
            } else {
                Pose2D::default()
            },
            status: self.status.into(),
            distance_to_goal: self.distance_to_goal_m,
            translation_velocity: velocities.translation_m_s,
            rotation_velocity: velocities.rotation_rad_s,
            waypoint: self.waypoint.map(Point2D::from).unwrap_or_default(),
            ..Default::default()
        }
    }
}

/// The cell of `cell_m` that holds `p`.
fn cell_of(p: Vec2, cell_m: f64) -> Cell {
    ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64)
}

/// Whether the robot should stand and wait for the way to its goal to open: the way is
/// shut (the cost map's way round, `around`, is much longer than the `straight` line), and
/// less than [`ObstacleAvoiderConfig::detour_wait_ns`] has passed since the goal's way was
/// first seen shut (`shut_since`): a goal waits once, however often its way shuts.
fn waits_for_the_way(
    shut_since: &mut Option<i64>,
    config: &ObstacleAvoiderConfig,
    (straight, around): (f64, f64),
    now_ns: i64,
) -> bool {
    if around <= straight * 1.1 + config.detour_margin_m {
        return false;
    }
    let since = *shut_since.get_or_insert(now_ns);
    now_ns - since < config.detour_wait_ns
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scan::RangeScan;
    use lewis_geometry::robot_to_odom;
    use std::f64::consts::PI;

    /// The remembered points as they were once worked out at every step: every point of
    /// every reading remembered, sorted by cell and then newest reading first, one per cell.
    fn sorted_points(readings: &[(i64, Vec<Vec2>)], cell_m: f64) -> Vec<Vec2> {
        let mut keyed: Vec<(Cell, usize, Vec2)> = readings
            .iter()
            .rev()
            .flat_map(|(_, points)| points.iter().copied())
            .enumerate()
            .map(|(order, p)| (cell_of(p, cell_m), order, p))
            .collect();
        keyed.sort_unstable_by_key(|&(cell, order, _)| (cell, order));
        keyed.dedup_by_key(|(cell, _, _)| *cell);
        keyed.into_iter().map(|(_, _, p)| p).collect()
    }

    #[test]
    fn remembered_points_kept_up_to_date_are_those_of_a_sort_of_every_reading() {
        let config = ObstacleAvoiderConfig {
            memory_readings: 6,
            memory_ns: 40,
            ..ObstacleAvoiderConfig::default()
        };
        let cell_m = config.arc_point_spacing_m / 2.0;
        let mut avoider = ObstacleAvoider::new(config.clone()).unwrap();
        let mut shadow: Vec<(i64, Vec<Vec2>)> = Vec::new();
        let mut rng = lewis_service::Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.next_f64();
        let mut stamp_ns = 0;
        for round in 0..300 {
            // Nearly the same place each time, so that readings share cells.
            let pose = Pose2D {
                x: 1.0 + next() * 0.05,
                y: -2.0 + next() * 0.05,
                theta: next() * 0.1,
            };
            let reading = Distance {
                sector_count: 24,
                sector_distances: (0..24)
                    .map(|_| {
                        if next() < 0.1 {
                            5.0
                        } else {
                            0.5 + next() * 3.0
                        }
                    })
                    .collect(),
                max_range: 5.0,
                first_sector_angle: -PI,
                sector_width: TAU / 24.0,
                ..Default::default()
            };
            // Now and then one arrives late (ignored) or at the same time as the last one.
            stamp_ns += [0, 3, 7, 10][round % 4];
            let stamp = if round % 11 == 5 {
                stamp_ns - 20
            } else {
                stamp_ns
            };
            avoider.observe_distance(&reading, &pose, stamp).unwrap();
            if shadow.last().is_none_or(|(newest, _)| *newest <= stamp) {
                let scan = RangeScan::from_distance(&reading).unwrap();
                let points = scan
                    .beams()
                    .iter()
                    .flat_map(|b| {
                        b.obstacle_points(config.arc_point_spacing_m, config.max_points_per_beam)
                    })
                    .map(|p| robot_to_odom(&pose, p))
                    .collect();
                shadow.push((stamp, points));
                if shadow.len() > config.memory_readings {
                    shadow.remove(0);
                }
            }
            if round % 7 == 0 {
                avoider.forget_old_readings(stamp_ns);
                while shadow.len() > 1 && stamp_ns - shadow[0].0 > config.memory_ns {
                    shadow.remove(0);
                }
            }
            avoider.refresh_points();
            assert!(!avoider.points.is_empty());
            assert_eq!(
                avoider.points,
                sorted_points(&shadow, cell_m),
                "round {round}"
            );
        }
    }
}
