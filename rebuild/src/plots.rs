//! The check's pictures: the beam error over the run's time (`check-time.png`) and where on
//! the map the error lies (`check-map.png`). Drawn by plotters with the font bundled in
//! `components/images/assets/` ([`lewis_images::plot`]: no system font, no C library), encoded by `image`.

use std::path::{Path, PathBuf};

use image::{Rgb, RgbImage};
use lewis_images::plot::{FAMILY, ensure_font};
use lewis_sim::world::World;
use plotters::prelude::*;

use crate::check::{CLOSE_M, CheckReport, ErrorMap, NEAR_M};

/// Why a picture was not written.
#[derive(Debug, thiserror::Error)]
#[error("{}: {reason}", path.display())]
pub struct PlotError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub reason: String,
}

const WIDTH: u32 = 960;
const HEIGHT: u32 = 480;

/// Writes the error by part of the run: median and 90th percentile, held out (solid) and
/// built from (dashed), with the goal's 5 cm and 20 cm.
///
/// # Errors
/// When it cannot be drawn or written.
pub fn write_time_plot(report: &CheckReport, path: &Path) -> Result<(), PlotError> {
    let fail = |reason: String| PlotError {
        path: path.to_owned(),
        reason,
    };
    ensure_font().map_err(fail)?;
    let mut pixels = vec![255_u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
        let end_s = report.parts.last().map_or(1.0, |p| p.to_s).max(1e-3);
        let top = report
            .parts
            .iter()
            .flat_map(|p| [p.held_out.p90_m, p.used.p90_m])
            .fold(0.25_f64, f64::max)
            .min(2.0);
        let mut chart = ChartBuilder::on(&root)
            .caption("Beam range error by part of the run", (FAMILY, 22))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..end_s, 0.0..top * 1.05)
            .map_err(|e| fail(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc("time from the first scan (s)")
            .y_desc("absolute range error (m)")
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        for (limit, label) in [(CLOSE_M, "5 cm"), (NEAR_M, "20 cm")] {
            chart
                .draw_series(LineSeries::new(
                    [(0.0, limit), (end_s, limit)],
                    BLACK.mix(0.3),
                ))
                .map_err(|e| fail(e.to_string()))?
                .label(label);
        }
        let mid = |p: &crate::check::Part| (p.from_s + p.to_s) / 2.0;
        let held = report.held_out.is_some();
        let series: [(&str, bool, bool, RGBColor); 4] = [
            ("median, held out", true, false, RGBColor(0x1f, 0x77, 0xb4)),
            ("p90, held out", true, true, RGBColor(0xd6, 0x27, 0x28)),
            (
                "median, built from",
                false,
                false,
                RGBColor(0x9e, 0xc5, 0xe8),
            ),
            ("p90, built from", false, true, RGBColor(0xf1, 0xa3, 0xa3)),
        ];
        for (label, held_out, p90, colour) in series {
            if held_out && !held {
                continue;
            }
            let points: Vec<(f64, f64)> = report
                .parts
                .iter()
                .filter_map(|p| {
                    let f = if held_out { &p.held_out } else { &p.used };
                    (f.beams > 0).then(|| (mid(p), if p90 { f.p90_m } else { f.median_m }.min(top)))
                })
                .collect();
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| fail(e.to_string()))?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(
                    points
                        .into_iter()
                        .map(|p| Circle::new(p, 3, colour.filled())),
                )
                .map_err(|e| fail(e.to_string()))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let image = RgbImage::from_raw(WIDTH, HEIGHT, pixels)
        .ok_or_else(|| fail("the plot's buffer has the wrong size".to_owned()))?;
    image.save(path).map_err(|e| fail(e.to_string()))
}

/// Writes the map with each cell a beam ended in coloured by the mean error there: green
/// within 5 cm, yellow within 20 cm, red beyond.
///
/// # Errors
/// When it cannot be written.
pub fn write_error_map(world: &World, errors: &ErrorMap, path: &Path) -> Result<(), PlotError> {
    let grid = world.grid();
    let (w, h) = (grid.width_cells(), grid.height_cells());
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(PlotError {
            path: path.to_owned(),
            reason: format!("a map of {w} x {h} cells is too big to draw"),
        });
    };
    let mut sums = vec![(0.0_f64, 0_u32); w * h];
    for &(p, e) in &errors.points {
        let (c, r) = grid.cell_of(p);
        if let (Ok(c), Ok(r)) = (usize::try_from(c), usize::try_from(r))
            && c < w
            && r < h
        {
            let s = &mut sums[r * w + c];
            s.0 += f64::from(e);
            s.1 += 1;
        }
    }
    let mut image = RgbImage::new(w32, h32);
    for r in 0..h {
        for c in 0..w {
            // both below the image's u32 size
            let (x, y) = (c as u32, (h - 1 - r) as u32);
            let (sum, n) = sums[r * w + c];
            let pixel = if n > 0 {
                let mean = sum / f64::from(n);
                if mean <= CLOSE_M {
                    Rgb([20, 170, 60])
                } else if mean <= NEAR_M {
                    Rgb([230, 190, 0])
                } else {
                    Rgb([220, 20, 20])
                }
            } else if grid.is_occupied(c as i64, r as i64) {
                Rgb([90, 90, 90])
            } else {
                Rgb([255, 255, 255])
            };
            image.put_pixel(x, y, pixel);
        }
    }
    image.save(path).map_err(|e| PlotError {
        path: path.to_owned(),
        reason: e.to_string(),
    })
}
