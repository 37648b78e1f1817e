//! The sweep as a PNG plot: the fault time across, the time to finish up, a green dot
//! where the mission succeeded, a red cross in a band above them where it failed (with the
//! state the fault struck in), and the recorded time to finish as a dashed line; the
//! legend in a row of its own above the plot, where it hides no point.
//!
//! Drawn by plotters into a pixel buffer with the font bundled in `components/images/assets/`
//! (through ab_glyph: no system font is read, no C font library linked) and encoded by
//! `image`: the same sweep gives the same bytes.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::ops::Range;
use std::path::Path;

use super::table::failure_spans;
use super::{Sweep, SweepError};
use crate::fault::format_seconds;

use lewis_images::plot::{FAMILY, ensure_font, rgb_png};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 600;
/// The title's row and each of the legend's, above the plot.
const TITLE_PX: u32 = 44;
const LEGEND_ROW_PX: u32 = 28;

const SUCCEEDED: RGBColor = RGBColor(0x1a, 0x96, 0x41);
const FAILED: RGBColor = RGBColor(0xd7, 0x19, 0x1c);
const NOT_RUN: RGBColor = RGBColor(0x80, 0x80, 0x80);
const RECORDED: RGBColor = RGBColor(0x30, 0x30, 0x30);

impl Sweep {
    /// Writes the sweep's plot as a PNG file at `path` (replacing it): x the fault time in
    /// seconds from the start of the recording, y the time to finish in seconds; a green
    /// dot per time at which the mission succeeded, a red cross in the band at the top
    /// where it failed (a grey ring where the replay could not run), the recorded time to
    /// finish as a dashed line. The same sweep gives the same bytes.
    ///
    /// # Errors
    /// When the plot cannot be drawn or encoded, or the file cannot be written; each
    /// names `path`.
    pub fn write_png(&self, path: &Path) -> Result<(), SweepError> {
        let bytes = self.png(path)?;
        std::fs::write(path, bytes).map_err(|source| SweepError::Write {
            path: path.to_owned(),
            source,
        })
    }

    /// The plot's PNG bytes, as [`Sweep::write_png`] writes them (`lewis test` inlines them
    /// in its page); `path` only names the file in errors.
    ///
    /// # Errors
    /// When the plot cannot be drawn or encoded.
    pub fn png(&self, path: &Path) -> Result<Vec<u8>, SweepError> {
        let draw_error = |reason: String| SweepError::Draw {
            path: path.to_owned(),
            reason,
        };
        ensure_font().map_err(draw_error)?;
        // Three bytes a pixel, as plotters' bitmap backend draws by default.
        let mut pixels = vec![0_u8; (WIDTH * HEIGHT * 3) as usize];
        self.draw(&mut pixels).map_err(draw_error)?;
        rgb_png(&pixels, WIDTH, HEIGHT).map_err(|source| SweepError::Encode {
            path: path.to_owned(),
            source,
        })
    }

    fn draw(&self, pixels: &mut [u8]) -> Result<(), String> {
        let root = BitMapBackend::with_buffer(pixels, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(show)?;
        let legend = legend_rows(&root, self.legend_items())?;
        let legend_px = LEGEND_ROW_PX * u32::try_from(legend.len()).unwrap_or(1);
        let (top, body) = root.split_vertically(TITLE_PX + legend_px);
        let (title_area, legend_area) = top.split_vertically(TITLE_PX);

        let recording = Path::new(&self.recording).file_name().map_or_else(
            || self.recording.clone(),
            |n| n.to_string_lossy().into_owned(),
        );
        let times = self.points.len() + self.failed_points.len();
        let title = format!(
            "Fault sweep of {recording}: {} at {times} {}",
            super::table::fault_name(&self.providers, self.kind),
            if times == 1 { "time" } else { "times" }
        );
        title_area
            .draw_text(
                &title,
                &TextStyle::from((FAMILY, 24).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Center)),
                (WIDTH as i32 / 2, TITLE_PX as i32 / 2 + 4),
            )
            .map_err(show)?;
        draw_legend(&legend_area, &legend)?;

        let scale = Scale::of(self);
        let band_height = scale.band.end - scale.band.start;
        // The marks in the upper part of the band, the states they struck in below them.
        let band_marks = scale.band.start + band_height * 0.62;
        let band_states = scale.band.start + band_height * 0.22;
        let mut chart = ChartBuilder::on(&body)
            .margin_left(16)
            .margin_right(32)
            .margin_top(8)
            .margin_bottom(12)
            .x_label_area_size(50)
            .y_label_area_size(70)
            .build_cartesian_2d(scale.x.clone(), scale.y.start..scale.band.end)
            .map_err(show)?;

        let band_start = scale.band.start;
        chart
            .configure_mesh()
            .x_desc("fault time (s from the start of the recording)")
            .y_desc("time to finish the mission (s)")
            .axis_desc_style((FAMILY, 17))
            .label_style((FAMILY, 15))
            // No tick labels in the band: its height means nothing.
            .y_label_formatter(&|y| {
                if *y > band_start {
                    String::new()
                } else {
                    tick(*y)
                }
            })
            .x_label_formatter(&|x| tick(*x))
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.08))
            .draw()
            .map_err(show)?;

        // The band where the failures go, labelled beside the axis like a tick.
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [
                    (scale.x.start, scale.band.start),
                    (scale.x.end, scale.band.end),
                ],
                FAILED.mix(0.08).filled(),
            )))
            .map_err(show)?;
        let (axis_x, band_y) = chart.backend_coord(&(scale.x.start, band_marks));
        root.draw_text(
            "failed",
            &(FAMILY, 15)
                .into_font()
                .color(&FAILED)
                .pos(Pos::new(HPos::Right, VPos::Center)),
            (axis_x - 8, band_y),
        )
        .map_err(show)?;

        if let Some(recorded) = self.recorded_time_to_finish_ns.map(seconds) {
            chart
                .draw_series(DashedLineSeries::new(
                    [(scale.x.start, recorded), (scale.x.end, recorded)],
                    10,
                    6,
                    RECORDED.stroke_width(2),
                ))
                .map_err(show)?;
        }
        chart
            .draw_series(self.points.iter().filter(|p| p.succeeded).map(|p| {
                let x = seconds(p.fault_at_ns);
                match p.time_to_finish_ns {
                    Some(t) => Circle::new((x, seconds(t)), 6, SUCCEEDED.filled()),
                    // Not hidden for want of a height: a ring on the x axis.
                    None => Circle::new((x, scale.y.start), 6, SUCCEEDED.stroke_width(2)),
                }
            }))
            .map_err(show)?;
        chart
            .draw_series(self.points.iter().filter(|p| !p.succeeded).map(|p| {
                Cross::new(
                    (seconds(p.fault_at_ns), band_marks),
                    7,
                    FAILED.stroke_width(3),
                )
            }))
            .map_err(show)?;
        let small = TextStyle::from((FAMILY, 13).into_font())
            .color(&FAILED)
            .pos(Pos::new(HPos::Center, VPos::Center));
        for span in failure_spans(self) {
            let middle = (seconds(span.from_ns) + seconds(span.to_ns)) / 2.0;
            chart
                .draw_series(std::iter::once(Text::new(
                    span.states.join(", "),
                    (middle, band_states),
                    small.clone(),
                )))
                .map_err(show)?;
        }
        chart
            .draw_series(self.failed_points.iter().map(|p| {
                Circle::new(
                    (seconds(p.fault_at_ns), band_marks),
                    6,
                    NOT_RUN.stroke_width(2),
                )
            }))
            .map_err(show)?;
        root.present().map_err(show)
    }

    /// The legend's items: what each mark on the plot means.
    fn legend_items(&self) -> Vec<(Marker, String)> {
        let mut items = Vec::new();
        if let Some(recorded) = self.recorded_time_to_finish_ns {
            let verdict = if self.recorded_succeeded == Some(false) {
                "failed"
            } else {
                "finished"
            };
            items.push((
                Marker::Dashed,
                format!("recorded run: {verdict} in {}", format_seconds(recorded)),
            ));
        }
        items.push((Marker::Dot, "succeeded (at its time to finish)".to_owned()));
        if self
            .points
            .iter()
            .any(|p| p.succeeded && p.time_to_finish_ns.is_none())
        {
            items.push((Marker::Ring(SUCCEEDED), "succeeded, no time".to_owned()));
        }
        items.push((
            Marker::Cross,
            "failed (below: the state it struck in)".to_owned(),
        ));
        if !self.failed_points.is_empty() {
            items.push((Marker::Ring(NOT_RUN), "replay could not run".to_owned()));
        }
        items
    }
}

/// One item of the legend laid out: its mark, its text and the text's width in pixels.
type LegendItem = (Marker, String, i32);

const LEGEND_FONT: u32 = 15;
/// The room of a mark, the gap to its text, and the gap to the next item.
const MARKER: i32 = 24;
const GAP: i32 = 8;
const BETWEEN: i32 = 28;

/// `items` in rows as wide as the picture.
fn legend_rows(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    items: Vec<(Marker, String)>,
) -> Result<Vec<Vec<LegendItem>>, String> {
    let font = TextStyle::from((FAMILY, LEGEND_FONT).into_font());
    let room = WIDTH as i32 - 40;
    let mut rows: Vec<Vec<LegendItem>> = Vec::new();
    let mut used = 0;
    for (marker, label) in items {
        let (width, _) = root.estimate_text_size(&label, &font).map_err(show)?;
        let width = width as i32;
        let needed = MARKER + GAP + width;
        match rows.last_mut() {
            Some(row) if used + BETWEEN + needed <= room => {
                used += BETWEEN + needed;
                row.push((marker, label, width));
            }
            _ => {
                used = needed;
                rows.push(vec![(marker, label, width)]);
            }
        }
    }
    Ok(rows)
}

/// The legend, in rows of their own above the plot, where it hides no point; each row
/// centred.
fn draw_legend(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    rows: &[Vec<LegendItem>],
) -> Result<(), String> {
    let font =
        TextStyle::from((FAMILY, LEGEND_FONT).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (row_index, row) in rows.iter().enumerate() {
        let total: i32 = row.iter().map(|(_, _, w)| MARKER + GAP + w).sum::<i32>()
            + BETWEEN * (row.len() as i32 - 1);
        let mut x = (WIDTH as i32 - total) / 2;
        let y = LEGEND_ROW_PX as i32 * row_index as i32 + LEGEND_ROW_PX as i32 / 2;
        for (marker, label, width) in row {
            let middle = (x + MARKER / 2, y);
            match marker {
                Marker::Dashed => {
                    for dash in [x, x + 15] {
                        area.draw(&PathElement::new(
                            vec![(dash, y), (dash + 9, y)],
                            RECORDED.stroke_width(2),
                        ))
                        .map_err(show)?;
                    }
                }
                Marker::Dot => area
                    .draw(&Circle::new(middle, 6, SUCCEEDED.filled()))
                    .map_err(show)?,
                Marker::Cross => area
                    .draw(&Cross::new(middle, 6, FAILED.stroke_width(3)))
                    .map_err(show)?,
                Marker::Ring(color) => area
                    .draw(&Circle::new(middle, 6, color.stroke_width(2)))
                    .map_err(show)?,
            }
            area.draw_text(label, &font, (x + MARKER + GAP, y))
                .map_err(show)?;
            x += MARKER + GAP + width + BETWEEN;
        }
    }
    Ok(())
}

/// How a legend item is drawn.
enum Marker {
    Dashed,
    Dot,
    Cross,
    Ring(RGBColor),
}

/// A drawing error as text for [`SweepError::Draw`].
fn show(error: impl std::fmt::Display) -> String {
    error.to_string()
}

/// The axes' ranges, in seconds.
struct Scale {
    /// The fault times: the whole run.
    x: Range<f64>,
    /// The times to finish, with room around them.
    y: Range<f64>,
    /// Above `y`: the band where the failures are drawn.
    band: Range<f64>,
}

impl Scale {
    fn of(sweep: &Sweep) -> Self {
        let last_fault = sweep
            .points
            .iter()
            .map(|p| p.fault_at_ns)
            .chain(sweep.failed_points.iter().map(|p| p.fault_at_ns))
            .max()
            .unwrap_or(0);
        let x_end = seconds(sweep.duration_ns.max(last_fault)).max(1.0);

        let finishes: Vec<f64> = sweep
            .points
            .iter()
            .filter(|p| p.succeeded)
            .filter_map(|p| p.time_to_finish_ns)
            .chain(sweep.recorded_time_to_finish_ns)
            .map(seconds)
            .collect();
        let (low, high) = finishes
            .iter()
            .fold(None, |range: Option<(f64, f64)>, &t| match range {
                None => Some((t, t)),
                Some((low, high)) => Some((low.min(t), high.max(t))),
            })
            .unwrap_or((0.0, seconds(sweep.duration_ns)));
        // Room around the times to finish, so that a spread of a second is seen but a
        // single value is not blown up into noise.
        let pad = ((high - low) * 0.15).max(high * 0.05).max(1.0);
        let y = (low - pad).max(0.0).floor()..(high + pad).ceil();
        let band_height = (y.end - y.start) * 0.14;
        let band = y.end..y.end + band_height;
        Self {
            x: 0.0..x_end,
            y,
            band,
        }
    }
}

/// A tick's value without the noise of floating point (`0.30000000000000004`).
fn tick(value: f64) -> String {
    let text = format!("{value:.2}");
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// Nanoseconds as seconds, for drawing (the rounding does not matter there).
fn seconds(ns: i64) -> f64 {
    ns as f64 / 1e9
}

/// Registers the bundled font with plotters, once for the process.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::tests_support::sweep;

    #[test]
    fn the_same_sweep_gives_the_same_png_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let (first, second) = (dir.path().join("a.png"), dir.path().join("b.png"));
        sweep().write_png(&first).unwrap();
        sweep().write_png(&second).unwrap();
        let (first, second) = (
            std::fs::read(first).unwrap(),
            std::fs::read(second).unwrap(),
        );
        assert_eq!(first, second);
        assert!(first.starts_with(b"\x89PNG\r\n\x1a\n"));
        assert!(first.len() < 200_000, "{} bytes", first.len());
    }

    #[test]
    fn ticks_are_written_short() {
        assert_eq!(tick(90.0), "90");
        assert_eq!(tick(0.1 + 0.2), "0.3");
        assert_eq!(tick(2.5), "2.5");
        assert_eq!(tick(0.0), "0");
    }

    #[test]
    fn an_unwritable_path_is_named_in_the_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no-such-folder").join("sweep.png");
        let error = sweep().write_png(&path).unwrap_err();
        assert!(matches!(error, SweepError::Write { .. }), "{error:?}");
        let text = error.to_string();
        assert!(
            text.starts_with(&format!(
                "cannot write the sweep's plot {}: ",
                path.display()
            )),
            "{text}"
        );
    }
}
