//! The world built from a run: each scan matched against the map built so far from a guess
//! (the recorded pose's motion since the last scan, or the last motion when the run has no
//! poses), then added to the map at the pose found.

use std::path::PathBuf;

use lewis_geometry::{Pose2, wrap_angle};

use crate::grid::{Grid, OccupancyRule};
use crate::matcher::{MatchOptions, match_scan, thin};
use crate::run::{PoseSource, Run};

/// How to build.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuildOptions {
    /// The side of a cell (a pixel of the map), in m.
    pub metres_per_cell: f64,
    /// Build from every other scan only (scans 0, 2, 4, ...), so that `check` can measure
    /// the world on scans it was not built from.
    pub hold_out: bool,
    /// When a cell is a wall.
    pub rule: OccupancyRule,
    /// Match scans against the map (else the recorded poses are taken as they are).
    pub match_scans: bool,
}

impl Default for BuildOptions {
    /// 5 cm cells, every scan.
    fn default() -> Self {
        Self {
            metres_per_cell: 0.05,
            hold_out: false,
            rule: OccupancyRule::default(),
            match_scans: true,
        }
    }
}

/// Where one scan was taken, as the world says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placed {
    /// The scan's index in the run.
    pub index: usize,
    /// Its time, in ns.
    pub time_ns: i64,
    /// The recorded pose, if the run has one.
    pub recorded: Option<Pose2>,
    /// The pose in the world.
    pub pose: Pose2,
    /// Whether the matcher placed it (else it is at its guess).
    pub matched: bool,
    /// Whether it went into the map.
    pub used: bool,
    /// The matcher's change to the guess, in m and rad.
    pub correction: (f64, f64),
}

/// What building found.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildReport {
    /// Where the poses came from.
    pub poses: PoseSource,
    /// Scans in the run.
    pub scans: usize,
    /// Scans in the map.
    pub used: usize,
    /// Scans the matcher placed (of those after the first).
    pub matched: usize,
    /// Median and largest correction of a step, in m.
    pub step_correction_m: (f64, f64),
    /// Median and largest correction of a step, in rad.
    pub step_correction_rad: (f64, f64),
    /// Largest distance between a placed pose and its recorded pose, in m (the
    /// recorded trajectory's drift as the map sees it), when the run has poses.
    pub drift_m: Option<f64>,
    /// Wall cells in the map.
    pub occupied_cells: u64,
    /// Cells seen occupied but mostly free (things that moved), left out.
    pub left_out_cells: u64,
    /// The grid's bytes at the end.
    pub grid_bytes: usize,
}

/// A world built: the grid and where each scan was taken.
#[derive(Debug, Clone)]
pub struct Built {
    /// The counts grid.
    pub grid: Grid,
    /// Every scan's place, in order.
    pub placed: Vec<Placed>,
    /// What was found.
    pub report: BuildReport,
}

/// Why no world was built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The scans did not match and the poses cannot be trusted alone.
    #[error(
        "{}: only {matched} of {tried} scans matched the map built so far, and {why}: a map from these poses would be wrong, so none is written",
        path.display()
    )]
    NoMatches {
        /// The run.
        path: PathBuf,
        /// Scans matched.
        matched: usize,
        /// Scans tried.
        tried: usize,
        /// Why the poses cannot be trusted alone.
        why: String,
    },
    /// The options cannot work.
    #[error("a cell size of {0} m: give a positive size of at least 1 cm")]
    CellSize(f64),
    /// The map would not fit in memory.
    #[error(
        "{}: at scan {index}, {source}: the poses are far off, or give a larger --metres-per-pixel",
        path.display()
    )]
    TooBig {
        /// The run.
        path: PathBuf,
        /// The scan that would not fit.
        index: usize,
        /// How big the map would be.
        source: crate::grid::TooBig,
    },
}

/// The fewest share of matched scans a run without trusted poses needs.
const MIN_MATCHED_SHARE: f64 = 0.5;

/// The pose `b` seen from `a` (`a` composed with it gives `b`).
#[must_use]
pub fn between(a: Pose2, b: Pose2) -> Pose2 {
    let d = (b.position() - a.position()).rotated(-a.heading_rad);
    Pose2::new(d.x, d.y, wrap_angle(b.heading_rad - a.heading_rad))
}

/// Builds the world of `run`; `progress` is told the scans done.
///
/// # Errors
/// When the options cannot work, or too few scans match and the run's poses cannot be
/// trusted alone.
pub fn build(
    run: &Run,
    options: &BuildOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<Built, BuildError> {
    if !(options.metres_per_cell.is_finite() && options.metres_per_cell >= 0.01) {
        return Err(BuildError::CellSize(options.metres_per_cell));
    }
    let mut grid = Grid::new(options.metres_per_cell, options.rule);
    let match_options = match run.poses {
        PoseSource::None => MatchOptions::without_odometry(),
        _ => MatchOptions::with_odometry(),
    };
    let mut placed: Vec<Placed> = Vec::with_capacity(run.scans.len());
    // The last scan placed, and the one before: the guess's reference.
    let mut last: Option<(Pose2, i64)> = None;
    let mut before_last: Option<(Pose2, i64)> = None;
    // The last scan with a recorded pose: where it was placed, and its recorded pose.
    let mut anchor: Option<(Pose2, Pose2)> = None;
    let mut inserted = 0_usize;
    for (index, scan) in run.scans.iter().enumerate() {
        let used = !options.hold_out || index % 2 == 0;
        let localised = matches!(run.poses, PoseSource::Localised(_));
        let guess = match (anchor, scan.recorded_pose, last) {
            (_, Some(recorded), None) => recorded,
            // A localised pose is in the world's frame already: the guess is the pose
            // itself, so that the matcher's small corrections never add up (along a
            // corridor, which pins no position along it, they slid metres).
            (_, Some(recorded), _) if localised => recorded,
            // The recorded motion since the last scan that had a recorded pose, from where
            // that scan was placed: a gap in the recorded poses breaks no chain.
            (Some((placed_at, recorded_at)), Some(recorded), _) => {
                placed_at.compose(between(recorded_at, recorded))
            }
            (_, _, None) => Pose2::default(),
            (_, _, Some((pose, t1))) => match before_last {
                // The last motion again, scaled to this step's time.
                Some((previous, t0)) if t1 > t0 => {
                    let m = between(previous, pose);
                    let f = ((scan.time_ns - t1) as f64 / (t1 - t0) as f64).clamp(0.0, 3.0);
                    pose.compose(Pose2::new(m.x_m * f, m.y_m * f, m.heading_rad * f))
                }
                _ => pose,
            },
        };
        let found = if inserted > 0 && (options.match_scans || scan.recorded_pose.is_none()) {
            let points = thin(&scan.points_in_robot(), 0.1, 250);
            match_scan(&grid, &points, guess, &match_options)
        } else {
            None
        };
        let pose = found.map_or(guess, |m| m.pose);
        let correction = (
            (pose.position() - guess.position()).norm(),
            wrap_angle(pose.heading_rad - guess.heading_rad).abs(),
        );
        // A scan the matcher could not place goes into the map only when its guess is a
        // recorded pose: a guess from the last motion alone is a guess.
        let trusted = found.is_some() || inserted == 0 || scan.recorded_pose.is_some();
        if used && trusted {
            grid.insert(scan, pose)
                .map_err(|source| BuildError::TooBig {
                    path: run.path.clone(),
                    index,
                    source,
                })?;
            inserted += 1;
        }
        placed.push(Placed {
            index,
            time_ns: scan.time_ns,
            recorded: scan.recorded_pose,
            pose,
            matched: found.is_some(),
            used: used && trusted,
            correction,
        });
        before_last = last;
        last = Some((pose, scan.time_ns));
        if let Some(recorded) = scan.recorded_pose {
            anchor = Some((pose, recorded));
        }
        if index % 16 == 0 {
            progress(index);
        }
    }
    progress(run.scans.len());
    let tried = run.scans.len().saturating_sub(1);
    let matched = placed.iter().filter(|p| p.matched).count();
    if options.match_scans && (matched as f64) < MIN_MATCHED_SHARE * tried as f64 {
        let why = match &run.poses {
            PoseSource::Localised(_) => None,
            PoseSource::Odometry(what) => Some(format!(
                "the odometry ({what}) does not agree with the scans"
            )),
            PoseSource::None => Some("the run has no odometry to fall back on".to_owned()),
        };
        if let Some(why) = why {
            return Err(BuildError::NoMatches {
                path: run.path.clone(),
                matched,
                tried,
                why,
            });
        }
    }
    let report = report(run, &grid, &placed);
    Ok(Built {
        grid,
        placed,
        report,
    })
}

fn median_and_max(mut values: Vec<f64>) -> (f64, f64) {
    if values.is_empty() {
        return (0.0, 0.0);
    }
    values.sort_by(f64::total_cmp);
    (values[values.len() / 2], values[values.len() - 1])
}

fn report(run: &Run, grid: &Grid, placed: &[Placed]) -> BuildReport {
    let matched: Vec<&Placed> = placed.iter().filter(|p| p.matched).collect();
    let drift_m = placed
        .iter()
        .filter_map(|p| {
            p.recorded
                .map(|r| (p.pose.position() - r.position()).norm())
        })
        .reduce(f64::max);
    let (occupied_cells, left_out_cells) = grid.census();
    BuildReport {
        poses: run.poses.clone(),
        scans: placed.len(),
        used: placed.iter().filter(|p| p.used).count(),
        matched: matched.len(),
        step_correction_m: median_and_max(matched.iter().map(|p| p.correction.0).collect()),
        step_correction_rad: median_and_max(matched.iter().map(|p| p.correction.1).collect()),
        drift_m,
        occupied_cells,
        left_out_cells,
        grid_bytes: grid.bytes(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn between_undoes_compose() {
        let a = Pose2::new(1.0, -2.0, 0.7);
        let b = Pose2::new(-0.5, 3.0, -2.9);
        let back = a.compose(between(a, b));
        assert!((back.x_m - b.x_m).abs() < 1e-12 && (back.y_m - b.y_m).abs() < 1e-12);
        assert!(wrap_angle(back.heading_rad - b.heading_rad).abs() < 1e-12);
    }
}
