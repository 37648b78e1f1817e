//! The robot description of an imported bag: its sources (`kind = "recorded"`, fed from
//! the recording by replay, never started) and the services replay can re-simulate over
//! what was found: `distance` (Distance) with a laser; `obstacle_avoider` and the
//! `vector_mover` it drives through with a laser and odometry. A bag without odometry gets
//! no avoider (it plans on the pose), a bag without a laser no Distance or avoider: the
//! report says so. Commands to the base are answered `ok` by replay, as for a CARMEN log.

use std::fmt::Write as _;
use std::path::Path;

use lewis_motion::service::{obstacle_avoider, vector_mover};
use lewis_perception::{blobfinder, range_distance};

use super::import::{
    BASE, BLOBFINDER, CAMERA, DISTANCE, ImportReport, LASER, LaserStats, SECOND_LASER, SONAR,
};
use super::topics::Role;
use crate::import::carmen::robot::{AVOIDER, MOVER, RECORDED_KIND};

fn quoted(text: &str) -> String {
    toml::Value::String(text.to_owned()).to_string()
}

fn float(x: f64) -> String {
    toml::Value::Float(x).to_string()
}

/// `ros2-` and the bag's file name without `.mcap`, as an identifier.
#[must_use]
pub fn robot_name(path: &Path) -> String {
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = file.strip_suffix(".mcap").unwrap_or(&file);
    format!("ros2-{stem}")
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .take(64)
        .collect()
}

fn rate(rate_hz: Option<f64>) -> String {
    rate_hz.map_or_else(String::new, |r| format!(", data_rate_hz = {r:.3}"))
}

/// Whether the import re-simulates the avoider (a laser and odometry).
#[must_use]
pub fn has_avoider(report: &ImportReport) -> bool {
    report.laser.is_some() && report.odometry.is_some()
}

/// The robot description of an import, as TOML text.
#[must_use]
pub fn robot_toml(report: &ImportReport) -> String {
    let mut t = String::new();
    let file = report
        .path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let _ = writeln!(
        t,
        "# The robot that made the ROS 2 bag {file}, as `lewis import ros2` understood it.\n\
         # Its sources (kind \"{RECORDED_KIND}\") are fed from the recording by replay, never\n\
         # started. The other services are re-simulated over them by `lewis replay`."
    );
    if report.sonar.is_some() {
        let _ = writeln!(
            t,
            "# The sonar is NOT a sensor of that robot: it is derived from the laser, so that a\n\
             # laser failure can be replayed on this bag."
        );
    }
    let period_ms = report.heartbeat_period_ns / 1_000_000;
    let _ = writeln!(
        t,
        "\n[robot]\nname = {}\ndescription = {}\n\n\
         [broker]\nheartbeat_period_ms = {}\nheartbeat_deadline_ms = {}\nfail_back = false\n",
        quoted(&robot_name(&report.path)),
        quoted(&format!("Imported from the ROS 2 bag {file}")),
        period_ms.max(1),
        (5 * period_ms).max(1)
    );
    for interface in ["RangeFinder", "Egomotion", "ImageSource"] {
        let _ = writeln!(
            t,
            "# The rate is the bag's mean, as a recorder received it: not checked.\n\
             [broker.interfaces.{interface}]\nchecks = {{ rate = 0.0 }}\n"
        );
    }
    if let Some(laser) = &report.laser {
        range_source(&mut t, LASER, laser, 10, None, "Laser");
    }
    if let Some(laser) = &report.second_laser {
        range_source(
            &mut t,
            SECOND_LASER,
            laser,
            5,
            Some("standby"),
            "Second range sensor",
        );
    }
    if let (Some(sonar), Some(laser)) = (&report.sonar, &report.laser) {
        let sonar_rate = laser
            .rate_hz
            .map(|r| r / f64::from(sonar.every_nth_scan.max(1)));
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{SONAR}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\n\
             start = \"standby\"\nprovides = [\n    \
             {{ interface = \"RangeFinder\", quality = 5, cost = 1{} }},\n]\n\n\
             [services.parameters]\norigin = \"derived from the laser\"\ntransducers = {}\n\
             cone_half_angle_rad = {}\nmax_range_m = {}\nevery_nth_scan = {}\n",
            quoted(
                "Sonar-like fallback DERIVED from the laser (not a real sensor), at a lower resolution"
            ),
            rate(sonar_rate),
            sonar.transducers,
            float(sonar.cone_half_angle_rad),
            float(sonar.max_range_m.min(laser.max_range_m)),
            sonar.every_nth_scan,
        );
    }
    if let Some(odometry) = &report.odometry {
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{BASE}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
             {{ interface = \"Egomotion\", quality = 10, cost = 1{} }},\n    \
             {{ interface = \"Synchrodrive\", quality = 10, cost = 1 }},\n]\n\n\
             [services.parameters]\norigin = \"ros2\"\ntopic = {}\n",
            quoted(&format!(
                "Odometry of the bag ({}, {}); its drive took commands live, none are in the bag",
                odometry.topic,
                if odometry.role == Role::Tf {
                    "odom to base transforms"
                } else {
                    "nav_msgs/Odometry"
                }
            )),
            rate(odometry.rate_hz),
            quoted(&odometry.topic),
        );
    }
    if let Some(image) = &report.image {
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{CAMERA}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
             {{ interface = \"ImageSource\", quality = 10, cost = 1{} }},\n]\n\n\
             [services.parameters]\norigin = \"ros2\"\ntopic = {}\n",
            quoted(&format!("Camera of the bag ({}), as rgb8", image.topic)),
            rate(image.rate_hz),
            quoted(&image.topic),
        );
    }
    if report.laser.is_some() {
        let [from_deg, to_deg] = report.distance_span_deg;
        let _ = writeln!(
            t,
            "# Re-simulated by `lewis replay` over the sources above.\n\n\
             [[services]]\nname = \"{DISTANCE}\"\ndescription = {}\nkind = \"{}\"\nstart = \"always\"\n\
             requires = [\"RangeFinder\"]\nprovides = [{{ interface = \"Distance\", quality = 10, cost = 1 }}]\n\n\
             [services.parameters]\nsector_count = {}\nspan_deg = [{}, {}]\n",
            quoted("Distance from the RangeFinder it is bound to, over the laser's field of view"),
            range_distance::KIND,
            report.distance_sectors,
            float(from_deg),
            float(to_deg),
        );
    }
    if let (Some(colors), Some(image)) = (&report.colors, &report.image) {
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{BLOBFINDER}\"\ndescription = {}\nkind = \"{}\"\nstart = \"always\"\n\
             requires = [\"ImageSource\"]\nprovides = [{{ interface = \"Blobs\", quality = 10, cost = 3 }}]\n\n\
             [services.parameters]\ncolors = {}\nmax_blobs_per_color = {}\n",
            quoted(&format!(
                "CMVision BlobFinder over the bag's camera ({})",
                image.topic
            )),
            blobfinder::KIND,
            quoted(&colors.to_string_lossy()),
            blobfinder::DEFAULT_MAX_BLOBS_PER_COLOR,
        );
    }
    if has_avoider(report) {
        let (x, y) = report.goal;
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{AVOIDER}\"\ndescription = {}\nkind = \"{}\"\nstart = \"always\"\n\
             requires = [\"RangeFinder\", \"Egomotion\", \"Mover\"]\n\
             provides = [{{ interface = \"Mover\", quality = 10, cost = 2 }}]\n\n\
             # The recorded robot does not obey the avoider: the goal is not given up for lack\n\
             # of progress within the bag.\n\
             [services.parameters]\ngoal = {{ x_m = {}, y_m = {} }}\nno_progress_timeout_ms = 3600000\n",
            quoted(
                "ObstacleAvoider to the goal of its parameters (by default the odometry pose farthest from the start), through the VectorMover"
            ),
            obstacle_avoider::KIND,
            float(x),
            float(y),
        );
        let _ = writeln!(
            t,
            "[[services]]\nname = \"{MOVER}\"\ndescription = {}\nkind = \"{}\"\n\
             requires = [\"Egomotion\", \"Synchrodrive\"]\n\
             provides = [{{ interface = \"Mover\", quality = 5, cost = 1 }}]",
            quoted(
                "VectorMover: the avoider's waypoints as velocities for the recorded robot's drive"
            ),
            vector_mover::KIND,
        );
    }
    t
}

fn range_source(
    t: &mut String,
    name: &str,
    laser: &LaserStats,
    quality: u32,
    start: Option<&str>,
    what: &str,
) {
    // A fallback waits in standby; the laser starts as the broker decides, as a CARMEN
    // import's does.
    let start = start.map_or_else(String::new, |s| format!("start = \"{s}\"\n"));
    let fov_deg = (laser.angle_increment_rad * laser.beams.saturating_sub(1) as f64)
        .abs()
        .to_degrees();
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{name}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\n{start}provides = [\n    \
         {{ interface = \"RangeFinder\", quality = {quality}, cost = 2{} }},\n]\n\n\
         [services.parameters]\norigin = \"ros2\"\ntopic = {}\nbeams = {}\nfield_of_view_deg = {fov_deg:.3}\nmax_range_m = {}\n",
        quoted(&format!(
            "{what} of the bag ({}): {} scans of {} beams over {fov_deg:.1} degrees, max range {} m",
            laser.topic, laser.scans, laser.beams, laser.max_range_m
        )),
        rate(laser.rate_hz),
        quoted(&laser.topic),
        laser.beams,
        float(laser.max_range_m),
    );
}
