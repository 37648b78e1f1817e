//! CARMEN logs (`lewis import carmen LOG[.gz]`): the real laser and odometry logs of the
//! Radish data sets, as a stream of Lewis messages with times and the robot description
//! that says what made them.
//!
//! - [`reader`] reads the log line by line (plain or gzip, told apart by its magic bytes);
//!   [`parse`] turns a line into a typed record. Malformed lines are reported with their
//!   file and line, counted and skipped.
//! - [`timing`] is the time policy: real logs have broken clocks, and the import says what it
//!   did about them and never produces time that goes backwards.
//! - [`laser`] turns scans into RangeFinder readings (the "no return" codes become
//!   `max_range`), and derives the sonar-like fallback provider `sonar`, which the logged
//!   robot did not have, so that a laser failure can be replayed on a real log.
//! - [`import`] runs the two passes: [`CarmenImport::open`] reads and re-times, then
//!   [`CarmenImport::messages`] streams [`ImportedMessage`]s: `/laser/RangeFinder` and
//!   `/distance/Distance` (what the robot's `range_distance` service makes of it) per scan,
//!   `/base/Egomotion` per `ODOM` line (or per scan when the log has none),
//!   `/sonar/RangeFinder` every few scans, and the sources' heartbeats on
//!   `/lewis/health/<source>` at the broker's period.
//! - [`robot`] writes the robot description of the import ([`robot_toml`]): the sources,
//!   and the services replay re-simulates over them (Distance, ObstacleAvoider with a goal,
//!   VectorMover).
//!
//! Writing MCAP is the recorder's job: this module knows nothing of files it writes.

pub mod import;
pub mod laser;
pub mod parse;
pub mod reader;
pub mod robot;
pub mod timing;

pub use import::{
    BASE, CarmenImport, DISTANCE, ImportError, ImportOptions, ImportReport, ImportedMessage, LASER,
    LaserSource, LaserSummary, Messages, OdometrySource, Payload, SONAR,
};
pub use laser::{ReadingCounts, SonarOptions};
pub use reader::{LineError, LogReader, ParseCounts, ReadError};
pub use robot::robot_toml;
pub use timing::{
    PeriodSource, StampProblem, StreamTiming, TimePolicy, TimingError, TimingOptions, TimingReport,
};
