//! Fidelity: the run's scans made again in the rebuilt world at the poses the world says
//! they were taken at, by the simulator's own ray caster (`lewis_sim::World::cast_ray`, the
//! one the simulated laser uses), and compared beam by beam with what the laser read.
//!
//! Only beams that returned are compared (a no-return reading has no range to compare).
//! Beams that end on a cell left out as something that moved are counted apart: the world
//! is the static building. Scans the world was not built from (`lewis world from
//! --hold-out`) give the figure that counts; the scans it was built from are reported
//! beside it.

use std::path::{Path, PathBuf};

use lewis_geometry::Vec2;
use lewis_sim::world::{World, WorldError};

use crate::run::Run;
use crate::world_dir::{self, WorldDirError};

/// The fidelity goal: median beam error under this, in m.
pub const GOAL_MEDIAN_M: f64 = 0.05;
/// The fidelity goal: at least this share of beams within [`NEAR_M`].
pub const GOAL_WITHIN_NEAR: f64 = 0.9;
/// A beam this close is "within 5 cm".
pub const CLOSE_M: f64 = 0.05;
/// A beam this close is "within 20 cm".
pub const NEAR_M: f64 = 0.20;
/// The height of the beams' plane, in m (the rebuilt map's walls span every height).
const BEAM_HEIGHT_M: f64 = 0.3;

/// Beam errors summed up.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Figures {
    /// Beams compared.
    pub beams: u64,
    /// Median absolute range error, in m.
    pub median_m: f64,
    /// 90th percentile of the absolute range error, in m.
    pub p90_m: f64,
    /// Share of beams within 5 cm.
    pub within_close: f64,
    /// Share of beams within 20 cm.
    pub within_near: f64,
}

impl Figures {
    /// The figures of `errors` (sorted in place).
    #[must_use]
    pub fn of(errors: &mut [f32]) -> Self {
        if errors.is_empty() {
            return Self::default();
        }
        errors.sort_by(f32::total_cmp);
        let n = errors.len();
        let at = |q: f64| {
            // an index of the slice: q in [0, 1]
            let i = ((n - 1) as f64 * q).round() as usize;
            f64::from(errors[i.min(n - 1)])
        };
        let within = |limit: f64| {
            let below = errors.partition_point(|e| f64::from(*e) <= limit);
            below as f64 / n as f64
        };
        Self {
            beams: n as u64,
            median_m: at(0.5),
            p90_m: at(0.9),
            within_close: within(CLOSE_M),
            within_near: within(NEAR_M),
        }
    }

    /// Whether these figures meet the goal (median under 5 cm, 90% within 20 cm).
    #[must_use]
    pub fn meets_goal(&self) -> bool {
        self.beams > 0 && self.median_m < GOAL_MEDIAN_M && self.within_near >= GOAL_WITHIN_NEAR
    }
}

/// One part of the run.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// From, in s after the first scan.
    pub from_s: f64,
    /// To, in s after the first scan.
    pub to_s: f64,
    /// Figures on held-out scans (empty when none).
    pub held_out: Figures,
    /// Figures on the scans the map was built from.
    pub used: Figures,
    /// Where the robot was, on average, in the world frame.
    pub centre: Vec2,
}

/// What the check found.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckReport {
    /// The world folder.
    pub world: PathBuf,
    /// On scans the map was not built from; `None` when it was built from all.
    pub held_out: Option<Figures>,
    /// On the scans the map was built from.
    pub used: Figures,
    /// By part of the run, in time order.
    pub parts: Vec<Part>,
    /// Beams ending on a cell left out as something that moved (not compared).
    pub moving_beams: u64,
    /// Beams without a return (not compared).
    pub no_return_beams: u64,
    /// Of the counting beams off by more than 20 cm: how many the world let pass beyond
    /// the reading (a hole in the map, or something the world leaves out), and how many it
    /// stopped short of it (something in the map the laser did not see there).
    pub far_off: FarOff,
}

/// Beams off by more than 20 cm, by which way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FarOff {
    /// The world's range was longer than the reading.
    pub beyond: u64,
    /// The world's range was shorter than the reading.
    pub short: u64,
}

impl CheckReport {
    /// The figures that count: on held-out scans when there are some.
    #[must_use]
    pub fn counting(&self) -> &Figures {
        self.held_out.as_ref().unwrap_or(&self.used)
    }

    /// The parts whose counting figures miss the goal.
    pub fn poor_parts(&self) -> impl Iterator<Item = &Part> {
        let held = self.held_out.is_some();
        self.parts.iter().filter(move |p| {
            let f = if held { &p.held_out } else { &p.used };
            f.beams > 0 && !f.meets_goal()
        })
    }
}

/// Where each beam's error lies, for the picture: the world position its reading ended at
/// and the error, in m.
#[derive(Debug, Clone, Default)]
pub struct ErrorMap {
    /// End points and their errors (held-out scans only, when there are some).
    pub points: Vec<(Vec2, f32)>,
}

/// Why a world cannot be checked.
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    /// The simulator cannot load the world.
    #[error(transparent)]
    World(#[from] WorldError),
    /// The folder's other files cannot be read.
    #[error(transparent)]
    Dir(#[from] WorldDirError),
    /// The trajectory is of another run.
    #[error(
        "{} was built from another run than {}: it places {placed} scans, the run has {scans}{detail}; build it from this run with `lewis world from`",
        dir.display(), run.display()
    )]
    OtherRun {
        /// The world folder.
        dir: PathBuf,
        /// The run.
        run: PathBuf,
        /// Scans placed in the folder.
        placed: usize,
        /// Scans in the run.
        scans: usize,
        /// What else differs.
        detail: String,
    },
}

/// Checks the world in `dir` against the scans of `run`, in `parts` parts of the run.
///
/// # Errors
/// When the world cannot be loaded, or was built from another run.
pub fn check(run: &Run, dir: &Path, parts: usize) -> Result<(CheckReport, ErrorMap), CheckError> {
    let world = World::load(dir)?;
    let placed = world_dir::read_trajectory(dir)?;
    let other = |detail: String| CheckError::OtherRun {
        dir: dir.to_owned(),
        run: run.path.clone(),
        placed: placed.len(),
        scans: run.scans.len(),
        detail,
    };
    if placed.len() != run.scans.len() {
        return Err(other(String::new()));
    }
    if let Some((p, s)) = placed
        .iter()
        .zip(&run.scans)
        .find(|(p, s)| p.time_ns != s.time_ns)
    {
        return Err(other(format!(
            " (scan {} is at {} ns in the run, {} ns in the folder)",
            p.index, s.time_ns, p.time_ns
        )));
    }
    let moving = world_dir::read_moving(dir);
    let grid = world.grid();
    let is_moving = |p: Vec2| -> bool {
        let Some(mask) = &moving else { return false };
        let (c, r) = grid.cell_of(p);
        let (w, h) = mask.dimensions();
        // One cell around: a reading ends within a cell of what it hit.
        (-1..=1).any(|dr| {
            (-1..=1).any(|dc| {
                let (c, r) = (c + dc, r + dr);
                match (u32::try_from(c), u32::try_from(r)) {
                    (Ok(x), Ok(row)) if x < w && row < h => {
                        mask.get_pixel(x, h - 1 - row).0[0] < 128
                    }
                    _ => false,
                }
            })
        })
    };
    let held_out_any = placed.iter().any(|p| !p.used);
    let t0 = run.scans.first().map_or(0, |s| s.time_ns);
    let duration_ns = run.scans.last().map_or(0, |s| s.time_ns) - t0;
    let parts = parts.max(1);
    let part_of = |t: i64| -> usize {
        if duration_ns <= 0 {
            return 0;
        }
        // in [0, parts]
        let f = (t - t0) as f64 / duration_ns as f64;
        ((f * parts as f64) as usize).min(parts - 1)
    };
    let mut held: Vec<Vec<f32>> = vec![Vec::new(); parts];
    let mut used: Vec<Vec<f32>> = vec![Vec::new(); parts];
    let mut centres = vec![(Vec2::new(0.0, 0.0), 0_u32); parts];
    let mut map = ErrorMap::default();
    let (mut moving_beams, mut no_return_beams) = (0, 0);
    let mut far_off = FarOff::default();
    for (scan, place) in run.scans.iter().zip(&placed) {
        let part = part_of(scan.time_ns);
        let centre = &mut centres[part];
        centre.0 = centre.0 + place.pose.position();
        centre.1 += 1;
        let sensor = place.pose.transform_point(scan.mount_m);
        for (i, &r) in scan.ranges_m.iter().enumerate() {
            if !scan.is_return(r) {
                no_return_beams += 1;
                continue;
            }
            let dir = Vec2::from_angle(place.pose.heading_rad + scan.bearing_rad(i));
            let end = sensor + dir * f64::from(r);
            if is_moving(end) {
                moving_beams += 1;
                continue;
            }
            let simulated = world
                .cast_ray(sensor, dir, scan.max_range_m, BEAM_HEIGHT_M)
                .map_or(scan.max_range_m, |h| h.range_m);
            // errors of a building's ranges: well within f32
            let error = (simulated - f64::from(r)).abs() as f32;
            if place.used {
                used[part].push(error);
            } else {
                held[part].push(error);
            }
            if place.used != held_out_any {
                map.points.push((end, error));
                if f64::from(error) > NEAR_M {
                    if simulated > f64::from(r) {
                        far_off.beyond += 1;
                    } else {
                        far_off.short += 1;
                    }
                }
            }
        }
    }
    let mut all_held: Vec<f32> = held.iter().flatten().copied().collect();
    let mut all_used: Vec<f32> = used.iter().flatten().copied().collect();
    let step_s = duration_ns as f64 / 1e9 / parts as f64;
    let parts = held
        .iter_mut()
        .zip(used.iter_mut())
        .zip(&centres)
        .enumerate()
        .map(|(k, ((h, u), c))| Part {
            from_s: k as f64 * step_s,
            to_s: (k + 1) as f64 * step_s,
            held_out: Figures::of(h),
            used: Figures::of(u),
            centre: c.0 * (1.0 / f64::from(c.1.max(1))),
        })
        .collect();
    let report = CheckReport {
        world: dir.to_owned(),
        held_out: held_out_any.then(|| Figures::of(&mut all_held)),
        used: Figures::of(&mut all_used),
        parts,
        moving_beams,
        no_return_beams,
        far_off,
    };
    Ok((report, map))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_the_median_the_p90_and_the_shares() {
        // 0.5 cm to 99.5 cm, one a centimetre, in reverse order.
        let mut errors: Vec<f32> = (0..100).rev().map(|i| (i as f32 + 0.5) / 100.0).collect();
        let f = Figures::of(&mut errors);
        assert_eq!(f.beams, 100);
        assert!((f.median_m - 0.505).abs() < 1e-6, "{f:?}");
        assert!((f.p90_m - 0.895).abs() < 1e-6, "{f:?}");
        assert!((f.within_close - 0.05).abs() < 1e-9, "{f:?}");
        assert!((f.within_near - 0.20).abs() < 1e-9, "{f:?}");
        assert!(!f.meets_goal());
        let mut good = vec![0.01_f32; 95];
        good.extend([1.0; 5]);
        assert!(Figures::of(&mut good).meets_goal());
        assert_eq!(Figures::of(&mut []), Figures::default());
    }
}
