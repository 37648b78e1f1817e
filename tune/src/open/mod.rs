//! `lewis tune open RUN.mcap|IMAGES --colors FILE`: the tuning page. A small HTTP server on
//! 127.0.0.1 (`lewis-pages`, as the supervisor's page) serves one page (`page.html`, compiled
//! in) that only draws: the frames with their classified pixels and blobs, the class
//! ranges as sliders, pixels marked on the frame, and per-class plots over the whole
//! recording. Every computation is done here, in Rust, with the live CMVision code
//! (`lewis_perception::sweep`). Boxes drawn around the true objects are held here as
//! labels, saved to the labels file `lewis tune check` reads, and scored live
//! (`labelling.rs`).
//!
//! Frames are read once, in a background thread (the page shows the first as soon as it
//! is read), and held 2x2-decimated under `--max-memory-mb` (see
//! `lewis_perception::sweep::FrameStore`): a quarter of the bytes, so a 5-minute recording
//! at 5 Hz of 640x480 frames takes 350 MB, and one past the bound is thinned evenly.

mod labelling;
mod render;
mod routes;
mod state;

use std::net::{Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::Context as _;
use clap::Args;
use lewis_pages::PageServer;
use lewis_perception::ColorConfig;
use lewis_perception::sweep::HeldFrame;

use crate::frames::Input;
use state::State;

/// Arguments of `lewis tune open`.
#[derive(Debug, Args)]
pub struct OpenArgs {
    /// An MCAP recording with ImageSource messages, or a folder or glob of PNG/JPEG files.
    pub input: String,
    /// The colour file to start from (Player's format, or TOML when it ends in .toml).
    #[arg(long)]
    pub colors: PathBuf,
    /// Where the page's Save writes the colour file (Player's format; default: the colour
    /// file's name with `.tuned.txt`, in the current folder).
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    /// The labels file (JSON, as `lewis tune check --labels` reads it): read at the start
    /// when it exists, its boxes shown and scored; the page's "Save labels" writes it
    /// (default: beside the input, `RUN.labels.json` for `RUN.mcap`, `labels.json` in a
    /// folder of images or, for a glob, in the current folder).
    #[arg(long, value_name = "FILE.json")]
    pub labels: Option<PathBuf>,
    /// Only this image topic of the recording (default: every ImageSource topic).
    #[arg(long)]
    pub channel: Option<String>,
    /// The port to serve on, on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = 8044)]
    pub port: u16,
    /// Do not open the page in the desktop's browser; only print its address.
    #[arg(long)]
    pub no_browser: bool,
    /// Also run the sign detector on the frame shown, with the classes being tuned (its
    /// board and arrow are the `White` and `Black` classes): its boards are drawn in white.
    #[arg(long)]
    pub signs: bool,
    /// The most memory the held frames take, in MB (beyond it the recording is thinned).
    #[arg(long, default_value_t = 512)]
    pub max_memory_mb: usize,
}

/// The tuning page being served, its frames being read in the background.
pub struct TuningPage {
    server: PageServer,
    url: String,
    labels_line: String,
}

impl std::fmt::Debug for TuningPage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TuningPage")
            .field("url", &self.url)
            .field("labels_line", &self.labels_line)
            .finish_non_exhaustive()
    }
}

impl TuningPage {
    /// The page's address (`http://127.0.0.1:PORT/`): how a script (and the browser test)
    /// finds the page.
    #[must_use]
    pub fn url(&self) -> &str {
        &self.url
    }

    /// What the page starts with for labels, and where "Save labels" writes (`labels: 3
    /// labelled frames read from RUN.labels.json ("Save labels" writes it)`).
    #[must_use]
    pub fn labels_line(&self) -> &str {
        &self.labels_line
    }

    /// Opens the page in the desktop's browser, when there is one; the address is printed
    /// either way.
    pub fn open_browser(&self) {
        let spawned = std::process::Command::new("xdg-open")
            .arg(&self.url)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn();
        if let Err(e) = spawned {
            tracing::info!("no browser opened ({e}): open {} yourself", self.url);
        }
    }

    /// Serves the page until the process is interrupted.
    pub fn wait(self) {
        self.server.wait();
    }
}

/// Starts `lewis tune open`: the page served on 127.0.0.1, the frames being read into it
/// in the background. [`TuningPage::wait`] serves it until interrupted.
///
/// # Errors
/// When the inputs cannot be read or the port cannot be bound.
pub fn open(args: &OpenArgs) -> anyhow::Result<TuningPage> {
    let config = ColorConfig::load(&args.colors)?;
    anyhow::ensure!(
        config.colors.len() <= lewis_perception::cmvision::MAX_COLORS,
        "{}: too many colour classes",
        args.colors.display()
    );
    let input = Input::open(&args.input, args.channel.as_deref())?;
    let labels_path = args
        .labels
        .clone()
        .unwrap_or_else(|| labelling::default_labels_path(&args.input));
    // Read (and refused) now, before the page opens: the same parser as `tune check`.
    let (labels, existed) = labelling::start_labels(&labels_path, &config, &args.input)?;
    let save = args.save.clone().unwrap_or_else(|| {
        let stem = args
            .colors
            .file_stem()
            .map_or_else(|| "colors".to_owned(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}.tuned.txt"))
    });
    if args.signs {
        // Refused now rather than on every frame: the classes the detector needs.
        lewis_perception::sign_detector::Params::default()
            .finder_with(&config)
            .with_context(|| format!("--signs with {}", args.colors.display()))?;
    }
    let mut state = State::new(
        args.input.clone(),
        args.colors.clone(),
        save,
        config,
        args.max_memory_mb.saturating_mul(1 << 20),
    );
    state.signs = args.signs;
    let labels_line = if existed {
        format!(
            "labels: {} labelled frames read from {} (\"Save labels\" writes it)",
            labels.frames.len(),
            labels_path.display()
        )
    } else {
        format!(
            "labels: none yet; \"Save labels\" writes {}",
            labels_path.display()
        )
    };
    state.labels = labels;
    state.labels_path = labels_path;
    let state = Arc::new(Mutex::new(state));
    let bind = SocketAddr::from((Ipv4Addr::LOCALHOST, args.port));
    let server = PageServer::start("lewis-tune-page", bind, routes::router(Arc::clone(&state)))
        .context("the tuning page")?;
    let url = server.url();
    {
        let state = Arc::clone(&state);
        std::thread::Builder::new()
            .name("lewis-tune-load".into())
            .spawn(move || load(&input, &state))
            .context("cannot start reading the frames")?;
    }
    Ok(TuningPage {
        server,
        url,
        labels_line,
    })
}

/// Reads every frame into the state's store, then marks the loading done.
fn load(input: &Input, state: &Mutex<State>) {
    let result = (|| -> anyhow::Result<()> {
        for frame in input.frames()? {
            let frame = frame?;
            let rgb = match lewis_perception::tuning::rgb_image(&frame.image) {
                Ok(rgb) => rgb,
                Err(e) => {
                    tracing::warn!("{}: {e}: skipped", frame.name);
                    continue;
                }
            };
            let full_size = [rgb.width(), rgb.height()];
            let held = HeldFrame::decimate(
                frame.name,
                frame.log_time_ns,
                rgb.width(),
                rgb.height(),
                rgb.as_raw(),
            )?;
            state::lock(state).add_frame(held, full_size);
        }
        Ok(())
    })();
    let mut state = state::lock(state);
    if let Err(e) = result {
        tracing::error!("reading the frames stopped: {e:#}");
        state.load_error = Some(format!("{e:#}"));
    }
    state.loading = false;
}
