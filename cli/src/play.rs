//! `lewis play RUN.mcap`: a recording published into live IPC at its recorded pace, with
//! pause and step from the keyboard when stdin is a terminal.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::os::fd::{AsFd, BorrowedFd};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lewis_recording::play::{
    Controls, NoControls, PlayCommand, PlayOptions, PlayReport, Status, play,
};
use lewis_runtime::ipc::Ipc;
use lewis_runtime::live::StopSignals;
use nix::sys::termios::{self, SetArg, Termios};

use lewis_runtime::ipc::Namespace;

/// Arguments of `lewis play`.
#[derive(Debug, Args)]
#[command(
    after_help = "Keys, when stdin is a terminal: space pauses and resumes, `s` \
    publishes the next message (pausing first), `q` quits. The playback time is published \
    on /lewis/clock (interface Clock) unless --no-clock.\n\nExit codes: 0 played to the \
    end or stopped; 2 the recording could not be played."
)]
pub struct PlayArgs {
    /// The recording (several files, or a parts index `RUN.parts.json`, are one run).
    #[arg(required = true, value_name = "RUN.mcap")]
    pub inputs: Vec<PathBuf>,
    /// Recorded seconds per wall second (2 plays twice as fast).
    #[arg(long, default_value_t = 1.0, value_name = "X")]
    pub rate: f64,
    /// Start again at the end, until Ctrl-C.
    #[arg(long = "loop")]
    pub looping: bool,
    /// Play only the topics matching one of these globs (`*` within one level of the name,
    /// `**` across levels).
    #[arg(long, num_args = 1.., value_name = "GLOB")]
    pub topics: Vec<String>,
    /// Start this many seconds after the recording's start.
    #[arg(long, default_value_t = 0.0, value_name = "T")]
    pub start: f64,
    /// Start paused (needs a terminal on stdin: space resumes, `s` steps).
    #[arg(long)]
    pub paused: bool,
    /// Do not publish the playback time on /lewis/clock.
    #[arg(long)]
    pub no_clock: bool,
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
}

/// Runs `lewis play`.
pub fn run(args: &PlayArgs) -> anyhow::Result<ExitCode> {
    let terminal = std::io::stdin().is_terminal();
    anyhow::ensure!(
        !args.paused || terminal,
        "--paused needs a terminal on stdin to resume (space) or step (s); stdin is not one"
    );
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let ipc = Ipc::open(&namespace, "lewis-play")?;
    let stop = StopSignals::install().context("cannot catch SIGTERM and SIGINT")?;
    let options = PlayOptions {
        inputs: args.inputs.clone(),
        rate: args.rate,
        looping: args.looping,
        topics: args.topics.clone(),
        start_s: args.start,
        paused: args.paused,
        clock: !args.no_clock,
    };
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template("{msg} {bar:30}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let mut shown = None::<Instant>;
    let mut on_status = |s: &Status| {
        let Some(bar) = &bar else {
            return;
        };
        // A status line a dozen times a second is plenty.
        let now = Instant::now();
        if !s.paused && shown.is_some_and(|t| now - t < Duration::from_millis(80)) {
            return;
        }
        shown = Some(now);
        let permille = if s.total_ns > 0 {
            u64::try_from(s.time_ns.clamp(0, s.total_ns).saturating_mul(1000) / s.total_ns)
                .unwrap_or(0)
        } else {
            1000
        };
        bar.set_position(permille);
        bar.set_message(format!(
            "{} {:>8.2} s of {:.2} s, {} messages{}",
            if s.paused { "paused " } else { "playing" },
            secs(s.time_ns),
            secs(s.total_ns),
            s.published,
            if s.pass > 1 {
                format!(", pass {}", s.pass)
            } else {
                String::new()
            }
        ));
    };
    let report = if terminal {
        let mut keys = Keyboard::new()?;
        play(&options, &ipc, &stop, &mut keys, &mut on_status)
    } else {
        play(&options, &ipc, &stop, &mut NoControls, &mut on_status)
    };
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let report = report?;
    std::io::stdout()
        .lock()
        .write_all(summary(&report).as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

// For display only.
fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

fn summary(report: &PlayReport) -> String {
    let mut t = String::new();
    let published: u64 = report.topics.values().map(|c| c.published).sum();
    let files: Vec<String> = report
        .files
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let _ = writeln!(
        t,
        "{} {}: {published} messages on {} topics{}, {} clock messages",
        if report.stopped { "stopped" } else { "played" },
        files.join(", "),
        report.topics.len(),
        if report.passes > 1 {
            format!(" in {} passes", report.passes)
        } else {
            String::new()
        },
        report.clock_messages
    );
    for (topic, count) in &report.topics {
        let failed = if count.failed > 0 {
            format!(
                ", {} refused ({})",
                count.failed,
                report.first_failures.get(topic).map_or("", String::as_str)
            )
        } else {
            String::new()
        };
        let _ = writeln!(t, "  {topic}: {}{failed}", count.published);
    }
    t
}

/// The terminal's keys, read one at a time without echo (the terminal is put back as it
/// was when this is dropped). Ctrl-C still interrupts.
struct Keyboard {
    stdin: std::io::Stdin,
    saved: Termios,
}

impl Keyboard {
    fn new() -> anyhow::Result<Self> {
        let stdin = std::io::stdin();
        let saved = termios::tcgetattr(stdin.as_fd()).context("cannot read the terminal's mode")?;
        let keys = lewis_sequencer::keys::single_key_mode(&saved, false);
        termios::tcsetattr(stdin.as_fd(), SetArg::TCSANOW, &keys)
            .context("cannot set the terminal to read single keys")?;
        Ok(Self { stdin, saved })
    }
}

impl Controls for Keyboard {
    fn fd(&self) -> Option<BorrowedFd<'_>> {
        Some(self.stdin.as_fd())
    }

    fn take(&mut self) -> Vec<PlayCommand> {
        let mut buffer = [0u8; 64];
        // VMIN = 0: returns at once with what is there.
        let read = nix::unistd::read(self.stdin.as_fd(), &mut buffer).unwrap_or(0);
        buffer[..read]
            .iter()
            .filter_map(|key| match key {
                b' ' => Some(PlayCommand::TogglePause),
                b's' | b'S' => Some(PlayCommand::Step),
                b'q' | b'Q' => Some(PlayCommand::Quit),
                _ => None,
            })
            .collect()
    }
}

impl Drop for Keyboard {
    fn drop(&mut self) {
        let _ = termios::tcsetattr(self.stdin.as_fd(), SetArg::TCSANOW, &self.saved);
    }
}
