//! A mission at a glance, as one PNG: the world's map, the robot's path coloured by the
//! sequencer's state (the same colours as the `status/sequencer` lane), the signs it saw,
//! and a cross wherever a service failed for good (the broker's `service-failed`: the
//! laser's death in the Challenge's fault). For the README and for `lewis demo`; `lewis
//! view RUN.mcap --png OUT.png` writes it.
//!
//! The path is the simulator's GroundTruth when the recording has it, else the odometry
//! (Egomotion, in its own frame: drawn without a map). Only the recorded side is drawn: a
//! replay's re-simulated channels (`/replay/...`) are left out. The picture has no text (no
//! font here): [`PictureReport`] says which colour is which state.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use image::{Rgb, RgbImage};
use lewis_interfaces::msg::{BrokerAction, Pose2D, Signs};

use crate::ViewError;
use crate::decode::{ChannelDecoder, Decoded, Drawn};
use crate::draw::{Side, sequencer_lane, state_colour};
use crate::source;
use crate::world_map::{self, MapStatus};

/// Map pixels per picture pixel: a 800 x 500 map becomes 1600 x 1000.
const MAP_SCALE: u32 = 2;
/// Without a map, the longer side of the picture.
const BARE_SIZE_PX: f64 = 1200.0;
/// Without a map, the margin around the path.
const BARE_MARGIN_M: f64 = 2.0;
/// Poses closer than this to the last one drawn are skipped.
const MIN_STEP_M: f64 = 0.02;
/// Detections of one sign fall within this distance of each other.
const SIGN_CLUSTER_M: f64 = 1.5;
/// A sign seen fewer times is taken for noise.
const SIGN_MIN_DETECTIONS: usize = 3;
/// The path's colour before the mission starts (or without a mission).
const NO_STATE: Rgb<u8> = Rgb([120, 120, 120]);
const WALL: Rgb<u8> = Rgb([70, 70, 70]);
const FREE: Rgb<u8> = Rgb([250, 250, 250]);
const CROSS: Rgb<u8> = Rgb([198, 40, 40]);
const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
const WHITE: Rgb<u8> = Rgb([255, 255, 255]);
const START: Rgb<u8> = Rgb([46, 125, 50]);

/// What [`write_png`] drew.
#[derive(Debug, Clone, PartialEq)]
pub struct PictureReport {
    /// The PNG written.
    pub output: PathBuf,
    /// Its size in pixels.
    pub width_px: u32,
    /// Its size in pixels.
    pub height_px: u32,
    /// The interface the path comes from (`GroundTruth` or `Egomotion`), `None` without one.
    pub pose_source: Option<&'static str>,
    /// The poses drawn (after skipping those closer than 2 cm to the last).
    pub poses: usize,
    /// The sequencer's states in the order they first appear, with their colour.
    pub states: Vec<(String, [u8; 3])>,
    /// The signs drawn: the arrow's word and where (world frame, m).
    pub signs: Vec<(String, [f64; 2])>,
    /// The services that failed for good and where the robot was then (world frame, m;
    /// `None` when no pose was known yet).
    pub failures: Vec<(String, Option<[f64; 2]>)>,
    /// What became of the world map, when the recording names a world.
    pub map: Option<MapStatus>,
}

impl fmt::Display for PictureReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({} x {} px): ",
            self.output.display(),
            self.width_px,
            self.height_px
        )?;
        match self.pose_source {
            Some(source) => write!(f, "path of {} {source} poses", self.poses)?,
            None => write!(f, "no pose in the recording")?,
        }
        if !self.states.is_empty() {
            let states: Vec<String> = self
                .states
                .iter()
                .map(|(state, [r, g, b])| format!("{state} #{r:02x}{g:02x}{b:02x}"))
                .collect();
            write!(f, "; states {}", states.join(", "))?;
        }
        write!(f, "; {} signs", self.signs.len())?;
        for (service, at) in &self.failures {
            match at {
                Some([x, y]) => write!(f, "; {service} failed at ({x:.1}, {y:.1}) m")?,
                None => write!(f, "; {service} failed")?,
            }
        }
        if let Some(map) = &self.map {
            write!(f, "; {map}")?;
        }
        Ok(())
    }
}

/// What is read from the recording, on its log time.
#[derive(Default)]
struct Collected {
    truth: Vec<(u64, Pose2D)>,
    odometry: Vec<(u64, Pose2D)>,
    lanes: Vec<(u64, String)>,
    signs: Vec<(u64, Signs)>,
    failures: Vec<(u64, String)>,
    metadata: BTreeMap<String, BTreeMap<String, String>>,
}

fn collect(recording: &Path) -> Result<Collected, ViewError> {
    let mut collected = Collected::default();
    let mut decoders: BTreeMap<u16, ChannelDecoder> = BTreeMap::new();
    let outcome = source::read_file(
        recording,
        &mut |message| {
            if Side::of(&message.channel.topic) != Side::Recorded {
                return Ok(());
            }
            let decoder = decoders
                .entry(message.channel.id)
                .or_insert_with(|| ChannelDecoder::new(message.channel));
            let Decoded::Drawn(drawn, _) = decoder.decode(message.data) else {
                return Ok(());
            };
            let t = message.log_time_ns;
            match *drawn {
                Drawn::GroundTruth(m) => collected.truth.push((t, m.pose)),
                Drawn::Egomotion(m) => collected.odometry.push((t, m.pose)),
                Drawn::Sequencer(m) => {
                    if let Some(lane) = sequencer_lane(&m) {
                        collected.lanes.push((t, lane));
                    }
                }
                Drawn::Signs(m) => collected.signs.push((t, m)),
                Drawn::Broker(m)
                    if BrokerAction::parse(&m.action) == Some(BrokerAction::ServiceFailed) =>
                {
                    collected.failures.push((t, m.service));
                }
                _ => {}
            }
            Ok(())
        },
        &mut |_| {},
    )?;
    collected.metadata = outcome.metadata;
    for list in [&mut collected.truth, &mut collected.odometry] {
        list.sort_by_key(|(t, _)| *t);
    }
    collected.lanes.sort_by_key(|(t, _)| *t);
    collected.signs.sort_by_key(|(t, _)| *t);
    collected.failures.sort_by_key(|(t, _)| *t);
    Ok(collected)
}

/// The latest pose at or before `t` (the first one when `t` is earlier).
fn pose_at(poses: &[(u64, Pose2D)], t: u64) -> Option<&Pose2D> {
    let after = poses.partition_point(|(pt, _)| *pt <= t);
    poses.get(after.saturating_sub(1)).map(|(_, p)| p)
}

/// World metres to picture pixels.
struct Frame {
    width: u32,
    height: u32,
    origin_m: [f64; 2],
    px_per_m: f64,
}

impl Frame {
    fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.origin_m[0]) * self.px_per_m,
            f64::from(self.height) - (y - self.origin_m[1]) * self.px_per_m,
        )
    }
}

/// Writes the picture of the recording `recording` to `output` (PNG).
///
/// # Errors
/// When the recording cannot be read or is not MCAP, or the PNG cannot be written.
pub fn write_png(recording: &Path, output: &Path) -> Result<PictureReport, ViewError> {
    let collected = collect(recording)?;
    let (poses, pose_source) = if !collected.truth.is_empty() {
        (&collected.truth, Some("GroundTruth"))
    } else if !collected.odometry.is_empty() {
        (&collected.odometry, Some("Egomotion"))
    } else {
        (&collected.truth, None)
    };
    // The map matches only the world frame.
    let world = (pose_source != Some("Egomotion"))
        .then(|| world_map::named_world(&collected.metadata))
        .flatten();
    let (map, map_status) = match world.map(|w| world_map::find(&w, recording)) {
        Some(Ok(found)) => {
            let status = MapStatus::Drawn {
                image: found.image.clone(),
                width_px: found.width_px,
                height_px: found.height_px,
            };
            (Some(found), Some(status))
        }
        Some(Err(missing)) => (None, Some(missing)),
        None => (None, None),
    };
    let (frame, mut picture) = match &map {
        Some(map) => {
            let frame = Frame {
                width: map.width_px * MAP_SCALE,
                height: map.height_px * MAP_SCALE,
                origin_m: map.origin_m,
                px_per_m: f64::from(MAP_SCALE) / map.metres_per_pixel,
            };
            let picture = RgbImage::from_fn(frame.width, frame.height, |x, y| {
                let at = ((y / MAP_SCALE) * map.width_px + x / MAP_SCALE) as usize * 4;
                // The map's walls are opaque, its free space transparent.
                if map.walls_rgba.get(at + 3).copied().unwrap_or(0) > 0 {
                    WALL
                } else {
                    FREE
                }
            });
            (frame, picture)
        }
        None => {
            let frame = bare_frame(poses);
            let picture = RgbImage::from_pixel(frame.width, frame.height, FREE);
            (frame, picture)
        }
    };

    // The states' colours, in order of appearance, as the lane has them.
    let mut states: Vec<(String, [u8; 3])> = Vec::new();
    for (_, lane) in &collected.lanes {
        if !states.iter().any(|(s, _)| s == lane) {
            let colour = state_colour(
                lane,
                &states.iter().map(|(s, _)| s.as_str()).collect::<Vec<_>>(),
            );
            states.push((lane.clone(), colour));
        }
    }
    let colour_of = |lane: &str| {
        states
            .iter()
            .find(|(s, _)| s == lane)
            .map_or(NO_STATE, |(_, c)| Rgb(*c))
    };

    // The path, each step in the colour of the state at its time.
    let mut drawn = 0;
    let mut last: Option<&Pose2D> = None;
    let mut lane_at = 0;
    let thickness = 4.0;
    for (t, pose) in poses {
        while lane_at < collected.lanes.len() && collected.lanes[lane_at].0 <= *t {
            lane_at += 1;
        }
        let colour = lane_at
            .checked_sub(1)
            .map_or(NO_STATE, |i| colour_of(&collected.lanes[i].1));
        match last {
            Some(prev) if (pose.x - prev.x).hypot(pose.y - prev.y) < MIN_STEP_M => continue,
            Some(prev) => {
                let a = frame.to_px(prev.x, prev.y);
                let b = frame.to_px(pose.x, pose.y);
                line(&mut picture, a, b, thickness, colour);
            }
            None => {}
        }
        last = Some(pose);
        drawn += 1;
    }
    if let (Some((_, first)), Some((_, end))) = (poses.first(), poses.last()) {
        let (x, y) = frame.to_px(first.x, first.y);
        disk(&mut picture, x, y, 9.0, WHITE);
        disk(&mut picture, x, y, 7.0, START);
        let (x, y) = frame.to_px(end.x, end.y);
        disk(&mut picture, x, y, 9.0, BLACK);
        disk(&mut picture, x, y, 5.0, WHITE);
    }

    // The signs: detections placed in the world from the pose at their time, grouped.
    let mut clusters: Vec<(String, [f64; 2], usize)> = Vec::new();
    for (t, signs) in &collected.signs {
        let Some(pose) = pose_at(poses, *t) else {
            continue;
        };
        let (sin, cos) = pose.theta.sin_cos();
        for sign in &signs.signs {
            let (sx, sy) = (sign.position.x, sign.position.y);
            let at = [pose.x + cos * sx - sin * sy, pose.y + sin * sx + cos * sy];
            let near = clusters.iter_mut().find(|(word, c, _)| {
                *word == sign.arrow && (c[0] - at[0]).hypot(c[1] - at[1]) < SIGN_CLUSTER_M
            });
            match near {
                Some((_, centre, n)) => {
                    let k = *n as f64;
                    centre[0] = (centre[0] * k + at[0]) / (k + 1.0);
                    centre[1] = (centre[1] * k + at[1]) / (k + 1.0);
                    *n += 1;
                }
                None => clusters.push((sign.arrow.clone(), at, 1)),
            }
        }
    }
    let signs: Vec<(String, [f64; 2])> = clusters
        .into_iter()
        .filter(|(_, _, n)| *n >= SIGN_MIN_DETECTIONS)
        .map(|(word, at, _)| (word, at))
        .collect();
    for (word, [x, y]) in &signs {
        let (px, py) = frame.to_px(*x, *y);
        square(&mut picture, px, py, 9.0, BLACK);
        square(&mut picture, px, py, 7.0, WHITE);
        if word == "desk" {
            disk(&mut picture, px, py, 4.0, BLACK);
        } else {
            arrow(&mut picture, px, py, word);
        }
    }

    // A cross where each service failed for good.
    let failures: Vec<(String, Option<[f64; 2]>)> = collected
        .failures
        .iter()
        .map(|(t, service)| (service.clone(), pose_at(poses, *t).map(|p| [p.x, p.y])))
        .collect();
    for (_, at) in &failures {
        if let Some([x, y]) = at {
            let (px, py) = frame.to_px(*x, *y);
            cross(&mut picture, px, py, 14.0, 4.5, WHITE);
            cross(&mut picture, px, py, 12.0, 2.5, CROSS);
        }
    }

    picture.save(output).map_err(|e| ViewError::Write {
        path: output.to_owned(),
        detail: e.to_string(),
    })?;
    Ok(PictureReport {
        output: output.to_owned(),
        width_px: frame.width,
        height_px: frame.height,
        pose_source,
        poses: drawn,
        states,
        signs,
        failures,
        map: map_status,
    })
}

/// A frame around `poses` without a map: the path with a margin, the longer side
/// [`BARE_SIZE_PX`].
fn bare_frame(poses: &[(u64, Pose2D)]) -> Frame {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for (_, p) in poses {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    if !lo[0].is_finite() {
        (lo, hi) = ([0.0, 0.0], [1.0, 1.0]);
    }
    let lo = [lo[0] - BARE_MARGIN_M, lo[1] - BARE_MARGIN_M];
    let size = [hi[0] + BARE_MARGIN_M - lo[0], hi[1] + BARE_MARGIN_M - lo[1]];
    let px_per_m = BARE_SIZE_PX / size[0].max(size[1]);
    Frame {
        width: (size[0] * px_per_m).ceil().max(1.0) as u32,
        height: (size[1] * px_per_m).ceil().max(1.0) as u32,
        origin_m: lo,
        px_per_m,
    }
}

fn put(picture: &mut RgbImage, x: i64, y: i64, colour: Rgb<u8>) {
    if let (Ok(x), Ok(y)) = (u32::try_from(x), u32::try_from(y))
        && x < picture.width()
        && y < picture.height()
    {
        picture.put_pixel(x, y, colour);
    }
}

fn disk(picture: &mut RgbImage, cx: f64, cy: f64, r: f64, colour: Rgb<u8>) {
    let reach = r.ceil() as i64;
    let (ix, iy) = (cx.round() as i64, cy.round() as i64);
    for dy in -reach..=reach {
        for dx in -reach..=reach {
            let (x, y) = (ix + dx, iy + dy);
            if (x as f64 - cx).hypot(y as f64 - cy) <= r {
                put(picture, x, y, colour);
            }
        }
    }
}

fn square(picture: &mut RgbImage, cx: f64, cy: f64, half: f64, colour: Rgb<u8>) {
    let (ix, iy, h) = (cx.round() as i64, cy.round() as i64, half.round() as i64);
    for y in iy - h..=iy + h {
        for x in ix - h..=ix + h {
            put(picture, x, y, colour);
        }
    }
}

fn line(picture: &mut RgbImage, a: (f64, f64), b: (f64, f64), width: f64, colour: Rgb<u8>) {
    let length = (b.0 - a.0).hypot(b.1 - a.1);
    let steps = (length * 2.0).ceil().max(1.0) as usize;
    for i in 0..=steps {
        let t = i as f64 / steps as f64;
        disk(
            picture,
            a.0 + (b.0 - a.0) * t,
            a.1 + (b.1 - a.1) * t,
            width / 2.0,
            colour,
        );
    }
}

fn cross(picture: &mut RgbImage, cx: f64, cy: f64, half: f64, width: f64, colour: Rgb<u8>) {
    line(
        picture,
        (cx - half, cy - half),
        (cx + half, cy + half),
        width,
        colour,
    );
    line(
        picture,
        (cx - half, cy + half),
        (cx + half, cy - half),
        width,
        colour,
    );
}

/// The sign's arrow inside its board, as the robot reads it (up: straight on).
fn arrow(picture: &mut RgbImage, cx: f64, cy: f64, word: &str) {
    let (dx, dy) = match word {
        "left" => (-1.0, 0.0),
        "right" => (1.0, 0.0),
        "down" => (0.0, 1.0),
        _ => (0.0, -1.0),
    };
    let tip = (cx + dx * 5.0, cy + dy * 5.0);
    line(picture, (cx - dx * 5.0, cy - dy * 5.0), tip, 1.5, BLACK);
    // The head: two strokes back from the tip, at right angles to each other.
    for side in [-1.0, 1.0] {
        let back = (
            tip.0 - dx * 3.0 + side * dy * 3.0,
            tip.1 - dy * 3.0 - side * dx * 3.0,
        );
        line(picture, tip, back, 1.5, BLACK);
    }
}
