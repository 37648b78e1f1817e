//! `lewis world from RUN -o DIR` and `lewis world check RUN DIR`: a simulator world rebuilt
//! from a real run's laser scans, and how faithfully it makes them again.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lewis_rebuild::check::{CLOSE_M, NEAR_M};
use lewis_rebuild::{
    BuildOptions, CheckReport, Figures, Run, build, check, plots, read_run, world_dir,
};

/// What `lewis world` does.
#[derive(Debug, Subcommand)]
pub enum WorldCommand {
    /// Build a world (the simulator's format: world.toml and map.png) from a run's laser
    /// scans: a Lewis recording, a CARMEN log or a ROS 2 bag.
    From(FromArgs),
    /// Make a run's scans again in a rebuilt world and compare them beam by beam.
    Check(CheckArgs),
}

/// Arguments of `lewis world from`.
#[derive(Debug, Args)]
#[command(
    after_help = "Poses: the run's own (the simulator's ground truth, odometry; a CARMEN corrected log's odometry is its corrected trajectory), corrected by matching each scan against the map built so far; without odometry, scan matching alone. Cells seen occupied in under a quarter of their looks (people walking by) are left out.\n\nWrites DIR/world.toml and map.png (what `lewis up` loads as a world), trajectory.csv (every scan's pose), moving.png (the cells left out) and rebuild.png (the map, the recorded path in blue, the matched path in red, scans the matcher could not place in orange).\n\nExit codes: 0 built; 2 the run could not be mapped."
)]
pub struct FromArgs {
    /// The run: a Lewis recording (.mcap), a CARMEN log (.log or .log.gz) or a ROS 2 bag
    /// (.mcap).
    #[arg(value_name = "RUN")]
    pub run: PathBuf,
    /// The world folder to write (created if missing).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// The side of a map pixel, in m.
    #[arg(long, default_value_t = 0.05, value_name = "M")]
    pub metres_per_pixel: f64,
    /// Build from every other scan only, so that `lewis world check` measures the world on
    /// scans it was not built from.
    #[arg(long)]
    pub hold_out: bool,
    /// Take the recorded poses as they are: no scan matching where the run has poses.
    #[arg(long)]
    pub no_scan_matching: bool,
}

/// Arguments of `lewis world check`.
#[derive(Debug, Args)]
#[command(
    after_help = "Each scan is ray cast in the world by the simulator at the pose DIR/trajectory.csv gives it, and each beam that returned is compared with the laser's reading. The goal: median error under 5 cm and 90% of beams within 20 cm, on scans the world was not built from (build with --hold-out); the scans it was built from are reported beside them. Writes DIR/check-time.png (the error over the run) and DIR/check-map.png (where it lies: green within 5 cm, yellow within 20 cm, red beyond).\n\nExit codes: 0 the goal is met; 1 it is not; 2 the check could not run."
)]
pub struct CheckArgs {
    /// The run the world was built from.
    #[arg(value_name = "RUN")]
    pub run: PathBuf,
    /// The world folder (`lewis world from -o DIR`).
    #[arg(value_name = "DIR")]
    pub world: PathBuf,
    /// Parts the run is cut into for the figures over time.
    #[arg(long, default_value_t = 10, value_name = "N")]
    pub parts: usize,
}

/// Runs `lewis world`.
///
/// # Errors
/// When the run cannot be read or mapped, or the world cannot be written or loaded.
pub fn run(command: &WorldCommand) -> anyhow::Result<ExitCode> {
    match command {
        WorldCommand::From(args) => from(args),
        WorldCommand::Check(args) => check_world(args),
    }
}

fn spinner(what: &str) -> Option<ProgressBar> {
    std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new_spinner();
        bar.set_style(
            ProgressStyle::with_template(&format!("{what} {{spinner}} {{msg}} ({{elapsed}})"))
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
        bar
    })
}

fn read(path: &Path) -> anyhow::Result<Run> {
    let bar = spinner("reading");
    let run = read_run(path);
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    Ok(run?)
}

fn from(args: &FromArgs) -> anyhow::Result<ExitCode> {
    let run = read(&args.run)?;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "read {} ({}): {} scans of {} over {:.1} s{}",
        run.path.display(),
        run.format,
        run.scans.len(),
        run.laser,
        run.duration_s(),
        if run.non_uniform > 0 {
            format!(" ({} uneven scans left out)", run.non_uniform)
        } else {
            String::new()
        }
    );
    std::io::stdout().lock().write_all(t.as_bytes())?;
    let options = BuildOptions {
        metres_per_cell: args.metres_per_pixel,
        hold_out: args.hold_out,
        match_scans: !args.no_scan_matching,
        ..BuildOptions::default()
    };
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(run.scans.len() as u64);
        bar.set_style(
            ProgressStyle::with_template("building {bar:40} {pos}/{len} scans ({elapsed})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let started = Instant::now();
    let built = build(&run, &options, &mut |n| {
        if let Some(bar) = &bar {
            bar.set_position(n as u64);
        }
    });
    let seconds = started.elapsed().as_secs_f64();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let built = built?;
    let written = world_dir::write(&args.output, &run, &built)
        .with_context(|| format!("writing the world into {}", args.output.display()))?;
    let r = &built.report;
    let mut t = String::new();
    let _ = writeln!(t, "poses: {}", r.poses);
    let _ = writeln!(
        t,
        "scan matcher: placed {} of {} scans; correction a step median {:.1} cm {:.2} deg, largest {:.1} cm {:.2} deg{}",
        r.matched,
        r.scans.saturating_sub(1),
        r.step_correction_m.0 * 100.0,
        r.step_correction_rad.0.to_degrees(),
        r.step_correction_m.1 * 100.0,
        r.step_correction_rad.1.to_degrees(),
        r.drift_m
            .map(|d| format!("; up to {d:.2} m from the recorded path"))
            .unwrap_or_default()
    );
    let _ = writeln!(
        t,
        "map: {} x {} px at {} m ({:.1} x {:.1} m) from {} scans{}; {} wall cells, {} cells of things that moved left out",
        written.size_px.0,
        written.size_px.1,
        args.metres_per_pixel,
        written.size_m.0,
        written.size_m.1,
        r.used,
        if args.hold_out {
            " (every other: --hold-out)"
        } else {
            ""
        },
        r.occupied_cells,
        r.left_out_cells
    );
    let pace = if seconds > 0.0 {
        format!("{:.0}x the run's time", run.duration_s() / seconds)
    } else {
        "instant".to_owned()
    };
    let _ = writeln!(
        t,
        "built in {seconds:.2} s ({pace}); grid {:.1} MiB",
        r.grid_bytes as f64 / (1024.0 * 1024.0)
    );
    let _ = writeln!(
        t,
        "wrote {}: {}, {}, {}, {}, {}",
        written.dir.display(),
        world_dir::WORLD_TOML,
        world_dir::MAP_PNG,
        world_dir::TRAJECTORY_CSV,
        world_dir::MOVING_PNG,
        world_dir::PICTURE_PNG
    );
    std::io::stdout().lock().write_all(t.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

fn figures_line(what: &str, scans: usize, f: &Figures) -> String {
    format!(
        "{what} ({scans} scans, {} beams): median {:.1} cm, p90 {:.1} cm, {:.1}% within {:.0} cm, {:.1}% within {:.0} cm: {}",
        f.beams,
        f.median_m * 100.0,
        f.p90_m * 100.0,
        f.within_close * 100.0,
        CLOSE_M * 100.0,
        f.within_near * 100.0,
        NEAR_M * 100.0,
        if f.meets_goal() {
            "meets the goal"
        } else {
            "misses the goal (median under 5 cm, 90% within 20 cm)"
        }
    )
}

fn check_world(args: &CheckArgs) -> anyhow::Result<ExitCode> {
    let run = read(&args.run)?;
    let bar = spinner("ray casting");
    let checked = check(&run, &args.world, args.parts);
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let (report, errors) = checked?;
    let placed = world_dir::read_trajectory(&args.world)?;
    let used = placed.iter().filter(|p| p.used).count();
    let text = check_text(&report, placed.len() - used, used);
    let time_png = args.world.join("check-time.png");
    let map_png = args.world.join("check-map.png");
    plots::write_time_plot(&report, &time_png)?;
    let world = lewis_sim::world::World::load(&args.world)?;
    plots::write_error_map(&world, &errors, &map_png)?;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    writeln!(
        out,
        "wrote {} and {}",
        time_png.display(),
        map_png.display()
    )?;
    Ok(if report.counting().meets_goal() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn check_text(report: &CheckReport, held_scans: usize, used_scans: usize) -> String {
    let mut t = String::new();
    match &report.held_out {
        Some(f) => {
            let _ = writeln!(t, "{}", figures_line("held out", held_scans, f));
        }
        None => {
            let _ = writeln!(
                t,
                "no held-out scans: build with `lewis world from --hold-out` to measure the world on scans it was not built from"
            );
        }
    }
    let _ = writeln!(
        t,
        "{}",
        figures_line("built from", used_scans, &report.used)
    );
    let _ = writeln!(
        t,
        "not compared: {} beams without a return, {} beams ending on things that moved",
        report.no_return_beams, report.moving_beams
    );
    let held = report.held_out.is_some();
    let far = report.far_off.beyond + report.far_off.short;
    if far > 0 {
        let _ = writeln!(
            t,
            "beams off by more than 20 cm{}: {} ({:.0}%) went on beyond the reading (holes: walls seen too sparsely, or things the map leaves out), {} stopped short of it (walls the laser did not see there)",
            if held { " (held out)" } else { "" },
            report.far_off.beyond,
            100.0 * report.far_off.beyond as f64 / far as f64,
            report.far_off.short
        );
    }
    for part in report.poor_parts() {
        let f = if held { &part.held_out } else { &part.used };
        let _ = writeln!(
            t,
            "poor fidelity {:.0}-{:.0} s, around ({:.1}, {:.1}) m: median {:.1} cm, {:.1}% within 20 cm",
            part.from_s,
            part.to_s,
            part.centre.x,
            part.centre.y,
            f.median_m * 100.0,
            f.within_near * 100.0
        );
    }
    t
}
