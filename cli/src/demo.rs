//! `lewis demo`: the simulated robot on the Robot Challenge, a fault on the way, the
//! recording re-simulated with another fault, and a few lines saying what happened
//! (`lewis_demo`).

use lewis_service::ServiceRegistry;
use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use lewis_demo::{DemoOptions, LiveFault};
use lewis_replay::fault::FaultSpec;
use lewis_runtime::ipc::Namespace;

/// Arguments of `lewis demo`.
#[derive(Debug, Args)]
#[command(
    long_about = "Runs the simulated robot (robots/sim.toml) on the Robot Challenge mission \
                  (robots/missions/challenge.seq) with the recorder on. When the first state \
                  (`door`) is over, the laser is killed again after every restart until the \
                  broker gives it up and moves its clients to the sonar. Then the mission's \
                  verdict, a replay of the recording with the laser stalled in the middle of \
                  the `sign` states, and the files written. Run it from the repository's root. \
                  Exits 0 when the mission succeeded, 1 when it failed."
)]
pub struct DemoArgs {
    /// The seed of the simulated devices (their noise, the people's timing); with --chaos,
    /// of the faults too (default 1).
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
    /// Do not serve the supervisor's page (else it is opened in the desktop's browser when
    /// there is a display, and its URL printed): after recovery the terminal is asked when
    /// the standard input is one, else nobody.
    #[arg(long)]
    pub no_gui: bool,
    /// The output folder: run.mcap, events.jsonl, replay.mcap, replay.json, run.rrd.
    #[arg(long, value_name = "DIR", default_value = lewis_demo::OUT_DIR)]
    pub out: PathBuf,
    /// Another live fault, in the `lewis replay --inject-fault` grammar with the time from
    /// the mission's start (`sonar@20s:crash`, `laser@30s:stall`; without a time, when the
    /// first state is over); `slow`, `stuck` and a host's loss only exist in a replay.
    #[arg(long, value_name = "SPEC", value_parser = parse_fault)]
    pub fault: Option<FaultSpec>,
    /// The supervisor page's port (0 picks a free one).
    #[arg(long, default_value_t = 8042)]
    pub gui_port: u16,
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Another mission script (for tests of the demo itself).
    #[arg(long, hide = true, default_value = lewis_demo::SCRIPT)]
    pub script: PathBuf,
    /// Another robot file (for tests of the demo itself).
    #[arg(long, hide = true, default_value = lewis_demo::ROBOT)]
    pub robot: PathBuf,
    /// Chaos: run the mission again and again, for --duration, while random providers are
    /// killed, stalled, frozen, garbled and put out of service at random times (drawn from
    /// --seed); report per mission and in total what the broker did, what was recorded and
    /// lost, and what the machine paid (memory, descriptors, shared memory, CPU). Writes
    /// chaos.json in --out (default logs/chaos) and keeps each failed mission's folder.
    #[arg(long)]
    pub chaos: bool,
    /// How long a chaos run lasts (`3m`, `1h`): the mission running then is stopped and
    /// not judged.
    #[arg(long, value_name = "TIME", default_value = "1h", value_parser = parse_duration, requires = "chaos")]
    pub duration: std::time::Duration,
    /// With --chaos: do not live each failed mission again to see whether the replay fails
    /// the same way.
    #[arg(long, requires = "chaos")]
    pub no_reproduce: bool,
    /// Run nothing: write the picture and the Rerun file of the demo already in --out
    /// (`scripts/demo.sh` runs the mission with a `lewis` built without the viewer first,
    /// for a quicker first run, and this after building the viewer).
    #[arg(long)]
    pub pictures_only: bool,
}

fn parse_duration(text: &str) -> Result<std::time::Duration, String> {
    lewis_stdx::parse_duration(text).map_err(|e| e.to_string())
}

fn parse_fault(text: &str) -> Result<FaultSpec, String> {
    text.parse()
        .map_err(|e: lewis_replay::fault::FaultError| e.to_string())
}

/// Runs `lewis demo`: exit 0 when the mission succeeded, 1 when it failed.
pub fn run(args: &DemoArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    if args.pictures_only {
        let files = lewis_demo::DemoFiles::in_dir(&args.out);
        anyhow::ensure!(
            files.run.is_file(),
            "{} not found: run `lewis demo` first",
            files.run.display()
        );
        write_pictures(&files, &mut std::io::stdout().lock())?;
        return Ok(ExitCode::SUCCESS);
    }
    if args.chaos {
        return run_chaos(args, registry);
    }
    let fault = match &args.fault {
        Some(spec) => LiveFault::from_spec(spec).map_err(anyhow::Error::msg)?,
        None => LiveFault::laser_after_first_state(),
    };
    let options = DemoOptions {
        robot: args.robot.clone(),
        script: args.script.clone(),
        seed: args.seed,
        no_gui: args.no_gui,
        gui_addr: SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), args.gui_port),
        out: args.out.clone(),
        fault,
        namespace: Namespace::from_arg(args.namespace.as_deref())?,
        lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
    };
    // The verdict as soon as the mission is over; the replay takes a minute more.
    let report = lewis_demo::run_demo(
        &options,
        registry,
        &crate::app::programs(),
        &mut |mission, fault| {
            let mut out = std::io::stdout().lock();
            let _ = write!(out, "\n{}", lewis_demo::mission_lines(mission, fault));
            let _ = writeln!(
                out,
                "replay: living the mission again with another fault..."
            );
            let _ = out.flush();
        },
    )?;
    let mut out = std::io::stdout().lock();
    write!(out, "{}", report.replay_summary())?;
    write_pictures(&report.files, &mut out)?;
    Ok(if report.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The camera frames in the demo's Rerun file: two a second, JPEG-compressed (`lewis view
/// --camera-every 500ms --camera-jpeg 80`); with every raw frame the file was 548 MB.
/// `lewis view logs/demo/run.mcap` shows them all.
#[cfg(feature = "viewer")]
const CAMERA_FRAMES: lewis_viewer::CameraFrames = lewis_viewer::CameraFrames {
    every_ns: 500_000_000,
    jpeg_quality: Some(80),
};

/// The run as a picture (PNG) and as a Rerun file, when this binary has the viewer.
#[cfg(feature = "viewer")]
fn write_pictures(files: &lewis_demo::DemoFiles, out: &mut dyn Write) -> anyhow::Result<()> {
    match lewis_viewer::write_png(&files.run, &files.png) {
        Ok(picture) => writeln!(out, "picture: {picture}")?,
        Err(e) => writeln!(out, "picture: none ({e})")?,
    }
    let options = lewis_viewer::ViewOptions {
        target: lewis_viewer::Target::Save(files.rrd.clone()),
        progress: false,
        camera: CAMERA_FRAMES,
    };
    match lewis_viewer::view(std::slice::from_ref(&files.run), &options) {
        Ok(_) => writeln!(
            out,
            "rerun: {} (open with `rerun {}`)",
            files.rrd.display(),
            files.rrd.display()
        )?,
        Err(e) => writeln!(out, "rerun: no file ({e})")?,
    }
    Ok(())
}

#[cfg(not(feature = "viewer"))]
fn write_pictures(_files: &lewis_demo::DemoFiles, out: &mut dyn Write) -> anyhow::Result<()> {
    writeln!(
        out,
        "picture and rerun: none (this lewis is built without the viewer: `lewis demo --pictures-only` with one built with it writes them)"
    )?;
    Ok(())
}

/// `lewis demo --chaos`: missions under random faults until `--duration` has passed; exit 0
/// when nothing was lost or left behind and every mission that failed had lost every
/// provider of something it needed.
fn run_chaos(args: &DemoArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        args.fault.is_none(),
        "--fault and --chaos do not go together: chaos draws its own faults"
    );
    let out = if args.out == std::path::Path::new(lewis_demo::OUT_DIR) {
        PathBuf::from(lewis_demo::chaos::OUT_DIR)
    } else {
        args.out.clone()
    };
    let options = lewis_demo::chaos::ChaosOptions {
        robot: args.robot.clone(),
        script: args.script.clone(),
        seed: args.seed.unwrap_or(1),
        duration: args.duration,
        out: out.clone(),
        lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
        sample_every: std::time::Duration::from_secs(5),
        reproduce: !args.no_reproduce,
    };
    {
        let mut out = std::io::stdout().lock();
        writeln!(
            out,
            "chaos: the Challenge again and again for {}, random faults from seed {}; results in {}",
            lewis_stdx::format_duration_ns(
                i64::try_from(args.duration.as_nanos()).unwrap_or(i64::MAX)
            ),
            options.seed,
            out_display(&options.out)
        )?;
        out.flush()?;
    }
    let report = lewis_demo::chaos::run_chaos(
        &options,
        registry,
        &crate::app::programs(),
        &mut |mission| {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{}", lewis_demo::chaos::mission_line(mission));
            let _ = out.flush();
        },
    )?;
    let mut stdout = std::io::stdout().lock();
    write!(stdout, "{}", report.summary())?;
    writeln!(stdout, "report: {}", out.join("chaos.json").display())?;
    let clean = report.lost() == 0
        && report.leftovers() == 0
        && !report
            .missions
            .iter()
            .any(lewis_demo::chaos::MissionResult::failed_with_providers_left);
    Ok(if clean {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn out_display(path: &std::path::Path) -> String {
    format!("{}/", path.display())
}
