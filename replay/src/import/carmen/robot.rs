//! The robot description (`robots/*.toml` format) of an imported log: what "ran" to make
//! it, so that replay knows its providers.
//!
//! Every service is a source whose publications are in the recording: `kind = "recorded"`,
//! a kind no harness starts (replay feeds them from the log). The laser provides
//! RangeFinder and Distance (quality 10), the base Egomotion, and the derived sonar, when
//! there is one, RangeFinder and Distance at a lower quality (5), as a hot standby since
//! its readings are in the log from the start.

use std::fmt::Write as _;
use std::path::Path;

use super::import::{BASE, ImportReport, LASER, SONAR};

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
    let laser = &report.laser;
    let file = report
        .path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let beams = laser.beams();
    #[allow(clippy::cast_precision_loss)] // beam counts are small
    let fov_deg = (laser.geometry.separation_rad * beams.saturating_sub(1) as f64).to_degrees();
    let scans: u64 = laser.beam_counts.values().sum();
    let mut t = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(
        t,
        "# The robot that made the CARMEN log {file}, as `lewis import carmen` understood it.\n\
         # Its services are sources (kind \"{RECORDED_KIND}\"): replay feeds their publications\n\
         # from the recording and never starts them."
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
    let _ = writeln!(
        t,
        "\n[robot]\nname = {}\ndescription = {}\n",
        quoted(&robot_name(&report.path)),
        quoted(&format!("Imported from the CARMEN log {file}")),
    );
    let _ = writeln!(
        t,
        "[broker]\nheartbeat_period_ms = 100\nheartbeat_deadline_ms = 500\nfail_back = false\n"
    );
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{LASER}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
         {{ interface = \"RangeFinder\", quality = 10, cost = 2{r} }},\n    \
         {{ interface = \"Distance\", quality = 10, cost = 2{r} }},\n]\n",
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
         mount_heading_rad = {}\ndistance_sectors = {}\n",
        laser.source.line_type(),
        toml::Value::Float(laser.max_range_m),
        toml::Value::Float(laser.mount.x_m),
        toml::Value::Float(laser.mount.y_m),
        toml::Value::Float(laser.mount.heading_rad),
        report.distance_sectors,
    );
    let _ = writeln!(
        t,
        "[[services]]\nname = \"{BASE}\"\ndescription = {}\nkind = \"{RECORDED_KIND}\"\nprovides = [\n    \
         {{ interface = \"Egomotion\", quality = 10, cost = 1{} }},\n]\n\n\
         [services.parameters]\norigin = \"carmen\"\nline_type = \"{}\"\n",
        quoted(&format!(
            "Odometry of the log ({})",
            match report.odometry {
                super::import::OdometrySource::OdomLines => "ODOM lines",
                super::import::OdometrySource::ScanPoses => "odometry poses of the scan lines",
            }
        )),
        rate(report.odometry_rate_hz),
        match report.odometry {
            super::import::OdometrySource::OdomLines => "ODOM",
            super::import::OdometrySource::ScanPoses => laser.source.line_type(),
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
             {{ interface = \"RangeFinder\", quality = 5, cost = 1{r} }},\n    \
             {{ interface = \"Distance\", quality = 5, cost = 1{r} }},\n]\n\n\
             [services.parameters]\norigin = \"derived from the laser\"\ntransducers = {}\n\
             cone_half_angle_rad = {}\nmax_range_m = {}\nevery_nth_scan = {}\ndistance_sectors = {}",
            quoted("Sonar-like fallback DERIVED from the laser (not a real sensor)"),
            sonar.transducers,
            toml::Value::Float(sonar.cone_half_angle_rad),
            toml::Value::Float(sonar.max_range_m.min(laser.max_range_m)),
            sonar.every_nth_scan,
            report.distance_sectors,
            r = rate(sonar_rate),
        );
    }
    t
}
