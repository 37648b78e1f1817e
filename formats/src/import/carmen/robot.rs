//! The robot description (`robots/*.toml` format) of an imported log: what "ran" to make
//! it, so that replay knows its providers, and what replay re-simulates over it.
//!
//! - **Sources** (`kind = "recorded"`, a kind no harness starts: replay feeds them from the
//!   log): the laser provides RangeFinder (quality 10), the base Egomotion and the logged
//!   robot's drive (Synchrodrive), and the derived sonar, when there is one, RangeFinder at
//!   a lower quality (5), as a hot standby since its readings are in the log from the start.
//! - **Services replay re-simulates**: `distance` (`range_distance`: Distance from whichever
//!   RangeFinder it is bound to; the import wrote its outputs as it would have published them
//!   live, so `lewis replay --check` compares against them), `obstacle_avoider` with a goal
//!   in its parameters, and the `vector_mover` it drives through.
//!
//! **Commands to the base.** The VectorMover commands `Synchrodrive.set_velocity`; on a log
//! there is no base to drive. Replay answers a call to a source that is not re-simulated
//! from the source's recorded command log, and, when it has none (an import has none), with
//! `ok` and the interface's default reply, counted in the report's `calls_defaulted`. The
//! robot still moves as it moved in the log: the avoider's and the mover's outputs say what
//! they *would have commanded* at each moment from the recorded readings and odometry.

use std::fmt::Write as _;
use std::path::Path;

use lewis_motion::service::{obstacle_avoider, vector_mover};
use lewis_perception::range_distance;

use super::import::{BASE, DISTANCE, ImportReport, LASER, OdometrySource, SONAR};

/// The name of the imported robot's ObstacleAvoider.
pub const AVOIDER: &str = "obstacle_avoider";
/// The name of the imported robot's VectorMover.
pub const MOVER: &str = "vector_mover";

/// The service kind of an imported source.
pub const RECORDED_KIND: &str = "recorded";

/// A TOML basic string holding `text`.
fn quoted(text: &str) -> String {
    toml::Value::String(text.to_owned()).to_string()
}

/// `carmen-` and the log's file name without `.gz` and `.log`, as an identifier.
#[must_use]
pub fn robot_name(path: &Path) -> String {
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = file.strip_suffix(".gz").unwrap_or(&file);
    let stem = stem.strip_suffix(".log").unwrap_or(stem);
    let name: String = format!("carmen-{stem}")
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .take(64)
        .collect();
    name
}

fn rate(rate_hz: Option<f64>) -> String {
    rate_hz.map_or_else(String::new, |r| format!(", data_rate_hz = {r:.3}"))
}

/// The robot description of an import, as TOML text.
#[must_use]
pub fn robot_toml(report: &ImportReport) -> String {
    let mut t = String::new();
    header(&mut t, report);
    sources(&mut t, report);
    resimulated(&mut t, report);
    t
}

fn header(t: &mut String, report: &ImportReport) {
    let file = report
        .path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Writing to a String cannot fail.
    let _ = writeln!(
        t,
        "# The robot that made the CARMEN log {file}, as `lewis import carmen` understood it.\n\
         # Its sources (kind \"{RECORDED_KIND}\") are fed from the recording by replay, never\n\
         # started. The other services are re-simulated over them by `lewis replay`; commands\n\
         # to the base are answered `ok` by replay (a log has no base to drive)."
    );
    if let Some(sonar) = &report.sonar {
        let _ = writeln!(
            t,
            "# The sonar is NOT a sensor of that robot: it is derived from the laser ({} transducers\n\
             # over the laser's field of view, each the nearest laser hit in a {:.1}-degree cone,\n\
             # {:.1} m, every {} scans), so that a laser failure can be replayed on this log.",
            sonar.transducers,
            (2.0 * sonar.cone_half_angle_rad).to_degrees(),
            sonar.max_range_m,
            sonar.every_nth_scan
        );
    }
    let period_ms = report.heartbeat_period_ns / 1_000_000;
    let _ = writeln!(
        t,
        "\n[robot]\nname = {}\ndescription = {}\n",
        quoted(&robot_name(&report.path)),
        quoted(&format!("Imported from the CARMEN log {file}")),
    );
    let _ = writeln!(
        t,
        "[broker]\nheartbeat_period_ms = {}\nheartbeat_deadline_ms = {}\nfail_back = false\n",
        period_ms.max(1),
        (5 * period_ms).max(1)
    );
    // The declared rates are the log's means; a logger's timing is irregular (gaps of a
    // second), and no broker judged it live: a replay must not fail its sensors on it.
    for interface in ["RangeFinder", "Egomotion"] {
        let _ = writeln!(
            t,
            "# The log's rate is a mean over an irregular logger: not checked.\n\
             [broker.interfaces.{interface}]\nchecks = {{ rate = 0.0 }}\n"
        );
    }
}

fn sources(t: &mut String, report: &ImportReport) {
    let laser = &report.laser;
    let beams = laser.beams();
    // beam counts are small
    let fov_deg = (laser.geometry.separation_rad * beams.saturating_sub(1) as f64).to_degrees();
    let scans: u64 = laser.beam_counts.values().sum();
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{LASER}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
         {{ interface = \"RangeFinder\", quality = 10, cost = 2{r} }},\n]\n",
        quoted(&format!(
            "Front laser of the log ({}): {scans} scans of {beams} beams over {fov_deg:.1} degrees, max range {} m",
            laser.source.line_type(),
            laser.max_range_m
        )),
        r = rate(laser.rate_hz),
    );
    let _ = writeln!(
        t,
        "[services.parameters]\norigin = \"carmen\"\nline_type = \"{}\"\nbeams = {beams}\n\
         field_of_view_deg = {fov_deg:.3}\nmax_range_m = {}\nmount_x_m = {}\nmount_y_m = {}\n\
         mount_heading_rad = {}\n",
        laser.source.line_type(),
        toml::Value::Float(laser.max_range_m),
        toml::Value::Float(laser.mount.x_m),
        toml::Value::Float(laser.mount.y_m),
        toml::Value::Float(laser.mount.heading_rad),
    );
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{BASE}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
         {{ interface = \"Egomotion\", quality = 10, cost = 1{} }},\n    \
         {{ interface = \"Synchrodrive\", quality = 10, cost = 1 }},\n]\n\n\
         [services.parameters]\norigin = \"carmen\"\nline_type = \"{}\"\n",
        quoted(&format!(
            "Odometry of the log ({}); its drive took commands live, none are in the log",
            match report.odometry {
                OdometrySource::OdomLines => "ODOM lines",
                OdometrySource::ScanPoses => "odometry poses of the scan lines",
            }
        )),
        rate(report.odometry_rate_hz),
        match report.odometry {
            OdometrySource::OdomLines => "ODOM",
            OdometrySource::ScanPoses => laser.source.line_type(),
        }
    );
    if let Some(sonar) = &report.sonar {
        let sonar_rate = laser
            .rate_hz
            .map(|r| r / f64::from(sonar.every_nth_scan.max(1)));
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{SONAR}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\n\
             start = \"standby\"\nprovides = [\n    \
             {{ interface = \"RangeFinder\", quality = 5, cost = 1{r} }},\n]\n\n\
             [services.parameters]\norigin = \"derived from the laser\"\ntransducers = {}\n\
             cone_half_angle_rad = {}\nmax_range_m = {}\nevery_nth_scan = {}\n",
            quoted(
                "Sonar-like fallback DERIVED from the laser (not a real sensor), at a lower resolution"
            ),
            sonar.transducers,
            toml::Value::Float(sonar.cone_half_angle_rad),
            toml::Value::Float(sonar.max_range_m.min(laser.max_range_m)),
            sonar.every_nth_scan,
            r = rate(sonar_rate),
        );
    }
}

fn resimulated(t: &mut String, report: &ImportReport) {
    let [from_deg, to_deg] = report.distance_span_deg;
    let _ = writeln!(
        t,
        "# Re-simulated by `lewis replay` over the sources above.\n\n\
         [[services]]\nname = \"{DISTANCE}\"\ndescription = {}\nkind = \"{}\"\nstart = \"always\"\n\
         requires = [\"RangeFinder\"]\nprovides = [{{ interface = \"Distance\", quality = 10, cost = 1 }}]\n\n\
         [services.parameters]\nsector_count = {}\nspan_deg = [{}, {}]\n",
        quoted(
            "Distance from the RangeFinder it is bound to (the laser; the sonar after a failover), over the laser's field of view"
        ),
        range_distance::KIND,
        report.distance_sectors,
        toml::Value::Float(from_deg),
        toml::Value::Float(to_deg),
    );
    let (x, y) = report.goal;
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{AVOIDER}\"\ndescription = {}\nkind = \"{}\"\nstart = \"always\"\n\
         requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]\n\
         provides = [{{ interface = \"Mover\", quality = 10, cost = 2 }}]\n\n\
         # The logged robot does not obey the avoider: its progress is the log's, so the goal is\n\
         # not given up for lack of progress within the log.\n\
         [services.parameters]\ngoal = {{ x_m = {}, y_m = {} }}\nno_progress_timeout_ms = 3600000\n",
        quoted(
            "ObstacleAvoider to the goal of its parameters (by default the odometry pose farthest from the start), through the VectorMover"
        ),
        obstacle_avoider::KIND,
        toml::Value::Float(x),
        toml::Value::Float(y),
    );
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{MOVER}\"\ndescription = {}\nkind = \"{}\"\n\
         requires = [\"Egomotion\", \"Synchrodrive\"]\n\
         provides = [{{ interface = \"Mover\", quality = 5, cost = 1 }}]",
        quoted("VectorMover: the avoider's waypoints as velocities for the logged robot's drive"),
        vector_mover::KIND,
    );
}
