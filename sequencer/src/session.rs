//! A mission run whole, as `lewis seq run` and `lewis up --script` run it: the script
//! checked, the supervisor asked on the page, on the terminal or by nobody, every record
//! published on `/lewis/sequencer` (so a recorder keeps it) and written to an events file,
//! the programs' lines and the decisions echoed for people.
//!
//! [`BesideBroker`] runs one on a thread beside a broker: it waits until the broker
//! answers (so the services it starts on demand can be asked for), runs the mission, and
//! when the mission ends asks whoever runs the broker to stop through a callback, never by
//! signalling its own process.

use std::collections::BTreeMap;
use std::fmt;
use std::io::{self, BufReader, IsTerminal, Write};
use std::net::SocketAddr;
use std::os::fd::AsFd;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_interfaces::msg::BrokerStatus;
use lewis_runtime::client::call_blocking;
use lewis_runtime::ipc::{Ipc, NAMESPACE_ENV, Namespace};
use lewis_runtime::names;

use crate::gui::{GuiError, GuiServer, RobotFeed, RobotWatch, RobotWatchOptions, open_in_browser};
use crate::keys::{KEYS_HINT, KeyTerminal};
use crate::live::{
    Command, ControlReceiver, Controller, LogLine, Outcome, RunError, RunOptions, SignalForwarder,
    Stream, control_channel, run_mission,
};
use crate::record::{Entry, JsonLinesSink, Record, RecordSink, Tee};
use crate::terminal::{TerminalKeys, answer_through};
use crate::{Mission, Publisher, Supervision, TerminalChooser, Verdict};

/// How long a mission beside a broker waits for the broker to answer before it gives up.
const BROKER_READY_TIMEOUT: Duration = Duration::from_secs(30);

/// How long one question to the broker may take while waiting for it.
const BROKER_CALL_TIMEOUT: Duration = Duration::from_secs(1);

/// Between two questions to a broker that is not there yet (nothing announces it).
const BROKER_RETRY: Duration = Duration::from_millis(20);

/// How a mission is supervised and where its records go.
#[derive(Debug, Clone)]
pub struct SessionOptions {
    /// Do not serve the supervisor's page even with `use gui`: ask on the terminal when the
    /// standard input is one, else nobody.
    pub no_gui: bool,
    /// Where the supervisor's page is served (port 0 picks a free one).
    pub gui_addr: SocketAddr,
    /// Also write every record to this file, as JSON lines.
    pub events: Option<PathBuf>,
    /// Open the supervisor's page in the desktop's browser when it is served (its URL is
    /// printed either way; without a display or a browser, one line says so).
    pub open_page: bool,
    /// Print the decisions and the programs' lines (`[state] text`) on stdout and stderr;
    /// without, they go to the logs only (a caller whose logs already show them).
    pub echo: bool,
    /// Ask nobody, whatever the standard input is (a batch of missions, a chaos run): after
    /// recovery the recovery state's own actions apply, and the terminal's keys answer
    /// nothing.
    pub unattended: bool,
}

/// Why a mission could not run (not how it ended: that is an [`Outcome`]).
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The script has errors.
    #[error("{diagnostics}\n{}: the script has errors", path.display())]
    Script {
        /// The script.
        path: PathBuf,
        /// What is wrong, with places.
        diagnostics: String,
    },
    /// The live driver could not go on.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The supervisor's page could not be served.
    #[error(transparent)]
    Gui(#[from] GuiError),
    /// The events file could not be written.
    #[error("cannot write the events file {}: {source}", path.display())]
    Events {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// A thread, the terminal, the signals or the control channel could not be set up.
    #[error("cannot set up the mission: {0}")]
    Setup(#[source] io::Error),
    /// The mission's thread panicked.
    #[error("the mission thread panicked")]
    Panicked,
}

/// Checks the script at `path` (its warnings go to stderr) and returns its mission.
///
/// # Errors
/// When the script has errors.
pub fn load_mission(path: &Path) -> Result<Mission, SessionError> {
    match crate::check_file(path) {
        Ok(checked) => {
            if !checked.warnings.is_empty() {
                let _ = writeln!(io::stderr(), "{}", checked.warnings);
            }
            Ok(checked.mission)
        }
        Err(diagnostics) => Err(SessionError::Script {
            path: path.to_path_buf(),
            diagnostics: diagnostics.to_string(),
        }),
    }
}

/// How a mission ended, for people: `mission finished: ...` or `mission aborted: ...`.
impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Finished { reason } => write!(f, "mission finished: {reason}"),
            Self::Aborted { reason } => write!(f, "mission aborted: {reason}"),
        }
    }
}

/// How a mission run ended: how the driver ended it, and the verdict on its records
/// (reaching `stop` through recovery is `finished` but not a success).
#[derive(Debug, Clone)]
pub struct MissionReport {
    /// Finished or aborted, as the FSM decided.
    pub outcome: Outcome,
    /// Whether the mission did its task, judged from its records.
    pub verdict: Verdict,
}

impl MissionReport {
    /// Whether the mission succeeded ([`Verdict::succeeded`]).
    #[must_use]
    pub fn succeeded(&self) -> bool {
        self.verdict.succeeded
    }

    /// A mission that could not start (the broker never answered, an interruption first).
    fn not_started(reason: String) -> Self {
        Self {
            outcome: Outcome::Aborted { reason },
            verdict: Verdict::of(&[]),
        }
    }
}

/// Two lines: the outcome, then the verdict.
impl fmt::Display for MissionReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}
{}",
            self.outcome, self.verdict
        )
    }
}

/// Runs a checked mission from `script` on this thread until it ends, catching Ctrl-C,
/// SIGTERM and SIGHUP to stop it cleanly: what `lewis seq run` does.
///
/// # Errors
/// When the mission could not run.
pub fn run_session(
    script: &Path,
    mission: Mission,
    options: &SessionOptions,
    namespace: &Namespace,
) -> Result<MissionReport, SessionError> {
    let (controller, control) = control_channel().map_err(SessionError::Setup)?;
    let signals = SignalForwarder::start(controller.clone()).map_err(SessionError::Setup)?;
    let outcome = execute(
        script,
        mission,
        options,
        None,
        namespace,
        &controller,
        &control,
    );
    drop(signals);
    outcome
}

/// Runs `mission` (from `script`) to its end: the programs in `namespace` (their
/// `LEWIS_NAMESPACE`), every record published on /lewis/sequencer there and written to
/// the events file; the supervisor asked on the page, on the terminal, or nobody
/// ([`Supervision::decide`]), the page showing the robot as `robot` says. Commands come
/// from `control` (the caller catches the signals).
fn execute(
    script: &Path,
    mission: Mission,
    options: &SessionOptions,
    robot: Option<&RobotWatchOptions>,
    namespace: &Namespace,
    controller: &Controller,
    control: &ControlReceiver,
) -> Result<MissionReport, SessionError> {
    let mut events = match &options.events {
        Some(path) => Some(
            JsonLinesSink::create(path).map_err(|source| SessionError::Events {
                path: path.clone(),
                source,
            })?,
        ),
        None => None,
    };
    let publisher = match Publisher::start(namespace) {
        Ok(started) => Some(started),
        Err(e) => {
            tracing::warn!("the mission is not published, so not recorded: {e}");
            None
        }
    };
    let terminal = io::stdin().is_terminal() && !options.unattended;
    let supervision = Supervision::decide(
        mission.use_gui(),
        options.no_gui || options.unattended,
        terminal,
    );
    if options.echo {
        // `lewis up` has the driver's log line; `lewis seq run` logs nothing else.
        let line = match supervision {
            Supervision::Unattended => {
                "seq: nobody can answer (no supervisor's page, and the standard input is not a \
                 terminal): after recovery the recovery state's actions apply"
            }
            Supervision::Terminal => "seq: the supervisor is asked on this terminal after recovery",
            Supervision::Page => "",
        };
        if !line.is_empty() {
            let _ = writeln!(io::stderr(), "{line}");
        }
    }
    let gui = if supervision == Supervision::Page {
        let gui = GuiServer::start(options.gui_addr, &mission, controller.clone())?;
        let _ = writeln!(io::stdout(), "supervisor's page: {}", gui.url());
        if options.open_page {
            open_in_browser(&gui.url(), io::stdout());
        }
        Some(gui)
    } else {
        None
    };
    // The terminal's keys answer for the registrar when there is a Speech provider and the
    // standard input is a terminal in the foreground; restored when this is dropped,
    // however the mission ends.
    let keys = match robot.filter(|r| r.speech.is_some()) {
        Some(_) if terminal => match KeyTerminal::stdin() {
            Ok(keys) => Some(keys),
            Err(e) => {
                tracing::debug!("no answers from the terminal's keys: {e}");
                None
            }
        },
        _ => None,
    };
    let feed = match (&gui, robot) {
        (Some(gui), Some(_)) => Some(gui.robot_feed()),
        (None, Some(_)) if keys.is_some() => Some(RobotFeed::detached(&mission)),
        _ => None,
    };
    let watch = match (&feed, robot) {
        (Some(feed), Some(robot)) => {
            match RobotWatch::start(namespace, robot.clone(), feed.clone()) {
                Ok(watch) => Some(watch),
                Err(e) => {
                    tracing::warn!("the supervisor's page does not show the robot: {e}");
                    None
                }
            }
        }
        _ => None,
    };
    let (keys, key_input) = keys.unzip();
    let answers = match (&feed, key_input) {
        (Some(feed), Some(input)) => {
            feed.on_said(|text| {
                let _ = writeln!(io::stderr(), "robot says \"{text}\": {KEYS_HINT}");
            });
            feed.on_answered(|what| {
                let _ = writeln!(io::stderr(), "registrar: {what}");
            });
            Some((answer_through(feed.clone(), io::stderr()), input))
        }
        _ => None,
    };
    let terminal = match (supervision, answers) {
        (Supervision::Terminal, Some((answers, input))) => Some(
            TerminalChooser::with_keys(input, io::stderr(), controller.clone(), Some(answers))
                .map_err(SessionError::Setup)?,
        ),
        (Supervision::Terminal, None) => {
            let stdin = BufReader::new(io::stdin());
            Some(
                TerminalChooser::start(stdin, io::stderr(), controller.clone())
                    .map_err(SessionError::Setup)?,
            )
        }
        (_, Some((answers, input))) => {
            TerminalKeys::start(input, controller.clone(), answers).map_err(SessionError::Setup)?;
            None
        }
        (_, None) => None,
    };

    let (lines, incoming) = mpsc::sync_channel(4096);
    let lines = options.echo.then_some(lines);
    let printer = std::thread::Builder::new()
        .name("lewis-seq-output".into())
        .spawn(move || {
            for line in incoming {
                let line: LogLine = line;
                let text = format!("[{}] {}\n", line.name, line.text);
                let _ = match line.stream {
                    Stream::Stdout => io::stdout().write_all(text.as_bytes()),
                    Stream::Stderr => io::stderr().write_all(text.as_bytes()),
                };
            }
        })
        .map_err(SessionError::Setup)?;

    let (publisher, published) = publisher.unzip();
    let mut records = Vec::new();
    let mut tee = Tee::new().with(&mut records);
    if options.echo {
        tee = tee.with(Console);
    }
    if let Some(published) = published {
        tee = tee.with(published);
    }
    if let Some(events) = events.as_mut() {
        tee = tee.with(events);
    }
    if let Some(gui) = &gui {
        tee = tee.with(gui.sink());
    }
    if let Some(terminal) = terminal {
        tee = tee.with(terminal);
    }
    let run_options = RunOptions {
        log_lines: lines,
        env: program_env(namespace),
        supervision,
        ..RunOptions::new(std::path::absolute(script).map_err(SessionError::Setup)?)
    };
    let outcome = run_mission(mission, run_options, control, &mut tee);
    drop(tee);
    // The supervisor is gone with its output threads: every line has been sent.
    let _ = printer.join();
    if let Some(publisher) = publisher {
        let report = publisher.finish();
        if report.failed > 0 || report.discarded > 0 {
            tracing::warn!(
                "{} of the mission's records were not published and {} deliveries were dropped on /lewis/sequencer",
                report.failed,
                report.discarded
            );
        }
    }
    if let Some(watch) = watch {
        watch.stop();
    }
    // The terminal's settings come back now (and on every early return, when dropped).
    drop(keys);
    if let Some(gui) = gui {
        gui.shutdown();
    }
    if let (Some(events), Some(path)) = (events, &options.events) {
        events.finish().map_err(|source| SessionError::Events {
            path: path.clone(),
            source,
        })?;
    }
    Ok(MissionReport {
        outcome: outcome?,
        verdict: Verdict::of(&records),
    })
}

/// Prints the mission's decisions as they are taken.
struct Console;

impl RecordSink for Console {
    fn record(&mut self, record: &Record) {
        let line = match &record.entry {
            Entry::Decided { decision } => format!("seq: {decision}\n"),
            Entry::Refused { event, error } => format!("seq: refused {event}: {error}\n"),
            Entry::MissionStarted { .. }
            | Entry::Observed { .. }
            | Entry::ProgramStarted { .. } => {
                return;
            }
        };
        let _ = io::stdout().write_all(line.as_bytes());
    }
}

/// A mission running on a thread beside a broker.
#[derive(Debug)]
pub struct BesideBroker {
    thread: JoinHandle<Result<MissionReport, SessionError>>,
    controller: Controller,
    /// Kept until the thread is joined, so that Ctrl-C reaches the mission.
    _signals: SignalForwarder,
}

impl BesideBroker {
    /// Starts `mission` (checked, from `script`) on a thread that first waits for the
    /// broker of `namespace`; `on_end` runs on that thread when the mission is over, to
    /// stop the broker. Call before the broker runs. The programs' lines and decisions go
    /// to the logs (`echo` is ignored: the logs of a robot already show them).
    ///
    /// # Errors
    /// When the thread, the signals or the control channel cannot be set up.
    pub fn start(
        script: &Path,
        mission: Mission,
        options: &SessionOptions,
        namespace: &Namespace,
        on_end: impl FnOnce() + Send + 'static,
    ) -> Result<Self, SessionError> {
        Self::start_watching(script, mission, options, None, namespace, on_end)
    }

    /// As [`BesideBroker::start`], the supervisor's page also showing the robot as `robot`
    /// says (where it is, its camera, its bindings: [`RobotWatch`]).
    ///
    /// # Errors
    /// When the thread, the signals or the control channel cannot be set up.
    pub fn start_watching(
        script: &Path,
        mission: Mission,
        options: &SessionOptions,
        robot: Option<RobotWatchOptions>,
        namespace: &Namespace,
        on_end: impl FnOnce() + Send + 'static,
    ) -> Result<Self, SessionError> {
        let (controller, control) = control_channel().map_err(SessionError::Setup)?;
        let signals = SignalForwarder::start(controller.clone()).map_err(SessionError::Setup)?;
        let options = SessionOptions {
            echo: false,
            ..options.clone()
        };
        let script = script.to_path_buf();
        let namespace = namespace.clone();
        let thread_controller = controller.clone();
        let thread = std::thread::Builder::new()
            .name("lewis-mission".into())
            .spawn(move || {
                let outcome = match wait_for_broker(&namespace, &control) {
                    Ok(()) => execute(
                        &script,
                        mission,
                        &options,
                        robot.as_ref(),
                        &namespace,
                        &thread_controller,
                        &control,
                    ),
                    Err(reason) => Ok(MissionReport::not_started(reason)),
                };
                // The broker and the services go when the mission does.
                on_end();
                outcome
            })
            .map_err(SessionError::Setup)?;
        Ok(Self {
            thread,
            controller,
            _signals: signals,
        })
    }

    /// Ends the mission if it still runs (the broker has stopped), waits for it and returns
    /// how it ended.
    ///
    /// # Errors
    /// When the mission could not run (process supervision, the supervisor's page).
    pub fn finish(self, why: &str) -> Result<MissionReport, SessionError> {
        // Queued and never read when the mission is already over.
        self.controller.interrupt(why);
        self.thread.join().map_err(|_| SessionError::Panicked)?
    }
}

/// Waits until the broker of `namespace` answers, or a command (Ctrl-C, the end of the
/// run) arrives, or [`BROKER_READY_TIMEOUT`] passes; `Err` says why the mission cannot run.
fn wait_for_broker(namespace: &Namespace, control: &ControlReceiver) -> Result<(), String> {
    let ipc = Ipc::open(namespace, &format!("lewis-mission-{}", std::process::id()))
        .map_err(|e| format!("cannot reach the broker: {e}"))?;
    let mut broker = ipc
        .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        .map_err(|e| format!("cannot reach the broker: {e}"))?;
    let deadline = Instant::now() + BROKER_READY_TIMEOUT;
    loop {
        if call_blocking(&mut broker, &BrokerStatus::default(), BROKER_CALL_TIMEOUT).is_ok() {
            return Ok(());
        }
        if Instant::now() >= deadline {
            return Err(format!(
                "the broker of namespace `{namespace}` did not answer within {} s",
                BROKER_READY_TIMEOUT.as_secs()
            ));
        }
        // Nothing announces the broker: ask again shortly, but wake at once for a command.
        let fd = control.as_fd();
        let mut fds = [rustix::event::PollFd::new(
            &fd,
            rustix::event::PollFlags::IN,
        )];
        let timeout = rustix::time::Timespec::try_from(BROKER_RETRY).ok();
        let _ = rustix::event::poll(&mut fds, timeout.as_ref());
        if let Some(command) = control.drain().into_iter().next() {
            return Err(match command {
                Command::Interrupt(reason) => format!("interrupted ({reason}) before it started"),
                Command::Stop | Command::Choose(_) => {
                    "stopped by the supervisor before it started".to_owned()
                }
            });
        }
    }
}

/// The variable that names the `lewis` binary to a mission's programs: the challenge's
/// programs are `#!/bin/sh` wrappers that run `"${LEWIS_EXE:-lewis}" app NAME`, so they run
/// the very `lewis` that runs the mission, installed or not.
pub const LEWIS_EXE_ENV: &str = "LEWIS_EXE";

/// What the sequencer adds to its programs' environment: the namespace, and the `lewis`
/// binary when the mission runs inside one (and the environment does not already name one).
fn program_env(namespace: &Namespace) -> BTreeMap<String, String> {
    let mut env = BTreeMap::from([(NAMESPACE_ENV.to_owned(), namespace.as_str().to_owned())]);
    if std::env::var_os(LEWIS_EXE_ENV).is_none()
        && let Ok(exe) = std::env::current_exe()
        && exe.file_stem().is_some_and(|stem| stem == "lewis")
    {
        env.insert(LEWIS_EXE_ENV.to_owned(), exe.to_string_lossy().into_owned());
    }
    env
}
