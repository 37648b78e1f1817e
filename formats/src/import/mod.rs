//! Importers: logs of other robot software turned into Lewis messages, with times, and
//! written as a Lewis recording that replay can run services over.
//!
//! - [`carmen`]: CARMEN logs (the Radish data sets) as a stream of messages and a robot.
//! - [`ros2`]: ROS 2 bags (rosbag2 MCAP files) as messages, the bag's own kept, and a robot.
//! - [`record`]: an import written through the recorder (`lewis import carmen`, `lewis import ros2`).

pub mod carmen;
pub mod record;
pub mod ros2;

use lewis_interfaces::msg::RangeFinder;
use lewis_perception::range_distance;

/// Checks the options every importer shares: the heartbeat period the import makes up, the
/// mission's goal, and the Distance sectors computed from the laser. The error is the
/// sentence to show.
fn check_shared_options(
    heartbeat_period_ns: i64,
    goal: Option<(f64, f64)>,
    distance_sectors: usize,
) -> Result<(), String> {
    if heartbeat_period_ns <= 0 {
        return Err(format!(
            "a heartbeat period of {heartbeat_period_ns} ns: give a positive period"
        ));
    }
    if let Some((x, y)) = goal
        && !(x.is_finite() && y.is_finite())
    {
        return Err(format!(
            "the goal ({x}, {y}) is not a point: give finite coordinates in m"
        ));
    }
    if !range_distance::SECTOR_COUNTS.contains(&distance_sectors) {
        return Err(format!(
            "{distance_sectors} Distance sectors: give {} to {}",
            range_distance::SECTOR_COUNTS.start(),
            range_distance::SECTOR_COUNTS.end()
        ));
    }
    Ok(())
}

/// The span a laser's Distance covers, in degrees rounded to a micro-degree (written into
/// the robot file), or all around when the scan wraps.
fn span_deg(scan: &RangeFinder) -> [f64; 2] {
    let span = carmen::laser::field_of_view(scan);
    let round = |rad: f64| (rad.to_degrees() * 1e6).round() / 1e6;
    let (from, to) = (round(span.from_rad), round(span.to_rad));
    if from < to {
        [from, to]
    } else {
        [-180.0, 180.0]
    }
}
