//! `lewis view`: a recording in the Rerun viewer.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::bail;
use clap::Args;
use lewis_viewer::{
    CameraFrames, DEFAULT_VIEWER_PORT, RERUN_SDK_PIP_VERSION, Target, ViewOptions,
    default_rrd_path, rerun_on_path, view,
};

/// `lewis view RUN.mcap [more.mcap ...] [--save OUT.rrd | --spawn | --connect ADDR | --png OUT.png]`
#[derive(Debug, Args)]
#[command(
    long_about = "Shows a recording in the Rerun viewer: poses, paths and scans in the world \
                  and in the robot frame, camera images with blobs, broker decisions, health, \
                  logs, and every numeric field as a plot, on the recording's log_time and \
                  publish_time timelines. Without --save, --spawn or --connect it starts the \
                  `rerun` viewer when it is on the PATH, and otherwise writes RUN.rrd next to \
                  the first recording. With --png it draws the mission as one picture instead."
)]
pub struct ViewArgs {
    /// The recording; several files are parts of one run, in order (a rotated recording's
    /// parts index, `RUN.parts.json`, stands for its parts).
    #[arg(required = true, value_name = "RUN.mcap")]
    pub files: Vec<PathBuf>,
    /// Write a Rerun file (the same recording always gives the same file).
    #[arg(short = 'o', long = "save", value_name = "OUT.rrd", conflicts_with_all = ["spawn", "connect"])]
    pub save: Option<PathBuf>,
    /// Start the Rerun viewer (`rerun` on the PATH) and send the recording to it.
    #[arg(long, conflicts_with = "connect")]
    pub spawn: bool,
    /// Send the recording to a running Rerun viewer.
    #[arg(long, value_name = "ADDR", num_args = 0..=1,
          default_missing_value = "rerun+http://127.0.0.1:9876/proxy")]
    pub connect: Option<String>,
    /// The port of the viewer to start (or to reuse, when one listens there already).
    #[arg(long, default_value_t = DEFAULT_VIEWER_PORT, conflicts_with_all = ["save", "connect"])]
    pub port: u16,
    /// Instead, draw the mission as one picture: the world map, the path coloured by the
    /// sequencer's state, the signs seen, a cross where a service failed for good.
    #[arg(long, value_name = "OUT.png", conflicts_with_all = ["save", "spawn", "connect"])]
    pub png: Option<PathBuf>,
    /// Show at most one camera frame per camera in this much time (`1s`, `500ms`; default:
    /// every frame). Camera frames are most of a Rerun file's bytes; scans, poses and the
    /// rest are always whole.
    #[arg(long, value_name = "DURATION", value_parser = parse_every, conflicts_with = "png")]
    pub camera_every: Option<u64>,
    /// Store camera frames JPEG-compressed at this quality (1 to 100), full size, instead of
    /// their pixels as recorded: a tenth of the bytes or less.
    #[arg(long, value_name = "QUALITY", value_parser = clap::value_parser!(u8).range(1..=100),
          conflicts_with = "png")]
    pub camera_jpeg: Option<u8>,
}

fn parse_every(text: &str) -> Result<u64, String> {
    let ns = lewis_stdx::parse_duration_ns(text).map_err(|e| e.to_string())?;
    Ok(u64::try_from(ns).unwrap_or(0))
}

impl ViewArgs {
    /// The camera frames asked for (`--camera-every`, `--camera-jpeg`).
    #[must_use]
    pub fn camera(&self) -> CameraFrames {
        CameraFrames {
            every_ns: self.camera_every.unwrap_or(0),
            jpeg_quality: self.camera_jpeg,
        }
    }
}

/// Where the recording goes, and whether it is the default file (so that the user is told
/// how to open it): `--save`, `--connect`, `--spawn` as asked; without any, a viewer when
/// `rerun` is on the PATH (`rerun_found`), else `RUN.rrd` next to the first recording (`files`, the
/// inputs with parts indexes expanded).
fn target(args: &ViewArgs, files: &[PathBuf], rerun_found: bool) -> anyhow::Result<(Target, bool)> {
    Ok(if let Some(path) = &args.save {
        (Target::Save(path.clone()), false)
    } else if let Some(address) = &args.connect {
        (Target::Connect(address.clone()), false)
    } else if args.spawn || rerun_found {
        (Target::Spawn { port: args.port }, false)
    } else {
        let Some(first) = files.first() else {
            bail!("no recording given");
        };
        (Target::Save(default_rrd_path(first)), true)
    })
}

/// How to open `rrd` when no viewer was found.
fn open_hint(rrd: &Path) -> String {
    format!(
        "no `rerun` viewer on the PATH: install it with `pip install rerun-sdk=={RERUN_SDK_PIP_VERSION}`, \
         then run `rerun {}`",
        rrd.display()
    )
}

/// Converts and reports; a recording with undecodable messages or damage still exits 0
/// (what could be shown was shown, and the report says what was not).
pub fn run(args: &ViewArgs) -> anyhow::Result<ExitCode> {
    let files = lewis_recording::expand_inputs(&args.files)?;
    if let Some(png) = &args.png {
        let [file] = files.as_slice() else {
            bail!("--png draws one recording, not {} files", files.len());
        };
        let report = lewis_viewer::write_png(file, png)?;
        writeln!(std::io::stdout().lock(), "{report}")?;
        return Ok(ExitCode::SUCCESS);
    }
    let (target, hint) = target(args, &files, rerun_on_path())?;
    let options = ViewOptions {
        target: target.clone(),
        progress: true,
        camera: args.camera(),
    };
    let report = view(&files, &options)?;
    let mut out = std::io::stdout().lock();
    write!(out, "{report}")?;
    if hint && let Target::Save(path) = &target {
        writeln!(out, "{}", open_hint(path))?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Command {
        #[command(flatten)]
        view: ViewArgs,
    }

    fn decide(args: &[&str], rerun_found: bool) -> (Target, bool) {
        let command = Command::try_parse_from(std::iter::once("view").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{args:?}: {e}"));
        target(&command.view, &command.view.files, rerun_found)
            .unwrap_or_else(|e| panic!("{args:?}: {e}"))
    }

    #[test]
    fn the_target_follows_the_flags_then_the_path() {
        let spawn = |port| Target::Spawn { port };
        let save = |p: &str| Target::Save(p.into());
        assert_eq!(decide(&["r.mcap"], true), (spawn(9876), false));
        assert_eq!(
            decide(&["r.mcap", "--port", "9000"], true),
            (spawn(9000), false)
        );
        assert_eq!(decide(&["logs/r.mcap"], false), (save("logs/r.rrd"), true));
        assert_eq!(decide(&["r.mcap", "--spawn"], false), (spawn(9876), false));
        assert_eq!(
            decide(&["r.mcap", "--save", "o.rrd"], true),
            (save("o.rrd"), false)
        );
        assert_eq!(
            decide(&["r.mcap", "--connect"], true),
            (
                Target::Connect("rerun+http://127.0.0.1:9876/proxy".into()),
                false
            )
        );
        assert!(
            Command::try_parse_from(["view", "r.mcap", "--save", "o.rrd", "--port", "1"]).is_err()
        );
        assert!(
            Command::try_parse_from(["view", "r.mcap", "--save", "o.rrd", "--png", "o.png"])
                .is_err()
        );
    }

    #[test]
    fn the_hint_says_which_version_to_install_and_how_to_open_the_file() {
        assert_eq!(
            open_hint(Path::new("logs/run.rrd")),
            "no `rerun` viewer on the PATH: install it with `pip install rerun-sdk==0.36.3`, \
             then run `rerun logs/run.rrd`"
        );
    }
}
