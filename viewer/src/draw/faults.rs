//! The faults a replay injected (`/replay/lewis/faults`, `LogLine`s whose stream is
//! `fault`, one when a fault starts and one when it ends): a text log
//! `events/replay/faults`, a state lane per faulty provider `status/replay/faults/<service>`
//! (a marker on the timeline), and a red mark in the world where the robot was when each
//! fault began (`world/replay/faults`).

use lewis_interfaces::msg::{LogLine, Pose2D};
use rerun::{Color, Points2D, TextLog};

use super::lanes::NO_FAULT;
use super::{Point, Side};
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// The channel where `lewis replay` writes the faults it injects.
pub(crate) const FAULTS_TOPIC: &str = "/replay/lewis/faults";

/// How the replay's fault lines begin (`replay/src/resim.rs`).
const STARTS: &str = "fault injected: ";
const ENDS: &str = "fault ends: ";

/// The marks placed so far: every fault stays marked once it has begun.
#[derive(Debug, Default)]
pub(super) struct FaultMarks {
    marks: Vec<([f32; 2], String)>,
}

impl FaultMarks {
    /// Draws one fault line; `world_pose` is where the robot was.
    pub(super) fn fault(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        stamp: Stamp,
        line: &LogLine,
        world_pose: Option<&Pose2D>,
    ) -> Result<(), ViewError> {
        let service = if line.service.is_empty() {
            "unknown"
        } else {
            line.service.as_str()
        };
        let starts = !line.text.starts_with(ENDS);
        rows.log(
            sink,
            &Side::Replayed.entity("events", &["faults"]),
            stamp,
            &TextLog::new(line.text.clone()).with_level(if starts { "ERROR" } else { "INFO" }),
            line.text.len() + 32,
        )?;
        let lane = if starts {
            format!("fault: {}", kind(&line.text, service))
        } else {
            NO_FAULT.to_owned()
        };
        rows.lane(
            sink,
            &Side::Replayed.entity("status", &["faults", service]),
            stamp,
            &lane,
        )?;
        let Some(pose) = world_pose.filter(|_| starts) else {
            return Ok(());
        };
        let at = Point::new(pose.x, pose.y);
        if !at.is_finite() {
            return Ok(());
        }
        self.marks.push((
            at.to_f32(),
            format!("{service} {}", kind(&line.text, service)),
        ));
        let bytes = self.marks.len() * 48;
        rows.log(
            sink,
            &Side::Replayed.entity("world", &["faults"]),
            stamp,
            &Points2D::new(self.marks.iter().map(|m| m.0))
                .with_labels(self.marks.iter().map(|m| m.1.clone()))
                .with_colors([Color::from_rgb(255, 30, 30)])
                .with_radii([0.3_f32]),
            bytes,
        )
    }
}

/// The fault's kind from `fault injected: laser stall (laser@12.5s:stall)`: `stall`.
fn kind<'t>(text: &'t str, service: &str) -> &'t str {
    text.strip_prefix(STARTS)
        .and_then(|rest| rest.strip_prefix(service))
        .map(str::trim_start)
        .and_then(|rest| rest.split(" (").next())
        .filter(|kind| !kind.is_empty())
        .unwrap_or("fault")
}
