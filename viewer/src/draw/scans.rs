//! The robot, its scans and what it perceives, in the robot frame and in the world.

use lewis_interfaces::msg::{Blobs3D, Mover, Pose2D, RangeFinder, Signs};
use rerun::{Arrows2D, Color, EntityPath, LineStrips2D, Points2D};

use super::{Point, Side, entity, recorded_topic, topic_entity, topic_parts};
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// Radius of the drawn robot outline (a B21r is about 0.53 m across).
const ROBOT_RADIUS_M: f64 = 0.26;
/// Scans with at most this many beams (sonar rings) are drawn with their rays too.
const MAX_BEAMS_WITH_RAYS: usize = 64;
const HIT_RADIUS_M: f32 = 0.03;

/// The robot's outline and heading in the robot frame, for all times.
pub(super) fn log_robot_body(rows: &mut Rows, sink: &mut dyn ChunkSink) -> Result<(), ViewError> {
    let outline: Vec<[f32; 2]> = (0..=48)
        .map(|i| {
            let angle = f64::from(i) * std::f64::consts::TAU / 48.0;
            Point::new(0.0, 0.0).along(angle, ROBOT_RADIUS_M).to_f32()
        })
        .collect();
    rows.log_static(
        sink,
        &entity(["robot", "body"]),
        &LineStrips2D::new([
            outline,
            vec![[0.0, 0.0], Point::new(ROBOT_RADIUS_M, 0.0).to_f32()],
        ])
        .with_colors([Color::from_rgb(90, 90, 90)])
        .with_radii([0.01_f32]),
    )
}

/// A pose as an arrow along the heading.
pub(super) fn log_pose(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    path: &EntityPath,
    stamp: Stamp,
    pose: &Pose2D,
    truth: bool,
) -> Result<(), ViewError> {
    let origin = Point::new(pose.x, pose.y);
    if !origin.is_finite() || !pose.theta.is_finite() {
        return Ok(());
    }
    let tip = origin.along(pose.theta, 2.0 * ROBOT_RADIUS_M);
    let colour = if truth {
        Color::from_rgb(40, 170, 60)
    } else {
        Color::from_rgb(150, 150, 150)
    };
    let arrow = Arrows2D::from_vectors([[(tip.x - origin.x) as f32, (tip.y - origin.y) as f32]])
        .with_origins([origin.to_f32()])
        .with_colors([colour])
        .with_radii([0.03_f32]);
    rows.log(sink, path, stamp, &arrow, 64)
}

/// One beam: where it starts and where it hit, in the robot frame.
struct Beam {
    origin: Point,
    hit: Point,
}

/// The beams of a scan that hit something (a range at or beyond `max_range`, not positive
/// or not finite is no return). Uniform scans place beam `i` at offset + i * separation;
/// others take it from `sensor_positions[i]`.
fn beams(scan: &RangeFinder) -> Vec<Beam> {
    let usable = |range: f64| {
        range.is_finite() && range > 0.0 && !(scan.max_range > 0.0 && range >= scan.max_range)
    };
    scan.ranges
        .iter()
        .enumerate()
        .filter(|(_, range)| usable(**range))
        .filter_map(|(i, &range)| {
            let (origin, bearing) = if scan.uniform {
                let k = i as f64;
                (
                    Point::new(
                        scan.x_offset + k * scan.x_separation,
                        scan.y_offset + k * scan.y_separation,
                    ),
                    scan.theta_offset + k * scan.theta_separation,
                )
            } else {
                let pose = scan.sensor_positions.get(i)?;
                (Point::new(pose.x, pose.y), pose.theta)
            };
            let hit = origin.along(bearing, range);
            hit.is_finite().then_some(Beam { origin, hit })
        })
        .collect()
}

/// A scan's hits in the robot frame, and in the world when a pose is known.
pub(super) fn log_scan(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    topic: &str,
    stamp: Stamp,
    scan: &RangeFinder,
    colour: Color,
    world_pose: Option<&Pose2D>,
) -> Result<(), ViewError> {
    let beams = beams(scan);
    let with_rays = scan.ranges.len() <= MAX_BEAMS_WITH_RAYS;
    let frames: [(&str, Option<Pose2D>); 2] = [
        ("robot", Some(Pose2D::default())),
        ("world", world_pose.cloned()),
    ];
    for (frame, pose) in frames {
        let Some(pose) = pose else { continue };
        let hits: Vec<[f32; 2]> = beams.iter().map(|b| b.hit.placed(&pose).to_f32()).collect();
        let bytes = hits.len() * 8;
        rows.log(
            sink,
            &topic_entity(&[frame, "scans"], topic, &[]),
            stamp,
            &Points2D::new(hits)
                .with_colors([colour])
                .with_radii([HIT_RADIUS_M]),
            bytes,
        )?;
        if with_rays {
            let rays: Vec<Vec<[f32; 2]>> = beams
                .iter()
                .map(|b| {
                    vec![
                        b.origin.placed(&pose).to_f32(),
                        b.hit.placed(&pose).to_f32(),
                    ]
                })
                .collect();
            let bytes = rays.len() * 16;
            rows.log(
                sink,
                &topic_entity(&[frame, "scans"], topic, &["rays"]),
                stamp,
                &LineStrips2D::new(rays)
                    .with_colors([colour])
                    .with_radii([0.005_f32]),
                bytes,
            )?;
        }
    }
    Ok(())
}

/// Blobs with a range, placed in the world.
pub(super) fn log_blobs3d_in_world(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    topic: &str,
    stamp: Stamp,
    blobs: &Blobs3D,
    world_pose: Option<&Pose2D>,
) -> Result<(), ViewError> {
    let Some(pose) = world_pose else {
        return Ok(());
    };
    let placed: Vec<_> = blobs
        .blobs
        .iter()
        .filter(|b| b.range_valid)
        .map(|b| {
            let point = Point::new(b.position.x, b.position.y).placed(pose);
            (
                point.to_f32(),
                rgb(b.blob.colour_rgb),
                b.blob.colour_name.clone(),
            )
        })
        .collect();
    let bytes = placed.len() * 32;
    rows.log(
        sink,
        &topic_entity(&["world", "blobs3d"], topic, &[]),
        stamp,
        &Points2D::new(placed.iter().map(|p| p.0))
            .with_colors(placed.iter().map(|p| p.1))
            .with_labels(placed.iter().map(|p| p.2.clone()))
            .with_radii([0.08_f32]),
        bytes,
    )
}

/// Signs, placed in the world, labelled with their arrow.
pub(super) fn log_signs_in_world(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    topic: &str,
    stamp: Stamp,
    signs: &Signs,
    world_pose: Option<&Pose2D>,
) -> Result<(), ViewError> {
    let Some(pose) = world_pose else {
        return Ok(());
    };
    let placed: Vec<[f32; 2]> = signs
        .signs
        .iter()
        .map(|s| Point::new(s.position.x, s.position.y).placed(pose).to_f32())
        .collect();
    let bytes = placed.len() * 32;
    rows.log(
        sink,
        &topic_entity(&["world", "signs"], topic, &[]),
        stamp,
        &Points2D::new(placed)
            .with_labels(signs.signs.iter().map(|s| s.arrow.clone()))
            .with_colors([Color::from_rgb(250, 250, 250)])
            .with_radii([0.1_f32]),
        bytes,
    )
}

/// The Mover's goal and the waypoint it heads for, in the odometry frame.
pub(super) fn log_mover(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    side: Side,
    topic: &str,
    stamp: Stamp,
    mover: &Mover,
) -> Result<(), ViewError> {
    let provider = topic_parts(recorded_topic(topic))
        .next()
        .unwrap_or_default();
    let goal = if mover.goal_id == 0 {
        Vec::new()
    } else {
        vec![Point::new(mover.goal.x, mover.goal.y).to_f32()]
    };
    rows.log(
        sink,
        &mover_entity(side, provider, "goal"),
        stamp,
        &Points2D::new(goal)
            .with_colors([Color::from_rgb(220, 0, 120)])
            .with_radii([0.12_f32])
            .with_labels([format!("goal {} ({})", mover.goal_id, mover.status)]),
        32,
    )?;
    let waypoint = if mover.goal_id == 0 {
        Vec::new()
    } else {
        vec![Point::new(mover.waypoint.x, mover.waypoint.y).to_f32()]
    };
    rows.log(
        sink,
        &mover_entity(side, provider, "waypoint"),
        stamp,
        &Points2D::new(waypoint)
            .with_colors([Color::from_rgb(250, 140, 200)])
            .with_radii([0.06_f32]),
        32,
    )
}

/// Where the Mover's `what` is drawn: in the odometry frame, where its goals are given, one
/// entity per provider (the avoider's goal and the VectorMover's waypoints it sets are
/// different things, published at different times).
fn mover_entity(side: Side, provider: &str, what: &str) -> EntityPath {
    match side {
        Side::Recorded => entity(["world", "odometry", "mover", provider, what]),
        Side::Replayed => entity([
            "world",
            "odometry",
            super::REPLAY_BRANCH,
            "mover",
            provider,
            what,
        ]),
    }
}

/// A `0xRRGGBB` colour.
pub(super) fn rgb(colour: u32) -> Color {
    let [_, r, g, b] = colour.to_be_bytes();
    Color::from_rgb(r, g, b)
}
