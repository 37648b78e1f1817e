//! SignFollower: to the nearest direction sign, the way its arrow says, and on until the
//! next sign.
//!
//! Signs are tracked in the odometry frame; a sign's arrow is the majority of its last
//! three readings. With no sign in view when it starts (after a recovery, say), the
//! program looks around in 45 degree turns, and goes on along the heading it started with
//! only if a whole turn shows none. It goes 1.3 m in front of the nearest sign it reads,
//! turns as the arrow says (up: straight on, left: +90 degrees, right: -90, down: back),
//! and goes on. The way it goes on is put on the building's nearest axis, learned from the
//! range finder's scans (see [`crate::common::axes`]), when it is near one.
//! It finishes with 0 once it reads another direction sign (more than 1.5 m from the one
//! it followed: the next state follows that one), with 1 when it reads the registration
//! desk's sign, and with 4 after a minute without a new sign.

use std::collections::{BTreeSet, VecDeque};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use lewis_geometry::{Pose2, Vec2, wrap_angle};
use lewis_interfaces::msg::{RangeFinder, SignArrow, Signs};
use lewis_service::{Context, Input};

use crate::common::axes::BuildingAxes;
use crate::common::driver::{Driver, moving_service};
use crate::common::exit;
use crate::common::frames::turn;
use crate::common::watch::DEFAULT_STALE_NS;

/// What SignFollower asks the broker for.
pub const REQUIRES: &[&str] = &["Signs", "Egomotion", "Mover", "RangeFinder"];

/// Readings less sure than this are ignored.
const MIN_CONFIDENCE: f64 = 0.5;
/// Signs further than this are not read, in m.
const MAX_READ_M: f64 = 8.0;
/// Two readings this close (odometry) are the same sign, in m.
const SAME_SIGN_M: f64 = 1.0;
/// Another sign is one further than this from the followed one, in m.
const OTHER_SIGN_M: f64 = 1.5;
/// Where the robot stops before a sign, in m.
const IN_FRONT_M: f64 = 1.3;
/// How far ahead the robot goes on after a sign, in m.
const GO_ON_M: f64 = 6.0;
/// The go-on goal is renewed when the robot is this near it, in m.
const RENEW_M: f64 = 3.0;
/// The point before the sign counts as reached within this, in m.
const REACHED_M: f64 = 0.3;
/// A turn target this near an axis of the building is put on it, in rad.
const SNAP_RAD: f64 = 0.45;
/// While it goes on, its heading follows the building's axis as it is learned better (and
/// as the odometry drifts from it) by up to this, in rad.
const RESNAP_RAD: f64 = 0.12;
/// Votes of the last readings of a sign.
const VOTES: usize = 3;
/// How long the robot stands and looks before (and after each turn of) its look around,
/// in ns: time for a sign in view to be read three times.
const LOOK_NS: i64 = 1_500_000_000;
/// Turns of 45 degrees in a look around: one whole turn.
const LOOK_TURNS: u32 = 8;

/// SignFollower's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SignConfig {
    /// The arrows it follows (`--signs "arrow left"`); empty: all four.
    pub arrows: BTreeSet<ArrowWord>,
    /// How long an input may be silent, in ns.
    pub stale_ns: i64,
    /// How long it goes without a new sign before giving up, in ns.
    pub timeout_ns: i64,
}

impl Default for SignConfig {
    fn default() -> Self {
        Self {
            arrows: BTreeSet::new(),
            stale_ns: DEFAULT_STALE_NS,
            timeout_ns: 60_000_000_000,
        }
    }
}

/// A direction arrow a sign can show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ArrowWord {
    /// Turn left.
    Left,
    /// Turn right.
    Right,
    /// Straight on.
    Up,
    /// Turn back.
    Down,
}

impl ArrowWord {
    /// Reads `left`, `arrow left`, `Arrow-Left` and the like.
    ///
    /// # Errors
    /// A word that is no arrow, with the ones that are.
    pub fn parse(text: &str) -> Result<Self, String> {
        let word = text
            .trim()
            .to_ascii_lowercase()
            .trim_start_matches("arrow")
            .trim_start_matches([' ', '-', '_'])
            .to_owned();
        match word.as_str() {
            "left" => Ok(Self::Left),
            "right" => Ok(Self::Right),
            "up" => Ok(Self::Up),
            "down" => Ok(Self::Down),
            _ => Err(format!(
                "`{text}` is no arrow: give left, right, up or down (`arrow left` is fine too)"
            )),
        }
    }

    /// The turn it asks for, in rad (counter-clockwise).
    #[must_use]
    pub fn turn_rad(self) -> f64 {
        match self {
            Self::Left => FRAC_PI_2,
            Self::Right => -FRAC_PI_2,
            Self::Up => 0.0,
            Self::Down => PI,
        }
    }

    fn of(arrow: SignArrow) -> Option<Self> {
        match arrow {
            SignArrow::Left => Some(Self::Left),
            SignArrow::Right => Some(Self::Right),
            SignArrow::Up => Some(Self::Up),
            SignArrow::Down => Some(Self::Down),
            SignArrow::Desk => None,
        }
    }
}

/// A sign seen, in the odometry frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SignTrack {
    /// Where it is (the mean of its readings).
    pub position: Vec2,
    readings: u32,
    votes: VecDeque<SignArrow>,
}

impl SignTrack {
    /// What it says: the arrow of at least two of its last three readings.
    #[must_use]
    pub fn arrow(&self) -> Option<SignArrow> {
        self.votes
            .iter()
            .copied()
            .find(|a| self.votes.iter().filter(|b| *b == a).count() >= 2)
    }
}

/// Every sign read so far (the pure core of SignFollower).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SignBook {
    tracks: Vec<SignTrack>,
}

impl SignBook {
    /// Takes one reading: a sign at `position` (odometry) saying `arrow`. Returns its track's
    /// index.
    pub fn observe(&mut self, position: Vec2, arrow: SignArrow) -> usize {
        let index = if let Some(i) = self
            .tracks
            .iter()
            .position(|t| t.position.distance(position) < SAME_SIGN_M)
        {
            i
        } else {
            self.tracks.push(SignTrack {
                position,
                readings: 0,
                votes: VecDeque::new(),
            });
            self.tracks.len() - 1
        };
        let track = &mut self.tracks[index];
        track.readings += 1;
        let k = f64::from(track.readings);
        track.position = track.position * ((k - 1.0) / k) + position * (1.0 / k);
        track.votes.push_back(arrow);
        while track.votes.len() > VOTES {
            track.votes.pop_front();
        }
        index
    }

    /// Takes the readings of a Signs sample seen from `pose` (odometry): the sure ones, near
    /// enough to be read.
    pub fn read(&mut self, pose: Pose2, signs: &Signs) {
        for sign in &signs.signs {
            let local = Vec2::new(sign.position.x, sign.position.y);
            let Ok(arrow) = sign.arrow.parse::<SignArrow>() else {
                continue;
            };
            if sign.confidence < MIN_CONFIDENCE || local.norm() > MAX_READ_M {
                continue;
            }
            self.observe(pose.transform_point(local), arrow);
        }
    }

    /// The track `index`.
    #[must_use]
    pub fn track(&self, index: usize) -> &SignTrack {
        &self.tracks[index]
    }

    /// The tracks whose arrow is settled, with their index.
    pub fn settled(&self) -> impl Iterator<Item = (usize, &SignTrack, SignArrow)> {
        self.tracks
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.arrow().map(|a| (i, t, a)))
    }
}

/// The heading to go on after a sign: the direction the robot faced the sign in (from
/// `before` to the sign at `sign`), turned by the arrow, put on the building's nearest axis
/// when near one. A sign's arrow is meant for someone facing its board squarely: when the
/// range finder saw a straight wall just behind the sign, the facing is square to that wall
/// (a sign seen at 45 degrees still says "left" of its own face). A wall beside the sign
/// (a sign on a post near a corridor's wall) is not behind it and does not count.
#[must_use]
pub fn heading_after(before: Vec2, sign: Vec2, arrow: ArrowWord, axes: &BuildingAxes) -> f64 {
    let seen = (sign - before).angle();
    let facing = axes
        .wall_behind(before, sign, WALL_BEHIND_M)
        .map_or(seen, |wall| {
            let normal = wall + FRAC_PI_2;
            // The normal pointing away from the robot, into the wall.
            if wrap_angle(normal - seen).abs() <= FRAC_PI_2 {
                wrap_angle(normal)
            } else {
                wrap_angle(normal + PI)
            }
        });
    axes.snap(wrap_angle(facing + arrow.turn_rad()), SNAP_RAD)
}

/// A wall met this near behind a sign, along the line of sight, is the wall it hangs on,
/// in m.
const WALL_BEHIND_M: f64 = 0.6;

/// The go-on goal from `here` along `heading` past the sign at `sign`: straight on, unless
/// the sign stands in the way (a sign saying "straight on" does): then a point just past
/// it on its other side, with room, so that the robot's path never crosses its board (which
/// the range finder, below it, does not see).
#[must_use]
pub fn go_on_goal(here: Vec2, heading: f64, sign: Vec2) -> Vec2 {
    let dir = Vec2::from_angle(heading);
    let left = dir.perpendicular();
    let rel = sign - here;
    let (along, side) = (rel.dot(dir), rel.dot(left));
    if along <= -0.3 || along > GO_ON_M || side.abs() >= PASS_M {
        return here + dir * GO_ON_M;
    }
    let away = if side > 0.0 { -1.0 } else { 1.0 };
    sign + left * (away * PASS_M) + dir * PASSED_M
}

/// How far past a sign in the way its side-step goal is, in m.
const PASSED_M: f64 = 0.5;

/// The room kept beside a sign's centre when going on past it, in m: half its board and the
/// robot with a margin.
const PASS_M: f64 = 1.4;

/// Where the program is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Looking for the first sign, standing: `turns` turns of the look around made, the
    /// last one finished at `still_from` (`None` while it turns).
    Look { turns: u32, still_from: Option<i64> },
    /// No sign all around: going on along the heading it started with.
    Ahead,
    /// To the point in front of sign `track`.
    Approach { track: usize, spot: Vec2 },
    /// Turning as the sign says, then on along `heading`.
    Turn { track: usize, heading: f64 },
    /// On along `heading`, watching for the next sign.
    GoOn { track: usize, heading: f64 },
}

/// The SignFollower program.
#[derive(Debug)]
pub struct SignFollower {
    config: SignConfig,
    driver: Driver,
    book: SignBook,
    axes: BuildingAxes,
    phase: Phase,
    start_heading: Option<f64>,
}

impl SignFollower {
    /// The program with its settings.
    #[must_use]
    pub fn new(config: SignConfig) -> Self {
        Self {
            driver: Driver::new(&["Signs", "Egomotion", "RangeFinder"], config.stale_ns),
            config,
            book: SignBook::default(),
            axes: BuildingAxes::default(),
            phase: Phase::Look {
                turns: 0,
                still_from: None,
            },
            start_heading: None,
        }
    }

    fn follows(&self, arrow: SignArrow) -> Option<ArrowWord> {
        let word = ArrowWord::of(arrow)?;
        (self.config.arrows.is_empty() || self.config.arrows.contains(&word)).then_some(word)
    }

    fn on_signs(&mut self, ctx: &mut Context<'_>, signs: &Signs) {
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        self.book.read(pose, signs);
        self.decide(ctx);
    }

    /// Acts on the signs read so far.
    fn decide(&mut self, ctx: &mut Context<'_>) {
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        let here = pose.position();
        if self.book.settled().any(|(_, _, a)| a == SignArrow::Desk) {
            self.driver.finish(
                ctx,
                exit::SAW_DESK,
                "the registration desk's sign is in sight",
            );
            return;
        }
        let followed = match self.phase {
            Phase::Look { .. } | Phase::Ahead => None,
            // Before the sign taken, others wait: it is the nearest.
            Phase::Approach { .. } => return,
            Phase::Turn { track, .. } | Phase::GoOn { track, .. } => Some(track),
        };
        let nearest = self
            .book
            .settled()
            .filter_map(|(i, t, a)| self.follows(a).map(|w| (i, t.position, w)))
            .filter(|(i, p, _)| {
                followed.is_none_or(|f| {
                    *i != f && p.distance(self.book.track(f).position) > OTHER_SIGN_M
                })
            })
            .min_by(|a, b| a.1.distance(here).total_cmp(&b.1.distance(here)));
        let Some((track, position, word)) = nearest else {
            return;
        };
        if followed.is_some() {
            self.driver.finish(
                ctx,
                exit::SUCCESS,
                &format!(
                    "the next sign ({word:?}) at {:.2},{:.2} (odometry)",
                    position.x, position.y
                ),
            );
            return;
        }
        let spot = position + (here - position) * (IN_FRONT_M / here.distance(position).max(1e-6));
        ctx.info(&format!(
            "a sign ({word:?}) at {:.2},{:.2} (odometry): going before it",
            position.x, position.y
        ));
        self.phase = Phase::Approach { track, spot };
        self.driver.mover.goto(ctx, spot);
    }

    fn other_input(&mut self, ctx: &mut Context<'_>, input: &Input<'_>) {
        let _ = match input.interface {
            "Signs" => input
                .decode()
                .map(|signs: Signs| self.on_signs(ctx, &signs)),
            "RangeFinder" => input.decode().map(|scan: RangeFinder| {
                if let Some(pose) = self.driver.odometry.pose() {
                    self.axes.observe(ctx.now(), pose, &scan);
                }
            }),
            _ => Ok(()),
        };
    }

    fn step(&mut self, ctx: &mut Context<'_>) {
        let now = ctx.now();
        let since = *self.driver.started_ns.get_or_insert(now);
        if let Some(lost) = self.driver.watch.lost(now) {
            self.driver
                .finish(ctx, exit::INPUT_LOST, &format!("no {lost} for too long"));
            return;
        }
        if now - since > self.config.timeout_ns {
            self.driver
                .finish(ctx, exit::GAVE_UP, "no new sign in time");
            return;
        }
        self.driver.mover.tick(ctx);
        let Some(pose) = self.driver.odometry.pose() else {
            return;
        };
        let here = pose.position();
        match self.phase {
            Phase::Look { turns, still_from } => {
                if self.start_heading.is_none() {
                    self.start_heading = Some(pose.heading_rad);
                    self.axes.assume(pose.heading_rad);
                }
                let still_from = match still_from {
                    Some(at) => at,
                    None if turns == 0 => since,
                    None if self.driver.mover.arrived() => {
                        self.phase = Phase::Look {
                            turns,
                            still_from: Some(now),
                        };
                        now
                    }
                    None => return,
                };
                if now - still_from < LOOK_NS {
                    return;
                }
                if turns == 0 {
                    ctx.info("no sign in view: looking around");
                }
                if turns < LOOK_TURNS {
                    self.phase = Phase::Look {
                        turns: turns + 1,
                        still_from: None,
                    };
                    self.driver.mover.rotate(ctx, FRAC_PI_4);
                } else {
                    ctx.info("no sign all around: going on the way it faced");
                    self.phase = Phase::Ahead;
                }
            }
            Phase::Ahead => {
                let heading = *self.start_heading.get_or_insert(pose.heading_rad);
                self.go_on(ctx, here, heading);
            }
            Phase::Approach { track, spot } => {
                let position = self.book.track(track).position;
                // The sign is better placed from nearer: follow its estimate.
                let spot_now =
                    position + (spot - position) * (IN_FRONT_M / spot.distance(position).max(1e-6));
                if spot_now.distance(spot) > 0.1 {
                    self.phase = Phase::Approach {
                        track,
                        spot: spot_now,
                    };
                    self.driver.mover.goto(ctx, spot_now);
                }
                if here.distance(spot_now) < REACHED_M || self.driver.mover.arrived() {
                    let Some(word) = self.book.track(track).arrow().and_then(ArrowWord::of) else {
                        return;
                    };
                    let heading = heading_after(spot_now, position, word, &self.axes);
                    let on_axis = match (self.axes.axes(), self.axes.nearest(heading)) {
                        (Some(axes), Some(axis)) if axis == heading => format!(
                            "on the building's axis, learned from {:.1} m of wall",
                            axes.support * 0.1
                        ),
                        (None, Some(axis)) if axis == heading => {
                            "on the axis of the heading it started with: none learned from the scans yet"
                                .to_owned()
                        }
                        _ => "off the building's axes".to_owned(),
                    };
                    ctx.info(&format!(
                        "before the sign: it says {word:?}, turning to {:.0} deg (odometry, {on_axis})",
                        heading.to_degrees()
                    ));
                    // The timeout counts from the last sign taken.
                    self.driver.started_ns = Some(now);
                    self.phase = Phase::Turn { track, heading };
                    self.driver
                        .mover
                        .rotate(ctx, turn(pose.heading_rad, heading));
                }
            }
            Phase::Turn { track, heading } => {
                if self.driver.mover.arrived() || turn(pose.heading_rad, heading).abs() < 0.05 {
                    self.phase = Phase::GoOn { track, heading };
                    self.go_on(ctx, here, heading);
                }
            }
            Phase::GoOn { heading, .. } => self.go_on(ctx, here, heading),
        }
    }

    /// Goes on along `heading`, the goal renewed as the robot nears it.
    fn go_on(&mut self, ctx: &mut Context<'_>, here: Vec2, heading: f64) {
        let heading = self.axes.snap(heading, RESNAP_RAD);
        if let Phase::GoOn { track, .. } = self.phase {
            self.phase = Phase::GoOn { track, heading };
        }
        let renew = match self.driver.mover.wanted() {
            Some(crate::common::mover::Motion::Goto(goal)) => {
                goal.distance(here) < RENEW_M || turn((goal - here).angle(), heading).abs() > 0.6
            }
            _ => true,
        };
        if renew {
            let goal = match self.phase {
                Phase::Turn { track, .. } | Phase::GoOn { track, .. } => {
                    go_on_goal(here, heading, self.book.track(track).position)
                }
                Phase::Look { .. } | Phase::Ahead | Phase::Approach { .. } => {
                    here + Vec2::from_angle(heading) * GO_ON_M
                }
            };
            self.driver.mover.goto(ctx, goal);
        }
    }
}

moving_service!(SignFollower);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn going_on_past_a_sign_in_the_way_steps_beside_it_first() {
        let here = Vec2::new(0.0, 0.0);
        // The sign ahead, a little to the left: a point past it on its right.
        let goal = go_on_goal(here, 0.0, Vec2::new(1.3, 0.4));
        assert!(goal.distance(Vec2::new(1.8, -1.0)) < 1e-9, "{goal:?}");
        let goal = go_on_goal(here, 0.0, Vec2::new(1.3, -0.2));
        assert!(goal.distance(Vec2::new(1.8, 1.2)) < 1e-9, "{goal:?}");
        // Behind, or well to the side: straight on.
        let straight = Vec2::new(GO_ON_M, 0.0);
        assert_eq!(go_on_goal(here, 0.0, Vec2::new(-1.0, 0.0)), straight);
        assert_eq!(go_on_goal(here, 0.0, Vec2::new(2.0, 1.5)), straight);
    }

    #[test]
    fn arrows_are_read_with_or_without_the_word_arrow() {
        assert_eq!(ArrowWord::parse("arrow left"), Ok(ArrowWord::Left));
        assert_eq!(ArrowWord::parse("Right"), Ok(ArrowWord::Right));
        assert_eq!(ArrowWord::parse("arrow-up"), Ok(ArrowWord::Up));
        assert!(ArrowWord::parse("desk").is_err());
        assert!(ArrowWord::parse("arrow sideways").is_err());
    }

    #[test]
    fn a_sign_says_what_two_of_its_last_three_readings_say() {
        let mut book = SignBook::default();
        let at = Vec2::new(5.0, 1.0);
        let i = book.observe(at, SignArrow::Left);
        assert_eq!(book.track(i).arrow(), None, "one reading is not enough");
        assert_eq!(book.observe(at + Vec2::new(0.2, 0.0), SignArrow::Right), i);
        assert_eq!(book.track(i).arrow(), None);
        book.observe(at, SignArrow::Left);
        assert_eq!(book.track(i).arrow(), Some(SignArrow::Left));
        book.observe(at, SignArrow::Right);
        assert_eq!(book.track(i).arrow(), Some(SignArrow::Right));
        // Another sign, elsewhere.
        let j = book.observe(Vec2::new(12.0, 1.0), SignArrow::Up);
        assert_ne!(i, j);
        assert_eq!(book.settled().count(), 1);
    }

    #[test]
    fn the_heading_after_a_sign_is_the_arrow_turned_from_the_way_it_was_faced() {
        let close = |a: f64, b: f64| (wrap_angle(a - b)).abs() < 1e-9;
        let square = BuildingAxes::along(0.0);
        let before = Vec2::new(0.0, 0.0);
        // Facing a sign ahead (+x), slightly to the left.
        let sign = Vec2::new(1.3, 0.2);
        let after = |arrow| heading_after(before, sign, arrow, &square);
        assert!(close(after(ArrowWord::Up), 0.0));
        assert!(close(after(ArrowWord::Left), FRAC_PI_2));
        assert!(close(after(ArrowWord::Right), -FRAC_PI_2));
        assert!(close(after(ArrowWord::Down), PI));
        // Seen from well off its face (50 degrees), on a wall along x: square to the wall,
        // turned.
        let aside = Vec2::from_angle(50_f64.to_radians()) * 4.0;
        let mut walled = BuildingAxes::along(0.0);
        let wall: Vec<Vec2> = (-10..=10)
            .map(|k| aside + Vec2::new(f64::from(k) * 0.05, 0.0))
            .collect();
        walled.observe_points(0, before, &wall);
        assert!(close(
            heading_after(before, aside, ArrowWord::Left, &walled),
            PI
        ));
        // A sign on a post 0.5 m from a corridor's side wall, seen from 3 m down the
        // corridor: the side wall is not behind it, and straight on is down the corridor.
        let post = Vec2::new(3.0, 0.7);
        let mut corridor = BuildingAxes::along(0.0);
        let side: Vec<Vec2> = (0..=120)
            .map(|k| Vec2::new(f64::from(k) * 0.05, 1.2))
            .collect();
        corridor.observe_points(0, before, &side);
        let on = heading_after(before, post, ArrowWord::Up, &corridor);
        assert!(close(on, 0.0), "{}", on.to_degrees());
        // With no wall seen behind it: the line of sight, turned, kept off the axes.
        let off = heading_after(before, aside, ArrowWord::Left, &square);
        assert!(close(off, 140_f64.to_radians()), "{}", off.to_degrees());
        // A building at 30 degrees to the odometry frame (the robot started turned): the
        // building's axes, not the odometry's.
        let turned = BuildingAxes::along(30_f64.to_radians());
        let up = heading_after(before, sign, ArrowWord::Up, &turned);
        assert!(close(up, 30_f64.to_radians()), "{}", up.to_degrees());
        let left = heading_after(before, sign, ArrowWord::Left, &turned);
        assert!(close(left, 120_f64.to_radians()), "{}", left.to_degrees());
        // Nothing learned: the way it faced, turned, as it is.
        let blind = BuildingAxes::default();
        assert!(close(
            heading_after(before, sign, ArrowWord::Up, &blind),
            sign.angle()
        ));
        let diagonal = Vec2::new(1.0, 1.0);
        assert!(close(
            heading_after(before, diagonal, ArrowWord::Up, &blind),
            FRAC_PI_4
        ));
    }
}
