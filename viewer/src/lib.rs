//! Lewis viewer: turns Lewis recordings (MCAP) into a Rerun recording that shows a run at a
//! glance, written to an .rrd file or sent to a Rerun viewer. The only crate that depends on
//! `rerun`; it reads MCAP through `lewis-mcap`, decodes with `lewis-interfaces`, and runs
//! nothing.
//!
//! Rerun opens MCAP files itself, but draws no laser scan, knows none of our interfaces
//! and nothing of a failover. Here every message is drawn on the recording's own time
//! (timelines `log_time`, the recorder's receive time, and `publish_time`, the sender's):
//! poses and paths and scans in a 2D world view and in the robot frame, camera images
//! with blobs and signs over them, broker decisions, health, log lines and commands as
//! text logs and state lanes, every numeric field as a plot, and any other decodable
//! message (foreign ROS 2 recordings too) as text. The entity tree is listed in the `draw`
//! module (`viewer/src/draw/mod.rs`).
//! A blueprint opens the viewer on that layout.
//!
//! The .rrd file depends only on the input: the same recording gives the same messages, byte
//! for byte (only the order of the manifests in Rerun's footer may differ).
//!
//! ```no_run
//! use lewis_viewer::{CameraFrames, Target, ViewOptions, view};
//!
//! let options = ViewOptions {
//!     target: Target::Save("run.rrd".into()),
//!     progress: false,
//!     camera: CameraFrames::ALL,
//! };
//! let report = view(&["run.mcap".into()], &options)?;
//! println!("{report}");
//! # Ok::<(), lewis_viewer::ViewError>(())
//! ```

mod blueprint;
mod decode;
mod draw;
mod error;
mod output;
pub mod picture;
mod report;
mod rows;
mod source;
mod world_map;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use indicatif::{ProgressBar, ProgressStyle};

pub use draw::Counts;
pub use error::ViewError;
pub use output::APPLICATION_ID;
pub use picture::{PictureReport, write_png};
pub use report::ViewReport;
pub use rows::{LOG_TIME, PUBLISH_TIME};
pub use world_map::MapStatus;

use decode::ChannelDecoder;
use output::Output;
use rows::Stamp;

/// The version of the Rerun SDK the .rrd files are written with.
pub const RERUN_VERSION: &str = "0.36.3";

/// The PyPI `rerun-sdk` version to install to open the files (`pip install rerun-sdk==...`):
/// the viewer of the same version as the SDK that wrote them.
pub const RERUN_SDK_PIP_VERSION: &str = RERUN_VERSION;

/// Where the Rerun recording goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// Written to this .rrd file (replaced if it exists).
    Save(PathBuf),
    /// Sent to a Rerun viewer started for it (the `rerun` binary on the PATH) listening on
    /// this port ([`DEFAULT_VIEWER_PORT`] usually), or to the viewer that already listens
    /// there.
    Spawn {
        /// The viewer's gRPC port.
        port: u16,
    },
    /// Sent to a running Rerun viewer at this gRPC address
    /// (`rerun+http://127.0.0.1:9876/proxy`).
    Connect(String),
}

/// How [`view`] works.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ViewOptions {
    /// Where the data goes.
    pub target: Target,
    /// Show a progress bar on standard error (only drawn on a terminal).
    pub progress: bool,
    /// Which camera frames go in, and how they are stored ([`CameraFrames::ALL`]: every
    /// frame as recorded).
    pub camera: CameraFrames,
}

/// Which camera frames a Rerun recording holds, and how: camera frames are most of a
/// recording's bytes, and stored raw most of a Rerun file's (a 640x480 rgb8 frame is 921
/// KB). Scans, poses and everything else are always whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CameraFrames {
    /// At most one frame per image topic in this much log time, ns (0: every frame).
    pub every_ns: u64,
    /// Stored JPEG-compressed at this quality (1 to 100), full size; `None`: the pixels as
    /// recorded.
    pub jpeg_quality: Option<u8>,
}

impl CameraFrames {
    /// Every frame, its pixels as recorded.
    pub const ALL: Self = Self {
        every_ns: 0,
        jpeg_quality: None,
    };
}

/// The port a Rerun viewer listens on for SDKs unless told otherwise.
pub const DEFAULT_VIEWER_PORT: u16 = 9876;

/// Whether an executable `rerun` is on the PATH, so that [`Target::Spawn`] can work.
#[must_use]
pub fn rerun_on_path() -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|dir| {
            std::fs::metadata(dir.join("rerun"))
                .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
        })
    })
}

/// The .rrd file next to `input`: `run.mcap` gives `run.rrd`.
#[must_use]
pub fn default_rrd_path(input: &Path) -> PathBuf {
    input.with_extension("rrd")
}

/// The Rerun recording id of a set of inputs: their file names, so that opening the same
/// run twice in one viewer shows one recording.
fn recording_id(inputs: &[PathBuf]) -> String {
    let names: Vec<String> = inputs
        .iter()
        .map(|p| {
            p.file_name().map_or_else(
                || p.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect();
    names.join("+")
}

/// Turns the recordings `inputs` (parts of one run, in order) into one Rerun recording.
///
/// # Errors
/// When an input cannot be read or is not MCAP, or the output cannot be written or
/// reached. A recording damaged part-way is shown up to the damage, which the report names.
pub fn view(inputs: &[PathBuf], options: &ViewOptions) -> Result<ViewReport, ViewError> {
    let recording_id = recording_id(inputs);
    // Check every input before creating anything.
    let mut total_bytes = 0;
    for input in inputs {
        let metadata = std::fs::metadata(input).map_err(|source| ViewError::Read {
            path: input.clone(),
            source,
        })?;
        total_bytes += metadata.len();
    }
    let mut output = match &options.target {
        Target::Save(path) => Output::file(path, &recording_id)?,
        Target::Spawn { port } => Output::spawn(&recording_id, *port)?,
        Target::Connect(address) => Output::connect(address, &recording_id)?,
    };
    let bar = if options.progress {
        let bar = ProgressBar::new(total_bytes);
        if let Ok(style) = ProgressStyle::with_template(
            "{msg} [{bar:30}] {bytes}/{total_bytes} ({bytes_per_sec}, {eta})",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar
    } else {
        ProgressBar::hidden()
    };

    let mut scene = draw::Scene::new(options.camera);
    blueprint::log_frames(scene.rows_mut(), &mut output)?;
    scene.start(&mut output)?;
    let mut damage = Vec::new();
    let mut map = None;
    let mut channels = 0;
    let mut done_bytes = 0;
    for input in inputs {
        bar.set_message(
            input
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        );
        let mut decoders: BTreeMap<u16, ChannelDecoder> = BTreeMap::new();
        let outcome = source::read_file(
            input,
            &mut |message| {
                let decoder = decoders
                    .entry(message.channel.id)
                    .or_insert_with(|| ChannelDecoder::new(message.channel));
                let decoded = decoder.decode(message.data);
                let stamp = Stamp {
                    log_time_ns: message.log_time_ns,
                    publish_time_ns: message.publish_time_ns,
                };
                scene.message(&mut output, message.channel, stamp, decoded)
            },
            &mut |bytes| bar.set_position(done_bytes + bytes),
        )?;
        channels += decoders.len();
        done_bytes += std::fs::metadata(input).map_or(0, |m| m.len());
        if let Some(reason) = outcome.damage {
            damage.push((input.clone(), reason));
        }
        if map.is_none()
            && let Some(world) = world_map::named_world(&outcome.metadata)
        {
            map = Some(match world_map::find(&world, input) {
                Ok(found) => {
                    world_map::log(scene.rows_mut(), &mut output, &found)?;
                    MapStatus::Drawn {
                        image: found.image,
                        width_px: found.width_px,
                        height_px: found.height_px,
                    }
                }
                Err(missing) => missing,
            });
        }
    }
    scene.finish(&mut output)?;
    bar.finish_and_clear();
    let plotted_topics = scene.plotted_topics();
    let (layout, activation) = blueprint::blueprint(
        &recording_id,
        &blueprint::Contents {
            camera: scene.has_images(),
            replay: scene.has_replay(),
            plotted_topics: &plotted_topics,
            world_bounds: scene.world_bounds(),
        },
    )?;
    output.finish(layout, activation)?;
    Ok(ViewReport {
        inputs: inputs.to_vec(),
        target: options.target.clone(),
        channels,
        counts: scene.counts,
        frames_skipped: scene.frames_skipped(),
        entities: scene.row_counts().clone(),
        failures: scene.failures.clone(),
        damage,
        map,
    })
}
