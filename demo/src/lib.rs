//! `lewis demo`: the README's main job. The simulated robot runs the Robot Challenge
//! mission with the recorder on; a fault kills a provider on the way (the broker fails over
//! and the mission goes on); the recording is re-simulated with a fault at another time; a
//! few lines, a picture and a Rerun file say what happened.
//!
//! It owns the demo's story: which robot and script, when the fault strikes, what is
//! written where and what is printed. It decides nothing of a run itself: the launch runs
//! the robot, the sequencer judges the mission, replay re-simulates it.

pub mod chaos;
pub mod fault;
pub mod mission_bench;

use std::fmt::Write as _;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use lewis_launch::{Launch, LaunchError, LaunchOptions, MissionPlan};
use lewis_recording::RecordingFiles;
use lewis_replay::fault::FaultSpec;
use lewis_replay::lockstep::Programs;
use lewis_replay::outcome::LoopKind;
use lewis_replay::report::Report;
use lewis_replay::resim::{ReplayOptions, ServiceSelection, replay_with};
use lewis_robot::{Known, Robot};
use lewis_runtime::broker::live::UpOptions;
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::ClockSource;
use lewis_sequencer::Verdict;
use lewis_sequencer::session::{MissionReport, SessionOptions, load_mission};
use lewis_service::ServiceRegistry;

pub use fault::{FaultLog, LiveFault, Strike};

/// The robot the demo runs, from the repository's root.
pub const ROBOT: &str = "robots/sim.toml";

/// The mission it runs, from the repository's root.
pub const SCRIPT: &str = "robots/missions/challenge.seq";

/// Where it writes by default.
pub const OUT_DIR: &str = "logs/demo";

/// What to run and where to write.
#[derive(Debug, Clone)]
pub struct DemoOptions {
    /// The robot file (`robots/sim.toml`).
    pub robot: PathBuf,
    /// The mission script (`robots/missions/challenge.seq`).
    pub script: PathBuf,
    /// The seed of the simulated devices (`seed` of every `sim-*` service: this one for
    /// the first, one more for each next); `None`: the robot file's own.
    pub seed: Option<u64>,
    /// No supervisor's page (the mission is then unattended unless a terminal answers).
    pub no_gui: bool,
    /// Where the supervisor's page is served.
    pub gui_addr: SocketAddr,
    /// The output folder.
    pub out: PathBuf,
    /// The live fault (default: the laser crashes beyond its restart limit after the first
    /// state).
    pub fault: LiveFault,
    /// The IPC namespace.
    pub namespace: Namespace,
    /// The `lewis` binary (for the services, the recorder and the programs).
    pub lewis_exe: PathBuf,
}

/// The files a demo writes, in its output folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DemoFiles {
    /// The live recording.
    pub run: PathBuf,
    /// The mission's records as JSON lines.
    pub events: PathBuf,
    /// The re-simulated recording.
    pub replay: PathBuf,
    /// The replay's report as JSON.
    pub replay_report: PathBuf,
    /// The Rerun file (written by the caller when it has the viewer).
    pub rrd: PathBuf,
    /// The picture of the run: the world, the path coloured by state, the signs seen, where
    /// a provider failed (written by the caller when it has the viewer).
    pub png: PathBuf,
    /// The robot file with the seed given, when one was.
    pub robot: Option<PathBuf>,
}

impl DemoFiles {
    /// The files of a demo whose output folder is `out`.
    #[must_use]
    pub fn in_dir(out: &Path) -> Self {
        Self {
            run: out.join("run.mcap"),
            events: out.join("events.jsonl"),
            replay: out.join("replay.mcap"),
            replay_report: out.join("replay.json"),
            rrd: out.join("run.rrd"),
            png: out.join("run.png"),
            robot: None,
        }
    }
}

/// How a demo went.
#[derive(Debug)]
pub struct DemoReport {
    /// How the mission ended, and its verdict.
    pub mission: MissionReport,
    /// What the live fault did.
    pub fault: FaultLog,
    /// The replay's report, or why there is none.
    pub replay: Result<Report, String>,
    /// The replay's fault, as given to it.
    pub replay_fault: String,
    /// The files written.
    pub files: DemoFiles,
}

impl DemoReport {
    /// Whether the mission succeeded (the verdict).
    #[must_use]
    pub fn succeeded(&self) -> bool {
        self.mission.succeeded()
    }

    /// A few lines for people: what happened and where the files are
    /// ([`mission_lines`], then [`DemoReport::replay_summary`]).
    #[must_use]
    pub fn summary(&self) -> String {
        mission_lines(&self.mission, &self.fault) + &self.replay_summary()
    }

    /// What the replay says and where the files are: the lines after [`mission_lines`].
    #[must_use]
    pub fn replay_summary(&self) -> String {
        let mut s = String::new();
        match &self.replay {
            Ok(report) => {
                let _ = write!(s, "{}", replay_lines(&self.replay_fault, report));
            }
            Err(e) => {
                let _ = writeln!(s, "replay with {}: failed: {e}", self.replay_fault);
            }
        }
        let files = &self.files;
        let _ = writeln!(
            s,
            "files: {} (recording), {} (mission records), {} and {} (replay)",
            files.run.display(),
            files.events.display(),
            files.replay.display(),
            files.replay_report.display()
        );
        let run = files.run.display();
        let _ = writeln!(
            s,
            "next: `lewis view {run}` (Rerun), `lewis info {run}`, `lewis replay {run} --all --inject-fault sonar@60s`"
        );
        s
    }
}

/// The mission's own lines, as soon as it is over: its verdict, the states it went
/// through, and what the live fault did.
#[must_use]
pub fn mission_lines(mission: &MissionReport, fault: &FaultLog) -> String {
    let verdict = &mission.verdict;
    let mut s = String::new();
    let _ = writeln!(s, "{verdict}");
    let route: Vec<&str> = verdict
        .states_visited
        .iter()
        .map(|v| v.state.as_str())
        .collect();
    let _ = writeln!(
        s,
        "states: {}",
        if route.is_empty() {
            "none".to_owned()
        } else {
            route.join(" -> ")
        }
    );
    let _ = writeln!(s, "live fault: {}", fault_line(fault));
    s
}

/// What the live fault did, in one line.
fn fault_line(f: &FaultLog) -> String {
    if let Some(error) = &f.error {
        return format!("could not strike: {error}");
    }
    if f.struck_ns.is_none() {
        return "did not strike (the mission ended first)".to_owned();
    }
    let mut line = String::new();
    if !f.killed.is_empty() {
        let _ = write!(line, "{} process(es) killed", f.killed.len());
    } else {
        line.push_str("struck");
    }
    if f.failed_ns.is_some() {
        line.push_str(", given up by the broker");
    }
    if f.rebinds.is_empty() {
        line.push_str("; no client moved");
    } else {
        let _ = write!(line, "; moved: {}", f.rebinds.join(", "));
    }
    line
}

/// What the replay says, in a few lines: the fault, who took over, what diverged.
fn replay_lines(fault: &str, report: &Report) -> String {
    let mut s = String::new();
    let lived_again = report.mission.as_ref().and_then(|m| {
        (m.loop_kind == LoopKind::Closed)
            .then_some(m.replayed.as_ref())
            .flatten()
    });
    match lived_again {
        Some(mission) => {
            let _ = writeln!(
                s,
                "replay: what if {fault} had happened as well? (closed loop: the mission lived again)"
            );
            let _ = writeln!(
                s,
                "  the mission would have {}: {} ({})",
                if mission.succeeded {
                    "succeeded"
                } else {
                    "FAILED"
                },
                mission.course().join(", "),
                mission
                    .time_to_finish_ns
                    .map_or_else(|| "unfinished".to_owned(), |t| format!("{:.1} s", secs(t)))
            );
        }
        None => {
            let _ = writeln!(
                s,
                "replay: what if {fault} had happened instead? (open loop: the recorded robot moves as it did)"
            );
        }
    }
    let takeovers: Vec<String> = report
        .faults
        .iter()
        .flat_map(|f| &f.takeovers)
        .map(|t| {
            format!(
                "{} {} -> {} after {:.1} s",
                t.client,
                t.interface,
                t.provider,
                secs(t.latency_ns)
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "  the broker moved: {}",
        if takeovers.is_empty() {
            "no client".to_owned()
        } else {
            takeovers.join(", ")
        }
    );
    let mut diverged: Vec<(i64, String)> = report
        .divergence
        .iter()
        .filter(|d| d.differing > 0)
        .filter_map(|d| {
            d.first_divergence_ns.map(|first| {
                let text = format!(
                    "{} from {:.1} s ({} of {})",
                    d.channel,
                    secs(first),
                    d.differing,
                    d.compared
                );
                (first, text)
            })
        })
        .collect();
    // The earliest first: where the replay left the recording.
    diverged.sort();
    let diverged: Vec<String> = diverged.into_iter().map(|(_, text)| text).collect();
    // Lived again, the robot drives otherwise and nearly every output changes: the first
    // few say when, the report has them all.
    let shown = diverged.len().min(OUTPUTS_SHOWN);
    let more = match diverged.len() - shown {
        0 => String::new(),
        n => format!(" and {n} more (replay.json)"),
    };
    let _ = writeln!(
        s,
        "  outputs that changed: {}{more}",
        if diverged.is_empty() {
            "none".to_owned()
        } else {
            diverged[..shown].join(", ")
        }
    );
    s
}

/// Outputs named in the summary's line of changed outputs.
const OUTPUTS_SHOWN: usize = 3;

/// Why the demo could not run.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    /// Not in the repository's root.
    #[error(
        "{} not found: run `lewis demo` from the root of the Lewis repository (where robots/ is)",
        path.display()
    )]
    NotInRepository {
        /// The file missing.
        path: PathBuf,
    },
    /// The robot file is not valid (or the seed could not be set).
    #[error("{0}")]
    Robot(String),
    /// The output folder or a file in it cannot be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The mission script has errors.
    #[error(transparent)]
    Script(#[from] lewis_sequencer::session::SessionError),
    /// The robot could not run.
    #[error(transparent)]
    Launch(#[from] LaunchError),
    /// The fault thread could not start.
    #[error("cannot watch the robot for the fault: {0}")]
    Fault(#[source] std::io::Error),
    /// A report could not be made or drawn.
    #[error("{0}")]
    Report(String),
    /// The robot ran without a mission report (a bug of the launch).
    #[error("the launch ended without the mission's report")]
    NoMission,
}

/// Runs the demo: the robot and the mission with the recorder and the live fault, then the
/// replay with a fault in the middle of the `sign` states (half-way when there were none).
/// The files of an earlier demo in the same folder are replaced.
/// `registry` builds the services in the replay and checks the robot's kinds; `programs`
/// builds the mission's programs, for the replay to live the mission again; `on_mission`
/// is told how the mission went as soon as it is over, before the replay.
///
/// # Errors
/// When the robot or the mission cannot run; a failed mission or replay is in the report.
pub fn run_demo(
    options: &DemoOptions,
    registry: &ServiceRegistry,
    programs: &dyn Programs,
    on_mission: &mut dyn FnMut(&MissionReport, &FaultLog),
) -> Result<DemoReport, DemoError> {
    for path in [&options.robot, &options.script] {
        if !path.exists() {
            return Err(DemoError::NotInRepository { path: path.clone() });
        }
    }
    std::fs::create_dir_all(&options.out).map_err(|source| DemoError::Write {
        path: options.out.clone(),
        source,
    })?;
    let mut files = DemoFiles::in_dir(&options.out);
    // The demo's own files from an earlier run: the recorder never replaces a recording.
    for old in [
        &files.run,
        &files.events,
        &files.replay,
        &files.replay_report,
        &files.rrd,
        &files.png,
    ] {
        match std::fs::remove_file(old) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => {
                return Err(DemoError::Write {
                    path: old.clone(),
                    source,
                });
            }
        }
    }
    let robot_path = match options.seed {
        Some(seed) => {
            let text = std::fs::read_to_string(&options.robot).map_err(|e| {
                DemoError::Robot(format!("cannot read {}: {e}", options.robot.display()))
            })?;
            let seeded = with_seed(&text, seed).map_err(DemoError::Robot)?;
            let file_name = options
                .robot
                .file_name()
                .map_or_else(|| PathBuf::from("robot.toml"), PathBuf::from);
            let path = options.out.join(file_name);
            std::fs::write(&path, seeded).map_err(|source| DemoError::Write {
                path: path.clone(),
                source,
            })?;
            files.robot = Some(path.clone());
            path
        }
        None => options.robot.clone(),
    };
    // Services get an absolute path: they may run in another directory.
    let robot_path = std::path::absolute(&robot_path).map_err(|source| DemoError::Write {
        path: robot_path.clone(),
        source,
    })?;
    let robot = load_robot(&robot_path, registry)?;
    let mission = load_mission(&options.script)?;

    // The fault thread opens the namespace before the launch does: what killed runs left
    // in it goes first (the launch would find this process's node alive and leave it).
    let _ = lewis_runtime::ipc::wipe_stale(&options.namespace);
    let fault = fault::FaultThread::start(&options.namespace, options.fault.clone())
        .map_err(DemoError::Fault)?;
    let launch_options = LaunchOptions {
        up: UpOptions {
            robot_path,
            namespace: options.namespace.clone(),
            lewis_exe: options.lewis_exe.clone(),
            duration: None,
            stop_grace: lewis_runtime::supervise::DEFAULT_STOP_GRACE,
            clock: ClockSource::Wall,
        },
        record: Some(Some(files.run.clone())),
        companions: Some(lewis_recorder::companion::CompanionOptions::default()),
        goal: None,
        mission: Some(MissionPlan {
            script: options.script.clone(),
            mission,
            options: SessionOptions {
                no_gui: options.no_gui,
                gui_addr: options.gui_addr,
                events: Some(files.events.clone()),
                // The demo is watched by a person at a desktop, when there is one.
                open_page: !options.no_gui,
                echo: false,
                unattended: false,
            },
        }),
    };
    let launched = Launch::new(robot, launch_options).and_then(Launch::run);
    let fault = fault.finish();
    let mission = launched?.mission.ok_or(DemoError::NoMission)?;
    on_mission(&mission, &fault);

    let replay_fault = replay_fault(&options.fault, &mission.verdict, &files.run);
    let replayed = re_simulate(registry, programs, &files, &replay_fault);
    Ok(DemoReport {
        mission,
        fault,
        replay: replayed,
        replay_fault,
        files,
    })
}

/// The launch of a mission nobody watches (chaos, the mission bench): the robot at
/// `robot_path` in `namespace`, recorded to `run`, the mission's records to `events`, no
/// page, nobody asked; stopped after `duration`.
pub(crate) fn unattended_launch(
    (robot_path, namespace, lewis_exe): (PathBuf, &Namespace, &Path),
    (script, mission): (&Path, &lewis_sequencer::Mission),
    (run, events): (PathBuf, PathBuf),
    duration: std::time::Duration,
) -> LaunchOptions {
    LaunchOptions {
        up: UpOptions {
            robot_path,
            namespace: namespace.clone(),
            lewis_exe: lewis_exe.to_owned(),
            duration: Some(duration),
            stop_grace: lewis_runtime::supervise::DEFAULT_STOP_GRACE,
            clock: ClockSource::Wall,
        },
        record: Some(Some(run)),
        companions: Some(lewis_recorder::companion::CompanionOptions::default()),
        goal: None,
        mission: Some(MissionPlan {
            script: script.to_owned(),
            mission: mission.clone(),
            options: SessionOptions {
                no_gui: true,
                gui_addr: SocketAddr::from(([127, 0, 0, 1], 0)),
                events: Some(events),
                open_page: false,
                echo: false,
                unattended: true,
            },
        }),
    }
}

/// Turns an I/O error on `path` into a [`DemoError::Write`] naming it.
pub(crate) fn write_error(path: &Path) -> impl FnOnce(std::io::Error) -> DemoError {
    let path = path.to_owned();
    move |source| DemoError::Write { path, source }
}

/// `dir`, emptied of an earlier run's files (a mission's folder).
pub(crate) fn fresh_dir(dir: &Path) -> Result<(), DemoError> {
    match std::fs::remove_dir_all(dir) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(source) => return Err(write_error(dir)(source)),
    }
    std::fs::create_dir_all(dir).map_err(write_error(dir))
}

/// The robot at `path`, checked against the kinds of `registry`.
pub(crate) fn load_robot(path: &Path, registry: &ServiceRegistry) -> Result<Robot, DemoError> {
    let interfaces = lewis_interfaces::interface_names();
    let known = Known {
        interfaces: &interfaces,
        kinds: Some(registry),
    };
    lewis_robot::load_checked(path, known).map_err(|e| DemoError::Robot(e.to_string()))
}

/// The robot description `text` with `seed` of every `sim-*` service set: `seed` for the
/// first, `seed + 1` for the next, and so on, so that no two devices draw the same noise.
///
/// # Errors
/// When the text is not TOML.
pub fn with_seed(text: &str, seed: u64) -> Result<String, String> {
    let mut table: toml::Table = text.parse().map_err(|e| format!("{e}"))?;
    let mut next = i64::try_from(seed).map_err(|_| format!("--seed {seed} is too large"))?;
    if let Some(toml::Value::Array(services)) = table.get_mut("services") {
        for service in services {
            let Some(service) = service.as_table_mut() else {
                continue;
            };
            let simulated = service
                .get("kind")
                .and_then(toml::Value::as_str)
                .is_some_and(|kind| kind.starts_with("sim-"));
            if !simulated {
                continue;
            }
            let parameters = service
                .entry("parameters")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if let Some(parameters) = parameters.as_table_mut() {
                parameters.insert("seed".to_owned(), toml::Value::Integer(next));
                next = next.saturating_add(1);
            }
        }
    }
    toml::to_string(&table).map_err(|e| format!("{e}"))
}

/// The replay's fault: the live fault's provider and kind at T, the middle of the
/// mission's first visit (the door, before the live fault struck: "what if it had died
/// there as well?"), from the recording's start; half-way when the mission has no visit.
fn replay_fault(live: &LiveFault, verdict: &Verdict, recording: &Path) -> String {
    let (provider, kind) = (&live.provider, live.kind);
    let Some(first) = verdict.states_visited.first() else {
        return format!("{provider}:{kind}");
    };
    let end = first.ended_ns.unwrap_or(first.started_ns);
    let middle_ns = first.started_ns + (end - first.started_ns) / 2;
    match RecordingFiles::open(&[recording.to_path_buf()]) {
        Ok(files) if middle_ns > files.start_ns() => {
            format!(
                "{provider}@{}ms:{kind}",
                (middle_ns - files.start_ns()) / 1_000_000
            )
        }
        _ => format!("{provider}:{kind}"),
    }
}

/// The interfaces the demo's replay does not write: camera frames, most of its bytes
/// (`lewis replay --leave-out ImageSource`).
pub const REPLAY_LEFT_OUT: &[&str] = &["ImageSource"];

/// Lives the recorded mission again with `fault` (the closed loop of `lewis replay --all`:
/// the simulated world, the services and the mission re-run, the live fault applied again
/// at its recorded time) and writes its report as JSON. The output holds what the replay
/// produced but its camera frames (`--outputs-only --leave-out ImageSource`): the
/// recording holds the rest, and a copy of it doubled the demo's disk use.
fn re_simulate(
    registry: &ServiceRegistry,
    programs: &dyn Programs,
    files: &DemoFiles,
    fault: &str,
) -> Result<Report, String> {
    let spec: FaultSpec = fault.parse().map_err(|e| format!("{e}"))?;
    let mut replay_options = ReplayOptions::new(vec![files.run.clone()]);
    replay_options.output = Some(files.replay.clone());
    replay_options.faults = vec![spec];
    replay_options.services = ServiceSelection::All;
    replay_options.outputs_only = true;
    replay_options.left_out = REPLAY_LEFT_OUT.iter().map(|i| (*i).to_owned()).collect();
    let report = replay_with(&replay_options, registry, Some(programs), &mut |_| {})
        .map_err(|e| format!("{e}"))?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| format!("{e}"))?;
    std::fs::write(&files.replay_report, json + "\n").map_err(|e| {
        format!(
            "cannot write the report to {}: {e}",
            files.replay_report.display()
        )
    })?;
    Ok(report)
}

// For display only.
#[allow(clippy::cast_precision_loss)]
fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_seed_goes_to_every_simulated_device_and_nothing_else() {
        let text = "[robot]\nname = \"r\"\n\n\
            [[services]]\nname = \"base\"\nkind = \"sim-base\"\n[services.parameters]\nseed = 1\nworld = \"w\"\n\n\
            [[services]]\nname = \"avoider\"\nkind = \"obstacle_avoider\"\n[services.parameters]\nseed = 9\n\n\
            [[services]]\nname = \"laser\"\nkind = \"sim-laser\"\n";
        let seeded: toml::Table = with_seed(text, 7).unwrap().parse().unwrap();
        let seeds: Vec<Option<i64>> = seeded["services"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                s.get("parameters")
                    .and_then(|p| p.get("seed"))
                    .and_then(toml::Value::as_integer)
            })
            .collect();
        assert_eq!(seeds, [Some(7), Some(9), Some(8)]);
        assert_eq!(
            seeded["services"][0]["parameters"]["world"].as_str(),
            Some("w")
        );
    }

    #[test]
    fn garbage_and_windows_are_refused_live() {
        let spec = |text: &str| text.parse::<FaultSpec>().unwrap();
        assert!(LiveFault::from_spec(&spec("laser@1s:slow")).is_err());
        assert!(LiveFault::from_spec(&spec("laser@1s:garbage")).is_ok());
        assert!(LiveFault::from_spec(&spec("laser@1s-2s:stall")).is_err());
        assert_eq!(
            LiveFault::from_spec(&spec("sonar@2s:crash")),
            Ok(LiveFault {
                provider: "sonar".to_owned(),
                kind: lewis_replay::fault::FaultKind::Crash,
                strike: Strike::At {
                    after_start_ns: 2_000_000_000
                },
            })
        );
        assert_eq!(
            LiveFault::from_spec(&spec("laser:crash")),
            Ok(LiveFault::laser_after_first_state())
        );
    }
}
