//! The simulator's world map under the world view: found from the robot description the
//! recorder stores in the file (metadata `lewis.robot`), whose services name their world
//! folder (`world = "robots/worlds/conference"`); the folder's `world.toml` gives the map
//! image, its scale and where its bottom-left corner lies.
//!
//! A recording made without the simulator names no world, and shows none. A world that is
//! named but not found here (the recording was copied to another machine) is reported, and
//! the rest is drawn as usual.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use lewis_stdx::world::{WorldHeader, WorldHeaderError, find_world};
use rerun::components::DrawOrder;
use rerun::{Image, Transform3D};

use crate::ViewError;
use crate::draw::entity;
use crate::rows::{ChunkSink, Rows};

/// The metadata record that holds the robot description (written by the recorder).
pub(crate) use lewis_mcap::format::ROBOT_METADATA;

/// Drawn under everything else of the world view.
const MAP_DRAW_ORDER: f32 = -100.0;

/// Pixels darker than this (luma, 0 to 255) are walls, as the simulator reads the map.
const WALL_LUMA: u8 = 128;

/// How walls are drawn: light grey on the viewer's dark background; free space is left
/// transparent, so that the path and the scans stand out.
const WALL_RGBA: [u8; 4] = [185, 185, 185, 255];

/// What became of the world map.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MapStatus {
    /// Drawn from this image.
    Drawn {
        /// The map image.
        image: PathBuf,
        /// Its size in pixels.
        width_px: u32,
        /// Its size in pixels.
        height_px: u32,
    },
    /// The recording names a world whose map could not be used; nothing was drawn.
    Missing {
        /// The world folder as the robot description names it.
        world: String,
        /// What went wrong: where it was looked for, or what is wrong with it.
        detail: String,
    },
}

impl fmt::Display for MapStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Drawn {
                image,
                width_px,
                height_px,
            } => write!(
                f,
                "world map {} ({width_px} x {height_px} px)",
                image.display()
            ),
            Self::Missing { world, detail } => {
                write!(f, "no world map drawn for world `{world}`: {detail}")
            }
        }
    }
}

/// The world folders the services of a robot description name, in order, without repeats.
/// A description that is not TOML names none.
pub(crate) fn world_folders(robot_toml: &str) -> Vec<String> {
    let Ok(robot) = robot_toml.parse::<toml::Table>() else {
        return Vec::new();
    };
    let mut folders = Vec::new();
    let services = robot.get("services").and_then(toml::Value::as_array);
    for service in services.into_iter().flatten() {
        let world = service
            .get("parameters")
            .and_then(|p| p.get("world"))
            .and_then(toml::Value::as_str);
        if let Some(world) = world
            && !folders.iter().any(|f| f == world)
        {
            folders.push(world.to_owned());
        }
    }
    folders
}

/// The first world folder named by the robot description in `metadata` (the file's
/// metadata records), if any.
pub(crate) fn named_world(metadata: &BTreeMap<String, BTreeMap<String, String>>) -> Option<String> {
    metadata
        .get(ROBOT_METADATA)?
        .values()
        .find_map(|toml| world_folders(toml).into_iter().next())
}

/// The map of a world folder, ready to draw.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WorldMap {
    /// The image file.
    pub image: PathBuf,
    /// The walls as RGBA pixels, top row first (free space transparent).
    pub walls_rgba: Vec<u8>,
    /// Its size.
    pub width_px: u32,
    /// Its size.
    pub height_px: u32,
    /// Metres per pixel.
    pub metres_per_pixel: f64,
    /// The world position of the image's bottom-left corner, m.
    pub origin_m: [f64; 2],
}

/// Finds and reads the map of `world` for the recording at `recording`: the folder as
/// written, then above the recording (see [`find_world`]).
pub(crate) fn find(world: &str, recording: &Path) -> Result<WorldMap, MapStatus> {
    let missing = |detail: String| MapStatus::Missing {
        world: world.to_owned(),
        detail,
    };
    let header = find_world(world, recording).map_err(|e| match e {
        WorldHeaderError::NotFound { .. } => missing(format!(
            "{e}; run `lewis view` from the folder `lewis up` ran in"
        )),
        WorldHeaderError::Invalid { .. } => missing(e.to_string()),
    })?;
    load(header).map_err(missing)
}

/// Reads the map image a world's header names; `Err` says what is wrong.
fn load(header: WorldHeader) -> Result<WorldMap, String> {
    let WorldHeader {
        image,
        metres_per_pixel,
        origin_m,
        ..
    } = header;
    let luma = image::open(&image)
        .map_err(|e| format!("{}: {e}", image.display()))?
        .into_luma8();
    let (width_px, height_px) = luma.dimensions();
    let walls_rgba = luma
        .pixels()
        .flat_map(|p| {
            if p.0[0] < WALL_LUMA {
                WALL_RGBA
            } else {
                [0; 4]
            }
        })
        .collect();
    Ok(WorldMap {
        image,
        walls_rgba,
        width_px,
        height_px,
        metres_per_pixel,
        origin_m,
    })
}

/// Draws `map` at `world/map`, for all times, under the paths and scans: the image's pixels
/// scaled to metres, its bottom-left corner at `origin_m`, its rows going down the world's
/// y axis (the image is stored top row first).
pub(crate) fn log(
    rows: &mut Rows,
    sink: &mut dyn ChunkSink,
    map: &WorldMap,
) -> Result<(), ViewError> {
    let path = entity(["world", "map"]);
    let (mpp, x0, top) = (
        map.metres_per_pixel as f32,
        map.origin_m[0] as f32,
        (map.origin_m[1] + f64::from(map.height_px) * map.metres_per_pixel) as f32,
    );
    rows.log_static(
        sink,
        &path,
        &Transform3D::from_translation_scale([x0, top, 0.0], [mpp, -mpp, 1.0]),
    )?;
    rows.log_static(
        sink,
        &path,
        &Image::from_rgba32(map.walls_rgba.clone(), [map.width_px, map.height_px])
            .with_draw_order(DrawOrder::from(MAP_DRAW_ORDER)),
    )?;
    Ok(())
}
