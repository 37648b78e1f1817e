//! What each message becomes in Rerun. The entity tree:
//!
//! | entity | what |
//! |---|---|
//! | `world/robot/pose`, `world/robot/path` | the true pose (GroundTruth) and its whole path |
//! | `world/mission/path` | the true path again, coloured by the mission's state (the `status/sequencer` lane's colours), when the recording has a mission |
//! | `world/odometry/pose`, `world/odometry/path` | the odometry's pose (Egomotion) and path, in the odometry frame (`world/odometry` places it in the world: where the odometry started on the true path) |
//! | `world/scans/<topic>` | every RangeFinder's hits placed in the world with the pose above |
//! | `world/map` | the simulated world's map, for all times, under everything else |
//! | `world/odometry/mover/PROVIDER/goal`, `.../waypoint` | where each Mover is going (odometry frame) |
//! | `world/blobs3d/<topic>`, `world/signs/<topic>` | perception placed in the world |
//! | `robot/body`, `robot/scans/<topic>` | the robot frame: outline, hits and (sonar) rays |
//! | `camera/<topic>/image`, `.../blobs/<topic>`, `.../signs/<topic>` | images, with boxes |
//! | `events/broker`, `events/sequencer`, `events/log/<service>`, `events/commands/<service>`, `events/health`, `events/mover/<topic>` | text logs |
//! | `status/bindings/<client>/<interface>`, `status/services/<service>`, `status/health/<service>`, `status/sequencer`, `status/mover/<topic>` | state lanes (markers on the timeline) |
//! | `events/replay/...`, `status/replay/...`, `world/replay/...` | the same for a replay's re-simulated outputs (`/replay/...` channels), beside the recorded ones |
//! | `events/replay/faults`, `status/replay/faults/<service>`, `world/replay/faults` | the faults a replay injected: text, timeline marker, where the robot was |
//! | `plots/<topic>/<field>` | every numeric field of interfaces without a drawing, and velocities |
//! | `topics/<topic>` | every other decodable message, as text |
//!
//! The world frame is the simulator's (GroundTruth) when the recording has it, else the
//! odometry frame. Scans are placed with the last pose received before them, and taken off
//! when their sensor has been silent for a second (`freshness`), so a dead laser's last
//! scan does not stay on screen. A replay's
//! re-simulated poses (only with `lewis replay --all`) are drawn at `world/replay/...` and
//! place nothing.

mod camera;
mod events;
mod faults;
mod freshness;
mod geometry;
mod lanes;
mod plots;
mod scans;
mod sequencer;

use std::collections::{BTreeMap, BTreeSet};

use lewis_interfaces::dynamic::Value;
use lewis_interfaces::msg::Pose2D;
use rerun::{Color, LineStrips2D};
use rerun::{EntityPath, EntityPathPart};

use crate::ViewError;
use crate::decode::{Decoded, Drawn};
use crate::rows::{ChunkSink, Rows, Stamp};
use crate::source::ChannelInfo;

pub(crate) use geometry::Point;
pub(crate) use lanes::state_colour;
pub(crate) use sequencer::lane as sequencer_lane;

/// The entity path made of these parts, each taken literally.
pub(crate) fn entity<'a>(parts: impl IntoIterator<Item = &'a str>) -> EntityPath {
    EntityPath::new(
        parts
            .into_iter()
            .filter(|part| !part.is_empty())
            .map(EntityPathPart::new)
            .collect(),
    )
}

/// Where a channel's data comes from: the robot, as recorded, or a replay's re-simulation
/// (`/replay/...` channels, which `lewis replay` writes beside the recorded ones). Entities
/// with fixed paths (broker, bindings, health, logs, mover, sequencer) get a `replay`
/// branch for re-simulated data, so the two are shown side by side, never mixed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Side {
    /// Recorded live.
    Recorded,
    /// Written by a replay.
    Replayed,
}

/// The branch of re-simulated data under each root.
pub(crate) const REPLAY_BRANCH: &str = "replay";

/// The prefix of the channels a replay writes.
const REPLAY_TOPIC_PREFIX: &str = "/replay/";

impl Side {
    /// The side of the channel `topic`.
    pub(crate) fn of(topic: &str) -> Self {
        if topic.starts_with(REPLAY_TOPIC_PREFIX) {
            Self::Replayed
        } else {
            Self::Recorded
        }
    }

    /// `root/prefix.../<topic's parts>`, with [`REPLAY_BRANCH`] after the root for
    /// re-simulated data and the topic without its `/replay` prefix.
    pub(crate) fn topic_entity(self, root: &str, prefix: &[&str], topic: &str) -> EntityPath {
        let parts: Vec<&str> = prefix
            .iter()
            .copied()
            .chain(topic_parts(recorded_topic(topic)))
            .collect();
        self.entity(root, &parts)
    }

    /// `root/rest...`, with [`REPLAY_BRANCH`] after the root for re-simulated data.
    pub(crate) fn entity(self, root: &str, rest: &[&str]) -> EntityPath {
        let branch = (self == Self::Replayed).then_some(REPLAY_BRANCH);
        entity(
            std::iter::once(root)
                .chain(branch)
                .chain(rest.iter().copied()),
        )
    }
}

/// The channel a replay's channel re-simulates: `/replay/mover/Mover` is `/mover/Mover`; a
/// recorded channel is itself.
pub(crate) fn recorded_topic(topic: &str) -> &str {
    topic.strip_prefix("/replay").unwrap_or(topic)
}

/// The parts of a topic: `/laser/RangeFinder` is `laser`, `RangeFinder`.
pub(crate) fn topic_parts(topic: &str) -> impl Iterator<Item = &str> {
    topic.split('/').filter(|part| !part.is_empty())
}

/// `prefix` then the parts of `topic`, then `suffix`.
pub(crate) fn topic_entity(prefix: &[&str], topic: &str, suffix: &[&str]) -> EntityPath {
    entity(
        prefix
            .iter()
            .copied()
            .chain(topic_parts(topic))
            .chain(suffix.iter().copied()),
    )
}

/// The world view frames the path with this much room around it (about the sonar's reach)…
const WORLD_MARGIN_M: f64 = 4.0;
/// …and shows at least this much on each side of its centre.
const WORLD_MIN_HALF_SIZE_M: f64 = 5.0;

/// Paths are kept with points this far apart at least: enough for a drawing, and a long
/// run stays small.
const PATH_STEP_M: f64 = 0.01;

/// What the scene remembers between messages.
pub(crate) struct Scene {
    rows: Rows,
    /// The pose that places robot-frame data in the world: the last true pose, or the last
    /// odometry pose when the recording has no true pose.
    world_pose: Option<Pose2D>,
    has_truth: bool,
    truth_path: Vec<Point>,
    odometry_path: Vec<Point>,
    scan_colours: BTreeMap<String, Color>,
    plotted_topics: BTreeSet<String>,
    has_images: bool,
    events: events::EventState,
    freshness: freshness::Freshness,
    /// The last true pose and the last odometry pose, until the odometry frame is placed.
    first_truth: Option<Pose2D>,
    first_odometry: Option<Pose2D>,
    odometry_placed: bool,
    sequencer: sequencer::SequencerState,
    /// The true path in pieces, each with the mission's state while it was driven.
    mission_path: Vec<(String, Vec<Point>)>,
    faults: faults::FaultMarks,
    has_replay: bool,
    camera: camera::CameraState,
    /// Messages drawn, shown generically, not decodable.
    pub counts: Counts,
    /// Per topic: messages that could not be decoded and the first reason.
    pub failures: BTreeMap<String, (u64, String)>,
}

/// How many messages went where.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Messages read.
    pub messages: u64,
    /// Messages of interfaces with their own drawing.
    pub drawn: u64,
    /// Messages shown generically (plots, text).
    pub generic: u64,
    /// Messages that could not be decoded.
    pub failed: u64,
}

impl Scene {
    pub(crate) fn new(frames: crate::CameraFrames) -> Self {
        Self {
            rows: Rows::new(),
            world_pose: None,
            has_truth: false,
            truth_path: Vec::new(),
            odometry_path: Vec::new(),
            scan_colours: BTreeMap::new(),
            plotted_topics: BTreeSet::new(),
            has_images: false,
            events: events::EventState::default(),
            freshness: freshness::Freshness::default(),
            first_truth: None,
            first_odometry: None,
            odometry_placed: false,
            sequencer: sequencer::SequencerState::default(),
            mission_path: Vec::new(),
            faults: faults::FaultMarks::default(),
            has_replay: false,
            camera: camera::CameraState::new(frames),
            counts: Counts::default(),
            failures: BTreeMap::new(),
        }
    }

    /// The rows, for data that is not a message (the frames' orientation).
    pub(crate) fn rows_mut(&mut self) -> &mut Rows {
        &mut self.rows
    }

    /// The topics with plots, in order.
    pub(crate) fn plotted_topics(&self) -> Vec<String> {
        self.plotted_topics.iter().cloned().collect()
    }

    /// Where the robot went (its true path, else its odometry's), with room around it for
    /// what it saw: what the world view frames. `None` without a path.
    pub(crate) fn world_bounds(&self) -> Option<crate::blueprint::Bounds> {
        let path = if self.truth_path.is_empty() {
            &self.odometry_path
        } else {
            &self.truth_path
        };
        let first = path.first()?;
        let (mut x, mut y) = ([first.x; 2], [first.y; 2]);
        for p in path {
            x = [x[0].min(p.x), x[1].max(p.x)];
            y = [y[0].min(p.y), y[1].max(p.y)];
        }
        let widen = |[low, high]: [f64; 2]| {
            let centre = (low + high) / 2.0;
            let half = ((high - low) / 2.0 + WORLD_MARGIN_M).max(WORLD_MIN_HALF_SIZE_M);
            [centre - half, centre + half]
        };
        Some(crate::blueprint::Bounds {
            x_m: widen(x),
            y_m: widen(y),
        })
    }

    /// Whether the recording holds a replay's outputs (`/replay/...` channels).
    pub(crate) fn has_replay(&self) -> bool {
        self.has_replay
    }

    /// Whether the recording has camera images.
    pub(crate) fn has_images(&self) -> bool {
        self.has_images
    }

    /// Camera frames left out ([`crate::CameraFrames::every_ns`]).
    pub(crate) fn frames_skipped(&self) -> u64 {
        self.camera.skipped
    }

    /// Rows logged per entity path.
    pub(crate) fn row_counts(&self) -> &BTreeMap<String, u64> {
        self.rows.row_counts()
    }

    /// Draws the robot's outline, once.
    pub(crate) fn start(&mut self, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
        scans::log_robot_body(&mut self.rows, sink)
    }

    /// Draws one message.
    pub(crate) fn message(
        &mut self,
        sink: &mut dyn ChunkSink,
        channel: &ChannelInfo,
        stamp: Stamp,
        decoded: Decoded,
    ) -> Result<(), ViewError> {
        self.counts.messages += 1;
        self.freshness.clear_stale(&mut self.rows, sink, stamp)?;
        self.place_odometry(sink)?;
        match decoded {
            Decoded::Drawn(drawn, value) => {
                self.counts.drawn += 1;
                self.drawn(sink, channel, stamp, *drawn)?;
                if let Some(value) = value {
                    self.plot(sink, &channel.topic, stamp, &value)?;
                }
                Ok(())
            }
            Decoded::Generic(value) => {
                self.counts.generic += 1;
                self.generic(sink, channel, stamp, &value)
            }
            Decoded::Failed(reason) => {
                self.counts.failed += 1;
                let failure = self
                    .failures
                    .entry(channel.topic.clone())
                    .or_insert((0, reason));
                failure.0 += 1;
                Ok(())
            }
        }
    }

    fn drawn(
        &mut self,
        sink: &mut dyn ChunkSink,
        channel: &ChannelInfo,
        stamp: Stamp,
        drawn: Drawn,
    ) -> Result<(), ViewError> {
        let topic = channel.topic.as_str();
        let side = Side::of(topic);
        self.has_replay |= side == Side::Replayed;
        let rows = &mut self.rows;
        match drawn {
            Drawn::RangeFinder(scan) => {
                let colour = scan_colour(&mut self.scan_colours, topic);
                self.freshness.drawn(topic, stamp);
                scans::log_scan(
                    rows,
                    sink,
                    topic,
                    stamp,
                    &scan,
                    colour,
                    self.world_pose.as_ref(),
                )
            }
            Drawn::GroundTruth(truth) if side == Side::Replayed => scans::log_pose(
                rows,
                sink,
                &side.entity("world", &["robot", "pose"]),
                stamp,
                &truth.pose,
                true,
            ),
            Drawn::Egomotion(odometry) if side == Side::Replayed => scans::log_pose(
                rows,
                sink,
                &side.entity("world", &["odometry", "pose"]),
                stamp,
                &odometry.pose,
                false,
            ),
            Drawn::GroundTruth(truth) => {
                self.has_truth = true;
                self.first_truth.get_or_insert_with(|| truth.pose.clone());
                self.world_pose = Some(truth.pose.clone());
                push_path(&mut self.truth_path, &truth.pose);
                if let Some(state) = self.sequencer.current(Side::Recorded) {
                    push_mission_path(&mut self.mission_path, state, &truth.pose);
                }
                scans::log_pose(
                    rows,
                    sink,
                    &entity(["world", "robot", "pose"]),
                    stamp,
                    &truth.pose,
                    true,
                )
            }
            Drawn::Egomotion(odometry) => {
                self.first_odometry
                    .get_or_insert_with(|| odometry.pose.clone());
                if !self.has_truth {
                    self.world_pose = Some(odometry.pose.clone());
                }
                push_path(&mut self.odometry_path, &odometry.pose);
                scans::log_pose(
                    rows,
                    sink,
                    &entity(["world", "odometry", "pose"]),
                    stamp,
                    &odometry.pose,
                    false,
                )
            }
            Drawn::Image(image) => {
                self.has_images = true;
                self.camera.image(rows, sink, topic, stamp, &image)
            }
            Drawn::Blobs(blobs) => self.camera.blobs(rows, sink, topic, stamp, &blobs),
            Drawn::Signs(signs) => {
                self.camera.signs(rows, sink, topic, stamp, &signs)?;
                scans::log_signs_in_world(
                    rows,
                    sink,
                    topic,
                    stamp,
                    &signs,
                    self.world_pose.as_ref(),
                )
            }
            Drawn::Blobs3D(blobs) => scans::log_blobs3d_in_world(
                rows,
                sink,
                topic,
                stamp,
                &blobs,
                self.world_pose.as_ref(),
            ),
            Drawn::Mover(mover) => {
                scans::log_mover(rows, sink, side, topic, stamp, &mover)?;
                self.events.mover(rows, sink, side, topic, stamp, &mover)
            }
            Drawn::Broker(decision) => events::broker(rows, sink, side, stamp, &decision),
            Drawn::Health(health) => self.events.health(rows, sink, side, stamp, &health),
            Drawn::LogLine(line) if topic == faults::FAULTS_TOPIC => {
                self.faults
                    .fault(rows, sink, stamp, &line, self.world_pose.as_ref())
            }
            Drawn::LogLine(line) => events::log_line(rows, sink, side, stamp, &line),
            Drawn::CommandLog(command) => events::command(rows, sink, side, stamp, &command),
            Drawn::Sequencer(record) => self.sequencer.record(rows, sink, side, stamp, &record),
        }
    }

    /// Places the odometry frame in the world once both the first true pose and the first
    /// odometry pose are known: the odometry started where the robot truly was. Without a
    /// true pose, the odometry frame is the world frame.
    fn place_odometry(&mut self, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
        if self.odometry_placed {
            return Ok(());
        }
        let (Some(truth), Some(odometry)) = (&self.first_truth, &self.first_odometry) else {
            return Ok(());
        };
        self.odometry_placed = true;
        let Some(placement) = geometry::Placement::between(truth, odometry) else {
            return Ok(());
        };
        self.rows.log_static(
            sink,
            &entity(["world", "odometry"]),
            &placement.to_transform(),
        )
    }

    fn generic(
        &mut self,
        sink: &mut dyn ChunkSink,
        channel: &ChannelInfo,
        stamp: Stamp,
        value: &Value,
    ) -> Result<(), ViewError> {
        let compiled_in = lewis_interfaces::msg::INTERFACES
            .iter()
            .any(|i| i.publication.name == channel.schema_name);
        if !compiled_in {
            events::generic_text(&mut self.rows, sink, &channel.topic, stamp, value)?;
        }
        self.has_replay |= Side::of(&channel.topic) == Side::Replayed;
        self.plot(sink, &channel.topic, stamp, value)
    }

    fn plot(
        &mut self,
        sink: &mut dyn ChunkSink,
        topic: &str,
        stamp: Stamp,
        value: &Value,
    ) -> Result<(), ViewError> {
        if plots::log_numeric_fields(&mut self.rows, sink, topic, stamp, value)?
            && !self.plotted_topics.contains(topic)
        {
            self.plotted_topics.insert(topic.to_owned());
        }
        Ok(())
    }

    /// Draws what needs the whole recording (the paths) and sends every pending row.
    pub(crate) fn finish(&mut self, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
        let paths = [
            (
                ["world", "robot", "path"],
                &self.truth_path,
                Color::from_rgb(40, 170, 60),
            ),
            (
                ["world", "odometry", "path"],
                &self.odometry_path,
                Color::from_rgb(150, 150, 150),
            ),
        ];
        for (path, points, colour) in paths {
            if points.len() > 1 {
                let strip: Vec<[f32; 2]> = points.iter().map(|p| p.to_f32()).collect();
                self.rows.log_static(
                    sink,
                    &entity(path),
                    &LineStrips2D::new([strip])
                        .with_colors([colour])
                        .with_radii([0.02_f32]),
                )?;
            }
        }
        if !self.mission_path.is_empty() {
            let mut states: Vec<&str> = Vec::new();
            let mut strips = Vec::new();
            let mut colours = Vec::new();
            for (state, points) in &self.mission_path {
                let [r, g, b] = state_colour(state, &states);
                if !states.contains(&state.as_str()) {
                    states.push(state);
                }
                strips.push(points.iter().map(|p| p.to_f32()).collect::<Vec<[f32; 2]>>());
                colours.push(Color::from_rgb(r, g, b));
            }
            self.rows.log_static(
                sink,
                &entity(["world", "mission", "path"]),
                &LineStrips2D::new(strips)
                    .with_colors(colours)
                    .with_radii([0.05_f32]),
            )?;
        }
        lanes::configure(&mut self.rows, sink)?;
        self.rows.flush(sink)
    }
}

/// Adds `pose` to the piece of the mission's path driven in `state`: a new piece (from the
/// last point, so that the path stays whole) when the state changed.
fn push_mission_path(pieces: &mut Vec<(String, Vec<Point>)>, state: &str, pose: &Pose2D) {
    let point = Point::new(pose.x, pose.y);
    if !point.is_finite() {
        return;
    }
    match pieces.last_mut() {
        Some((last_state, points)) if last_state == state => {
            if points
                .last()
                .is_none_or(|last| last.distance(point) >= PATH_STEP_M)
            {
                points.push(point);
            }
        }
        last => {
            let start = last.and_then(|(_, points)| points.last().copied());
            pieces.push((state.to_owned(), start.into_iter().chain([point]).collect()));
        }
    }
}

fn push_path(path: &mut Vec<Point>, pose: &Pose2D) {
    let point = Point::new(pose.x, pose.y);
    if !point.is_finite() {
        return;
    }
    if path
        .last()
        .is_none_or(|last| last.distance(point) >= PATH_STEP_M)
    {
        path.push(point);
    }
}

/// Laser red, sonar blue, other range finders from a fixed palette in order of appearance:
/// a failover shows as the scan changing colour and character.
fn scan_colour(colours: &mut BTreeMap<String, Color>, topic: &str) -> Color {
    const OTHERS: [(u8, u8, u8); 4] = [(200, 160, 0), (160, 60, 200), (0, 170, 170), (120, 80, 40)];
    let count = colours.len();
    *colours.entry(topic.to_owned()).or_insert_with(|| {
        let lower = topic.to_ascii_lowercase();
        if lower.contains("sonar") {
            Color::from_rgb(40, 110, 240)
        } else if lower.contains("laser") || lower.contains("lidar") {
            Color::from_rgb(230, 60, 30)
        } else {
            let (r, g, b) = OTHERS[count % OTHERS.len()];
            Color::from_rgb(r, g, b)
        }
    })
}
