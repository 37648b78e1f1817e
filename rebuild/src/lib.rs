//! A simulator world rebuilt from a real run's laser scans (`lewis world from`), and how
//! faithfully it makes those scans again (`lewis world check`).
//!
//! - [`run`]: a run's scans and recorded poses, from a Lewis recording, or a CARMEN log or
//!   a ROS 2 bag imported in memory by `lewis-formats`' importers.
//! - [`grid`]: the occupancy counts (seen occupied, seen free) and the static map drawn
//!   from them: what moved is left out.
//! - [`matcher`]: scan-to-map matching (correlative search, Gauss-Newton refinement).
//! - [`build`](mod@build): the run's scans placed and added, one by one.
//! - [`world_dir`]: the world folder in the simulator's format, with the trajectory, the
//!   cells left out and a picture.
//! - [`check`](mod@check): the scans made again by the simulator's ray caster, compared beam by beam;
//!   [`plots`] draws the result.
//!
//! It owns no format and no ray caster: files are read by `lewis-recording` and the
//! importers, worlds are loaded and ray cast by `lewis-sim`. It runs nothing live.

pub mod build;
pub mod check;
pub mod grid;
pub mod matcher;
pub mod plots;
pub mod run;
pub mod world_dir;

pub use build::{BuildError, BuildOptions, BuildReport, Built, Placed, build};
pub use check::{CheckError, CheckReport, ErrorMap, Figures, check};
pub use run::{PoseSource, Run, RunError, RunFormat, read_run};
