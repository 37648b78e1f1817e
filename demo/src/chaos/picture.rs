//! The chaos run as a picture (PNG): across, the minutes of the run, each mission a band
//! (green when it succeeded, red when it failed); down, three panels: the memory (PSS)
//! of the biggest processes, the run's open descriptors, and the machine's entries in
//! shared memory. A leak is a line that climbs from band to band.

use std::path::Path;

use lewis_images::plot::{FAMILY, ensure_font, rgb_png};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::ChaosReport;

const WIDTH: u32 = 1100;
const HEIGHT: u32 = 860;
const TITLE_PX: u32 = 44;

const SUCCEEDED: RGBColor = RGBColor(0x1a, 0x96, 0x41);
const FAILED: RGBColor = RGBColor(0xd7, 0x19, 0x1c);
/// Colour-blind-safe lines (Okabe and Ito).
const LINES: [RGBColor; 7] = [
    RGBColor(0x00, 0x72, 0xb2),
    RGBColor(0xe6, 0x9f, 0x00),
    RGBColor(0x00, 0x9e, 0x73),
    RGBColor(0xcc, 0x79, 0xa7),
    RGBColor(0x56, 0xb4, 0xe9),
    RGBColor(0xd5, 0x5e, 0x00),
    RGBColor(0x40, 0x40, 0x40),
];

/// How many processes the memory panel draws (the biggest at their peak).
const PROCESSES_DRAWN: usize = 7;

type Series = (String, RGBColor, Vec<(f64, f64)>);

/// Writes the picture of `report` at `path` (replacing it).
///
/// # Errors
/// When it cannot be drawn, encoded or written; the message names `path`.
pub fn write_png(report: &ChaosReport, path: &Path) -> Result<(), String> {
    let named = |e: String| format!("cannot draw {}: {e}", path.display());
    ensure_font().map_err(named)?;
    let mut pixels = vec![0_u8; (WIDTH * HEIGHT * 3) as usize];
    draw(report, &mut pixels).map_err(named)?;
    let png = rgb_png(&pixels, WIDTH, HEIGHT).map_err(|e| named(e.to_string()))?;
    std::fs::write(path, png).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

fn draw(report: &ChaosReport, pixels: &mut [u8]) -> Result<(), String> {
    let root = BitMapBackend::with_buffer(pixels, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE).map_err(show)?;
    let (title, body) = root.split_vertically(TITLE_PX);
    title
        .draw_text(
            &format!(
                "Chaos, seed {}: {} of {} missions succeeded, {} messages lost, {} entries left in shared memory",
                report.seed,
                report.succeeded(),
                report.judged(),
                report.lost(),
                report.leftovers()
            ),
            &TextStyle::from((FAMILY, 20).into_font())
                .pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Center,
                    plotters::style::text_anchor::VPos::Center,
                )),
            (WIDTH as i32 / 2, TITLE_PX as i32 / 2 + 4),
        )
        .map_err(show)?;
    let panels = body.split_evenly((3, 1));
    let minutes = |t_s: f64| t_s / 60.0;
    let end = report
        .samples
        .last()
        .map_or(1.0, |s| minutes(s.t_s))
        .max(0.1);

    // The biggest processes at their peak, memory in MiB.
    let mut names: Vec<(u64, &String)> = report
        .memory
        .iter()
        .map(|m| (m.first_kib.max(m.last_kib), &m.name))
        .collect();
    names.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(b.1)));
    let memory: Vec<Series> = names
        .iter()
        .take(PROCESSES_DRAWN)
        .zip(LINES)
        .map(|((_, name), colour)| {
            let points = report
                .samples
                .iter()
                .filter_map(|s| Some((minutes(s.t_s), *s.pss_kib.get(*name)? as f64 / 1024.0)))
                .collect();
            ((*name).clone(), colour, points)
        })
        .collect();
    let fds: Vec<Series> = vec![(
        "open descriptors (all processes)".to_owned(),
        LINES[0],
        report
            .samples
            .iter()
            .map(|s| (minutes(s.t_s), s.fds as f64))
            .collect(),
    )];
    let shm: Vec<Series> = vec![(
        "entries in /dev/shm and /tmp/iceoryx2".to_owned(),
        LINES[5],
        report
            .samples
            .iter()
            .map(|s| (minutes(s.t_s), s.shm_entries as f64))
            .collect(),
    )];
    let bands = mission_bands(report, &minutes);
    panel(&panels[0], "memory, PSS (MiB)", &memory, &bands, end)?;
    panel(&panels[1], "open descriptors", &fds, &bands, end)?;
    panel(&panels[2], "shared-memory entries", &shm, &bands, end)?;
    root.present().map_err(show)
}

/// Each mission's span on the run's clock (minutes) and whether it succeeded.
fn mission_bands(report: &ChaosReport, minutes: &dyn Fn(f64) -> f64) -> Vec<(f64, f64, bool)> {
    report
        .missions
        .iter()
        .enumerate()
        .filter_map(|(i, m)| {
            let index = u32::try_from(i).ok()?;
            let times: Vec<f64> = report
                .samples
                .iter()
                .filter(|s| s.mission == index)
                .map(|s| minutes(s.t_s))
                .collect();
            let from = times.iter().copied().fold(f64::INFINITY, f64::min);
            let to = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            (from <= to && !m.cut_short).then_some((from, to, m.succeeded))
        })
        .collect()
}

fn panel(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    y_desc: &str,
    series: &[Series],
    bands: &[(f64, f64, bool)],
    end: f64,
) -> Result<(), String> {
    let top = series
        .iter()
        .flat_map(|(_, _, points)| points.iter().map(|p| p.1))
        .fold(0.0_f64, f64::max)
        .max(1.0)
        * 1.15;
    let mut chart = ChartBuilder::on(area)
        .margin_left(16)
        .margin_right(32)
        .margin_top(10)
        .margin_bottom(6)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..end, 0.0..top)
        .map_err(show)?;
    chart
        .configure_mesh()
        .x_desc("minutes from the start of the run")
        .y_desc(y_desc)
        .axis_desc_style((FAMILY, 15))
        .label_style((FAMILY, 13))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(show)?;
    chart
        .draw_series(bands.iter().map(|&(from, to, succeeded)| {
            let colour = if succeeded { SUCCEEDED } else { FAILED };
            Rectangle::new([(from, 0.0), (to, top)], colour.mix(0.08).filled())
        }))
        .map_err(show)?;
    for (name, colour, points) in series {
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                colour.stroke_width(2),
            ))
            .map_err(show)?
            .label(name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(3))
            });
    }
    chart
        .configure_series_labels()
        .label_font((FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.2))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(show)?;
    Ok(())
}

fn show(e: impl std::fmt::Display) -> String {
    e.to_string()
}

#[cfg(test)]
mod tests {
    use super::super::resources::UseSample;
    use super::super::striker::BrokerCounts;
    use super::super::{ChaosReport, MemoryTrend, MissionResult};
    use super::*;

    fn report() -> ChaosReport {
        let mission = |number: u32, succeeded: bool| MissionResult {
            number,
            device_seed: 1,
            succeeded,
            cut_short: false,
            reason: String::new(),
            states: Vec::new(),
            duration_s: 100.0,
            faults: Vec::new(),
            broker: BrokerCounts::default(),
            recorded: 1000,
            lost: 0,
            leftovers: 0,
            kept: None,
            replay_command: None,
            replay_fails_too: None,
            replay_error: None,
        };
        let samples = (0..40)
            .map(|i| UseSample {
                t_s: f64::from(i) * 5.0,
                mission: i / 20,
                pss_kib: [("laser".to_owned(), 100_000 + u64::from(i) * 100)].into(),
                fds: 500,
                shm_entries: 3000,
                cpu_percent: Some(40.0),
            })
            .collect();
        ChaosReport {
            seed: 1,
            ran_s: 200.0,
            missions: vec![mission(1, true), mission(2, false)],
            samples,
            memory: vec![MemoryTrend {
                name: "laser".to_owned(),
                first_kib: 101_900,
                last_kib: 103_900,
                kib_per_mission: Some(2_000.0),
            }],
            fds_per_mission: Some(0.0),
            shm_entries_per_mission: Some(0.0),
            mean_cpu_percent: 40.0,
        }
    }

    #[test]
    fn the_same_report_gives_the_same_png() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
        write_png(&report(), &a).unwrap();
        write_png(&report(), &b).unwrap();
        let bytes = std::fs::read(&a).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"));
        assert_eq!(bytes, std::fs::read(&b).unwrap());
        let missing = dir.path().join("no/such/folder/c.png");
        assert!(
            write_png(&report(), &missing)
                .unwrap_err()
                .contains("no/such/folder")
        );
    }
}
