//! The world folder written: the simulator's own format (`world.toml` and `map.png`, what
//! `lewis_sim::World::load` and `lewis_stdx::world::find_world` read), beside it where
//! every scan was taken (`trajectory.csv`), the cells left out as things that moved
//! (`moving.png`) and a picture (`rebuild.png`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use image::{GrayImage, Luma, Rgb, RgbImage};
use lewis_geometry::{Pose2, Vec2};

use crate::build::{Built, Placed};
use crate::grid::Cell;
use crate::run::Run;

/// Luma of a wall (the simulator takes below 128 as a wall).
const WALL: u8 = 0;
/// Luma of a cell seen free.
const FREE: u8 = 255;
/// Luma of a cell never seen: free to the simulator (at or above 128), so that its beams
/// are not stopped in the gaps between a long-range scan's beams.
const UNKNOWN: u8 = 190;
/// Cells of margin around what was seen.
const MARGIN_CELLS: i64 = 10;

/// The files of a world folder.
pub const WORLD_TOML: &str = "world.toml";
/// The map image.
pub const MAP_PNG: &str = "map.png";
/// Where every scan was taken.
pub const TRAJECTORY_CSV: &str = "trajectory.csv";
/// The cells left out (black).
pub const MOVING_PNG: &str = "moving.png";
/// The picture of the build.
pub const PICTURE_PNG: &str = "rebuild.png";

/// Why a world folder cannot be written or read.
#[derive(Debug, thiserror::Error)]
pub enum WorldDirError {
    /// A file cannot be written or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// An image cannot be encoded or decoded.
    #[error("{}: {source}", path.display())]
    Image {
        /// The file.
        path: PathBuf,
        /// What the codec said.
        source: image::ImageError,
    },
    /// Nothing was seen.
    #[error("no scan of the run saw anything: there is no map to write")]
    Empty,
    /// A line of the trajectory is not as written.
    #[error("{}:{line}: {reason}", path.display())]
    Trajectory {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

/// What was written.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    /// The folder.
    pub dir: PathBuf,
    /// The map's size in pixels.
    pub size_px: (u32, u32),
    /// The map's size in m.
    pub size_m: (f64, f64),
    /// Where its lower-left corner lies, in m.
    pub origin_m: (f64, f64),
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> WorldDirError + '_ {
    move |source| WorldDirError::Io {
        path: path.to_owned(),
        source,
    }
}

fn save_png(
    path: &Path,
    save: impl FnOnce(&Path) -> image::ImageResult<()>,
) -> Result<(), WorldDirError> {
    save(path).map_err(|source| WorldDirError::Image {
        path: path.to_owned(),
        source,
    })
}

/// Writes the world of `built` (from `run`) into `dir`, created if missing.
///
/// # Errors
/// When nothing was seen, or a file cannot be written.
pub fn write(dir: &Path, run: &Run, built: &Built) -> Result<Written, WorldDirError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let grid = &built.grid;
    let (lo, hi) = grid.observed_bounds().ok_or(WorldDirError::Empty)?;
    let lo = [lo[0] - MARGIN_CELLS, lo[1] - MARGIN_CELLS];
    let hi = [hi[0] + MARGIN_CELLS, hi[1] + MARGIN_CELLS];
    // a building's cells: positive and far below u32
    let (w, h) = ((hi[0] - lo[0] + 1) as u32, (hi[1] - lo[1] + 1) as u32);
    let size = grid.metres_per_cell();
    let cell_at = |x: u32, y: u32| -> Cell { [lo[0] + i64::from(x), lo[1] + i64::from(h - 1 - y)] };
    let mut map = GrayImage::new(w, h);
    let mut moving = GrayImage::from_pixel(w, h, Luma([FREE]));
    for y in 0..h {
        for x in 0..w {
            let cell = cell_at(x, y);
            let luma = if grid.is_occupied(cell) {
                WALL
            } else if grid.is_observed(cell) {
                FREE
            } else {
                UNKNOWN
            };
            map.put_pixel(x, y, Luma([luma]));
            if grid.is_left_out(cell) {
                moving.put_pixel(x, y, Luma([WALL]));
            }
        }
    }
    let map_path = dir.join(MAP_PNG);
    save_png(&map_path, |p| map.save(p))?;
    let moving_path = dir.join(MOVING_PNG);
    save_png(&moving_path, |p| moving.save(p))?;
    let origin = (lo[0] as f64 * size, lo[1] as f64 * size);
    let size_m = (f64::from(w) * size, f64::from(h) * size);
    let name = dir.file_name().map_or_else(
        || "rebuilt".to_owned(),
        |n| n.to_string_lossy().into_owned(),
    );
    let start = built.placed.first().map(|p| p.pose).unwrap_or_default();
    let r = &built.report;
    let mut toml = String::new();
    let _ = writeln!(
        toml,
        "# Rebuilt by `lewis world from` from {} ({}), {} scans of {}.",
        run.path.display(),
        run.format,
        r.scans,
        run.laser
    );
    let _ = writeln!(
        toml,
        "# Poses: {}; {} of {} scans placed by the scan matcher.",
        r.poses,
        r.matched,
        r.scans.saturating_sub(1)
    );
    let _ = writeln!(
        toml,
        "# {} wall cells; {} cells seen occupied but mostly free (things that moved) left out.",
        r.occupied_cells, r.left_out_cells
    );
    let _ = writeln!(
        toml,
        "# The map's black pixels are walls, white seen free, grey never seen (free to the simulator)."
    );
    let _ = writeln!(
        toml,
        "# The run starts at the pose below (a sim-base's `start` parameter); trajectory.csv has every scan's."
    );
    let _ = writeln!(
        toml,
        "#   start = {{ x_m = {:.3}, y_m = {:.3}, heading_deg = {:.1} }}",
        start.x_m,
        start.y_m,
        start.heading_rad.to_degrees()
    );
    let _ = writeln!(toml);
    let _ = writeln!(toml, "name = {}", toml_string(&name));
    let _ = writeln!(toml, "map = \"{MAP_PNG}\"");
    let _ = writeln!(toml, "metres_per_pixel = {size}");
    let _ = writeln!(toml, "size_m = [{}, {}]", size_m.0, size_m.1);
    let _ = writeln!(toml, "origin_m = [{}, {}]", origin.0, origin.1);
    let toml_path = dir.join(WORLD_TOML);
    std::fs::write(&toml_path, toml).map_err(io(&toml_path))?;
    write_trajectory(&dir.join(TRAJECTORY_CSV), &built.placed)?;
    let picture = picture(&map, &moving, (lo, h), size, &built.placed);
    save_png(&dir.join(PICTURE_PNG), |p| picture.save(p))?;
    Ok(Written {
        dir: dir.to_owned(),
        size_px: (w, h),
        size_m,
        origin_m: origin,
    })
}

fn toml_string(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {}
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

const TRAJECTORY_HEADER: &str =
    "index,time_ns,recorded_x_m,recorded_y_m,recorded_heading_rad,x_m,y_m,heading_rad,matched,used";

fn write_trajectory(path: &Path, placed: &[Placed]) -> Result<(), WorldDirError> {
    let mut text = String::with_capacity(placed.len() * 96);
    let _ = writeln!(text, "{TRAJECTORY_HEADER}");
    for p in placed {
        let (rx, ry, rh) = p
            .recorded
            .map_or((String::new(), String::new(), String::new()), |r| {
                (
                    format!("{:.6}", r.x_m),
                    format!("{:.6}", r.y_m),
                    format!("{:.6}", r.heading_rad),
                )
            });
        let _ = writeln!(
            text,
            "{},{},{rx},{ry},{rh},{:.6},{:.6},{:.6},{},{}",
            p.index,
            p.time_ns,
            p.pose.x_m,
            p.pose.y_m,
            p.pose.heading_rad,
            u8::from(p.matched),
            u8::from(p.used)
        );
    }
    std::fs::write(path, text).map_err(io(path))
}

/// Reads `dir/trajectory.csv`: every scan's place as `lewis world from` wrote it.
///
/// # Errors
/// When the file cannot be read or a line is not as written.
pub fn read_trajectory(dir: &Path) -> Result<Vec<Placed>, WorldDirError> {
    let path = dir.join(TRAJECTORY_CSV);
    let text = std::fs::read_to_string(&path).map_err(io(&path))?;
    let bad = |line: usize, reason: String| WorldDirError::Trajectory {
        path: path.clone(),
        line,
        reason,
    };
    let mut lines = text.lines();
    if lines.next() != Some(TRAJECTORY_HEADER) {
        return Err(bad(
            1,
            format!(
                "the header is not `{TRAJECTORY_HEADER}`: write the world again with `lewis world from`"
            ),
        ));
    }
    let mut placed = Vec::new();
    for (n, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let line_no = n + 2;
        if fields.len() != 10 {
            return Err(bad(line_no, format!("{} fields, not 10", fields.len())));
        }
        let float = |i: usize| -> Result<f64, WorldDirError> {
            fields[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    bad(
                        line_no,
                        format!("field {} `{}` is not a number", i + 1, fields[i]),
                    )
                })
        };
        let recorded = if fields[2].is_empty() {
            None
        } else {
            Some(Pose2::new(float(2)?, float(3)?, float(4)?))
        };
        let index = fields[0]
            .parse::<usize>()
            .map_err(|_| bad(line_no, format!("the index `{}` is not a count", fields[0])))?;
        let time_ns = fields[1]
            .parse::<i64>()
            .map_err(|_| bad(line_no, format!("the time `{}` is not in ns", fields[1])))?;
        placed.push(Placed {
            index,
            time_ns,
            recorded,
            pose: Pose2::new(float(5)?, float(6)?, float(7)?),
            matched: fields[8] == "1",
            used: fields[9] == "1",
            correction: (0.0, 0.0),
        });
    }
    Ok(placed)
}

/// Reads `dir/moving.png` as the set of cells left out, in the map's pixels (`None` when
/// the folder has none: a world not rebuilt).
#[must_use]
pub fn read_moving(dir: &Path) -> Option<GrayImage> {
    image::open(dir.join(MOVING_PNG)).ok().map(|i| i.to_luma8())
}

/// The largest side of a picture, in pixels: bigger maps are drawn a few cells a pixel.
const PICTURE_MAX_PX: u32 = 1600;

/// Colours of the picture.
const RECORDED: Rgb<u8> = Rgb([40, 90, 220]);
const PLACED: Rgb<u8> = Rgb([220, 30, 30]);
const UNMATCHED: Rgb<u8> = Rgb([250, 150, 0]);
const MOVED: Rgb<u8> = Rgb([120, 200, 120]);

/// The map (walls black, things that moved green), the recorded path (blue), the path the
/// matcher placed the scans on (red) and the scans it could not place (orange).
fn picture(
    map: &GrayImage,
    moving: &GrayImage,
    (lo, h): (Cell, u32),
    size: f64,
    placed: &[Placed],
) -> RgbImage {
    let (w, hh) = map.dimensions();
    let scale = w.max(hh).div_ceil(PICTURE_MAX_PX).max(1);
    let (pw, ph) = (w.div_ceil(scale), hh.div_ceil(scale));
    let mut out = RgbImage::new(pw, ph);
    for y in 0..ph {
        for x in 0..pw {
            // The darkest of the cells a pixel covers: walls stay drawn when scaled down.
            let mut luma = 255_u8;
            let mut moved = false;
            for dy in 0..scale {
                for dx in 0..scale {
                    let (mx, my) = (x * scale + dx, y * scale + dy);
                    if mx < w && my < hh {
                        luma = luma.min(map.get_pixel(mx, my).0[0]);
                        moved |= moving.get_pixel(mx, my).0[0] == WALL;
                    }
                }
            }
            let pixel = if moved && luma != WALL {
                MOVED
            } else {
                Rgb([luma, luma, luma])
            };
            out.put_pixel(x, y, pixel);
        }
    }
    let to_px = |p: Vec2| -> (f64, f64) {
        let cx = p.x / size - lo[0] as f64;
        let cy = f64::from(h) - (p.y / size - lo[1] as f64);
        (cx / f64::from(scale), cy / f64::from(scale))
    };
    let path = |out: &mut RgbImage, poses: &mut dyn Iterator<Item = Vec2>, colour: Rgb<u8>| {
        let mut previous: Option<(f64, f64)> = None;
        for p in poses {
            let q = to_px(p);
            if let Some(a) = previous {
                line(out, a, q, colour);
            }
            previous = Some(q);
        }
    };
    path(
        &mut out,
        &mut placed
            .iter()
            .filter_map(|p| p.recorded.map(Pose2::position)),
        RECORDED,
    );
    path(
        &mut out,
        &mut placed.iter().map(|p| p.pose.position()),
        PLACED,
    );
    for p in placed.iter().skip(1).filter(|p| !p.matched) {
        let (x, y) = to_px(p.pose.position());
        for d in -2..=2 {
            dot(&mut out, x + f64::from(d), y + f64::from(d), UNMATCHED);
            dot(&mut out, x + f64::from(d), y - f64::from(d), UNMATCHED);
        }
    }
    out
}

fn dot(out: &mut RgbImage, x: f64, y: f64, colour: Rgb<u8>) {
    if x >= 0.0 && y >= 0.0 && x < f64::from(out.width()) && y < f64::from(out.height()) {
        // inside the image: non-negative and below its size
        out.put_pixel(x as u32, y as u32, colour);
    }
}

/// A line of pixels from `a` to `b`.
pub(crate) fn line(out: &mut RgbImage, a: (f64, f64), b: (f64, f64), colour: Rgb<u8>) {
    let steps = (b.0 - a.0)
        .abs()
        .max((b.1 - a.1).abs())
        .ceil()
        .clamp(1.0, 1e5);
    // at most 1e5 steps
    let n = steps as u32;
    for i in 0..=n {
        let f = f64::from(i) / steps;
        dot(out, a.0 + (b.0 - a.0) * f, a.1 + (b.1 - a.1) * f, colour);
    }
}
