//! The mission bench as a picture (PNG): the world's map, each mission's start pose (a dot
//! and its heading, green when the mission succeeded, red and numbered when it failed) and
//! the ways its people walked, so that a failure that clusters (a corner, a heading) shows.

use std::path::Path;

use lewis_geometry::Vec2;
use lewis_images::plot::{FAMILY, ensure_font, rgb_png};
use lewis_sim::world::World;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::MissionBenchReport;

const WIDTH: u32 = 1100;
const TITLE_PX: u32 = 44;
/// The margin round the map, in pixels.
const MARGIN_PX: u32 = 10;

const SUCCEEDED: RGBColor = RGBColor(0x1a, 0x96, 0x41);
const FAILED: RGBColor = RGBColor(0xd7, 0x19, 0x1c);
const WALL: RGBColor = RGBColor(0x48, 0x48, 0x48);
const WALK: RGBColor = RGBColor(0x56, 0xb4, 0xe9);

/// Writes the picture of `report` in `world` at `path` (replacing it).
///
/// # Errors
/// When it cannot be drawn, encoded or written; the message names `path`.
pub fn write_png(report: &MissionBenchReport, world: &World, path: &Path) -> Result<(), String> {
    let named = |e: String| format!("cannot draw {}: {e}", path.display());
    ensure_font().map_err(named)?;
    let grid = world.grid();
    let size = grid.far_corner() - grid.origin();
    let scale = f64::from(WIDTH - 2 * MARGIN_PX) / size.x.max(1e-9);
    let height = TITLE_PX + 2 * MARGIN_PX + (size.y * scale).ceil() as u32;
    let mut pixels = vec![0_u8; (WIDTH * height * 3) as usize];
    let frame = Frame {
        origin: grid.origin(),
        scale,
        height,
    };
    draw(report, world, &frame, &mut pixels).map_err(named)?;
    let png = rgb_png(&pixels, WIDTH, height).map_err(|e| named(e.to_string()))?;
    std::fs::write(path, png).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// World metres to picture pixels (y up in the world, down in the picture).
struct Frame {
    origin: Vec2,
    scale: f64,
    height: u32,
}

impl Frame {
    fn pixel(&self, p: Vec2) -> (i32, i32) {
        let x = f64::from(MARGIN_PX) + (p.x - self.origin.x) * self.scale;
        let y = f64::from(self.height - MARGIN_PX) - (p.y - self.origin.y) * self.scale;
        (x.round() as i32, y.round() as i32)
    }

    fn point(&self, (x, y): (u32, u32)) -> Vec2 {
        Vec2::new(
            self.origin.x + (f64::from(x) - f64::from(MARGIN_PX) + 0.5) / self.scale,
            self.origin.y + (f64::from(self.height - MARGIN_PX) - f64::from(y) - 0.5) / self.scale,
        )
    }
}

fn draw(
    report: &MissionBenchReport,
    world: &World,
    frame: &Frame,
    pixels: &mut [u8],
) -> Result<(), String> {
    let root = BitMapBackend::with_buffer(pixels, (WIDTH, frame.height)).into_drawing_area();
    root.fill(&WHITE).map_err(show)?;
    let grid = world.grid();
    for y in TITLE_PX + MARGIN_PX..frame.height - MARGIN_PX {
        for x in MARGIN_PX..WIDTH - MARGIN_PX {
            let (column, row) = grid.cell_of(frame.point((x, y)));
            if grid.is_occupied(column, row) {
                root.draw_pixel((x as i32, y as i32), &WALL).map_err(show)?;
            }
        }
    }
    let n = report.missions.len();
    root.draw_text(
        &format!(
            "{} of {n} missions succeeded, {}; green: succeeded, red: failed (numbered); blue: people's ways",
            report.succeeded(),
            if report.random_start {
                "from random starts"
            } else {
                "from the robot file's start"
            }
        ),
        &TextStyle::from((FAMILY, 18).into_font()).pos(Pos::new(HPos::Center, VPos::Center)),
        (WIDTH as i32 / 2, TITLE_PX as i32 / 2 + 4),
    )
    .map_err(show)?;
    for m in &report.missions {
        for w in &m.walkers {
            let from = frame.pixel(Vec2::new(w.from[0], w.from[1]));
            let to = frame.pixel(Vec2::new(w.to[0], w.to[1]));
            root.draw(&PathElement::new(vec![from, to], WALK.stroke_width(2)))
                .map_err(show)?;
        }
    }
    // The failures last, over the successes.
    let mut order: Vec<_> = report.missions.iter().collect();
    order.sort_by_key(|m| !m.succeeded);
    for m in order {
        let colour = if m.succeeded { SUCCEEDED } else { FAILED };
        let at = Vec2::new(m.start.x_m, m.start.y_m);
        let ahead = at + Vec2::from_angle(m.start.heading_deg.to_radians()) * 0.6;
        let centre = frame.pixel(at);
        root.draw(&Circle::new(centre, 5, colour.filled()))
            .map_err(show)?;
        root.draw(&PathElement::new(
            vec![centre, frame.pixel(ahead)],
            colour.stroke_width(2),
        ))
        .map_err(show)?;
        if !m.succeeded {
            root.draw_text(
                &m.number.to_string(),
                &TextStyle::from((FAMILY, 15).into_font()).color(&FAILED),
                (centre.0 + 8, centre.1 + 2),
            )
            .map_err(show)?;
        }
    }
    root.present().map_err(show)
}

fn show(e: impl std::fmt::Display) -> String {
    e.to_string()
}
