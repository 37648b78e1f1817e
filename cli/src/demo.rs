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
    /// The seed of the simulated devices (their noise, the people's timing).
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
    /// first state is over); `garbage` only exists in a replay.
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
    /// Run nothing: write the picture and the Rerun file of the demo already in --out
    /// (`scripts/demo.sh` runs the mission with a `lewis` built without the viewer first,
    /// for a quicker first run, and this after building the viewer).
    #[arg(long)]
    pub pictures_only: bool,
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
