//! Lewis launch: a robot run whole, as `lewis up` runs it. The broker and the robot's
//! services (`lewis_runtime::broker::live`), a recorder subscribed before they start and
//! stopped after them (`lewis_recorder::live::child`), and beside them, when asked, a goal
//! to drive to (`lewis_motion::goal`) or a mission script (`lewis_sequencer::session`).
//!
//! When it records, every service learns where the recording goes
//! (`lewis_service::RECORDING_ENV`): a service that writes files of its own, as
//! espeak-speech writes its audio, puts them beside it.
//!
//! It owns the order in which they start and stop, and how a run ends: Ctrl-C, SIGTERM,
//! the duration, a [`StopHandle`] from another thread, or the goal or mission being over
//! (they ask through a stop handle too; nothing signals its own process). It owns no
//! decision of theirs.

use std::path::{Path, PathBuf};

pub mod goal;
pub mod program;

use goal::{GoalPlan, GoalRun, GoalRunError};

use lewis_motion::goal::Outcome as GoalOutcome;
use lewis_recorder::companion::CompanionOptions;
use lewis_recorder::live::child::{ChildError, ChildOptions, RecorderChild};
use lewis_robot::Robot;
use lewis_runtime::broker::live::{UpError, UpOptions, UpSummary, run_up_with_hosts};
use lewis_runtime::broker::remote::RemoteHosts;
use lewis_runtime::live::{StopHandle, StopSignals};
use lewis_sequencer::Mission;
use lewis_sequencer::gui::RobotWatchOptions;
use lewis_sequencer::session::{BesideBroker, MissionReport, SessionError, SessionOptions};
use lewis_service::RECORDING_ENV;

/// A mission script to run beside the robot.
#[derive(Debug, Clone)]
pub struct MissionPlan {
    /// The script, for the records.
    pub script: PathBuf,
    /// Its mission, checked.
    pub mission: Mission,
    /// How the supervisor is asked and where the records go.
    pub options: SessionOptions,
}

/// What a launch runs.
#[derive(Debug, Clone)]
pub struct LaunchOptions {
    /// The broker's and the services' options.
    pub up: UpOptions,
    /// Record into this file (`Some(None)`: the default name under `logs/`); `None`: no
    /// recording.
    pub record: Option<Option<PathBuf>>,
    /// The recording's ROS 2 companion channels (`None`: none).
    pub companions: Option<CompanionOptions>,
    /// A goal to drive to; the run ends with it.
    pub goal: Option<GoalPlan>,
    /// A mission to run; the run ends with it.
    pub mission: Option<MissionPlan>,
}

/// Why a launch could not run.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// The stop signals could not be caught.
    #[error("cannot catch SIGTERM and SIGINT: {0}")]
    Signals(#[source] std::io::Error),
    /// The broker could not run.
    #[error(transparent)]
    Up(#[from] UpError),
    /// The recorder child could not be set up.
    #[error(transparent)]
    Recorder(#[from] ChildError),
    /// The goal could not be driven.
    #[error(transparent)]
    Goal(#[from] GoalRunError),
    /// The mission could not run.
    #[error(transparent)]
    Mission(#[from] SessionError),
}

/// How a launch ended.
#[derive(Debug, Clone)]
pub struct LaunchReport {
    /// The broker's run.
    pub up: UpSummary,
    /// How the goal ended, when there was one.
    pub goal: Option<GoalOutcome>,
    /// How the mission ended and its verdict, when there was one.
    pub mission: Option<MissionReport>,
}

impl LaunchReport {
    /// Whether the run did what it was asked: the mission succeeded (it reached `stop`
    /// other than through recovery: `lewis_sequencer::verdict`), or else the goal was
    /// reached, or else (nothing asked) the robot ran until it was stopped.
    #[must_use]
    pub fn succeeded(&self) -> bool {
        match (&self.mission, &self.goal) {
            (Some(mission), _) => mission.succeeded(),
            (None, Some(goal)) => *goal == GoalOutcome::Arrived,
            (None, None) => true,
        }
    }
}

/// A robot ready to run: the stop signals are caught from here on.
#[derive(Debug)]
pub struct Launch {
    robot: Robot,
    options: LaunchOptions,
    signals: StopSignals,
}

impl Launch {
    /// Prepares `robot` to run with `options`.
    ///
    /// # Errors
    /// When the stop signals cannot be caught.
    pub fn new(robot: Robot, options: LaunchOptions) -> Result<Self, LaunchError> {
        let signals = StopSignals::install().map_err(LaunchError::Signals)?;
        Ok(Self {
            robot,
            options,
            signals,
        })
    }

    /// A handle that stops the run from another thread, as Ctrl-C would.
    #[must_use]
    pub fn stop_handle(&self) -> StopHandle {
        self.signals.handle()
    }

    /// Runs the robot until it is stopped: the recorder first (subscribed before anything
    /// is published), the goal and the mission, then the broker and the services; at the
    /// end the mission stops, then the services, then the recorder (which keeps their last
    /// words), then the broker's channels close.
    ///
    /// # Errors
    /// When the broker, the recorder, the goal or the mission could not run.
    pub fn run(self) -> Result<LaunchReport, LaunchError> {
        self.run_with_hosts(None)
    }

    /// As [`Launch::run`], on the robot host of a robot on more than one: the broker
    /// reaches the other hosts through `remote`.
    ///
    /// # Errors
    /// When the broker, the recorder, the goal or the mission could not run.
    pub fn run_with_hosts(
        self,
        remote: Option<&mut dyn RemoteHosts>,
    ) -> Result<LaunchReport, LaunchError> {
        let Self {
            mut robot,
            options,
            signals,
        } = self;
        let namespace = &options.up.namespace;
        // First, so that every process and thread of the run inherits it; undone when the
        // robot ends.
        let machine = lewis_runtime::supervise::MachineSettings::apply(&robot);
        // Before anything of this run opens a channel: what killed runs left half made
        // would be refused to it.
        let _ = lewis_runtime::ipc::wipe_stale(namespace);
        let mut recorder = match &options.record {
            Some(output) => RecorderChild::start(&ChildOptions {
                lewis_exe: options.up.lewis_exe.clone(),
                robot_path: options.up.robot_path.clone(),
                robot_name: robot.name.clone(),
                namespace: namespace.clone(),
                output: output.clone(),
                companions: options.companions,
            })?,
            None => None,
        };
        if let Some(recorder) = &recorder {
            name_the_recording(&mut robot, recorder.path());
        }
        let goal = match options.goal {
            Some(plan) => {
                let stop = signals.handle();
                Some(GoalRun::start(plan, namespace, move || stop.stop())?)
            }
            None => None,
        };
        let mut mission = match &options.mission {
            Some(plan) => {
                let stop = signals.handle();
                // The supervisor's page shows this robot beside the question.
                let watch = RobotWatchOptions::from_robot(&robot, &options.up.robot_path);
                Some(BesideBroker::start_watching(
                    &plan.script,
                    plan.mission.clone(),
                    &plan.options,
                    Some(watch),
                    namespace,
                    move || stop.stop(),
                )?)
            }
            None => None,
        };
        let mut mission_outcome = None;
        let mut finish = || {
            // The mission ends before the recorder stops, which records its last decisions.
            if let Some(run) = mission.take() {
                mission_outcome = Some(run.finish("lewis up ended"));
            }
            // Stopped after the services (it records their last words and the broker's stop
            // decisions) and before the broker's channels close.
            if let Some(recorder) = recorder.take() {
                recorder.stop();
            }
        };
        // Reborrowed for the run's own borrows of the robot and its options.
        let remote = remote.map(|r| -> &mut dyn RemoteHosts { r });
        let up = run_up_with_hosts(&robot, &options.up, &signals, &mut finish, remote);
        // When the broker could not run, `finish` has not run yet.
        finish();
        let goal = goal.map(GoalRun::finish).transpose();
        drop(machine);
        // Every process of the run has ended: what it made in shared memory (channels,
        // publication ledgers) goes with it, so no run leaves anything behind. Another
        // host's bridge still running keeps the namespace, and its `lewis up` wipes it.
        let _ = lewis_runtime::ipc::wipe_ended(namespace);
        let up = up?;
        tracing::info!("broker down ({}), {} decisions", up.ended_by, up.decisions);
        Ok(LaunchReport {
            up,
            goal: goal?,
            mission: mission_outcome.transpose()?,
        })
    }
}

/// Names the recording at `path` to every service of `robot` ([`RECORDING_ENV`]), so one
/// that writes files of its own puts them beside it; a service's own `environment` wins.
fn name_the_recording(robot: &mut Robot, path: &Path) {
    let path = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
    let path = path.to_string_lossy();
    for service in &mut robot.services {
        service
            .environment
            .entry(RECORDING_ENV.to_owned())
            .or_insert_with(|| path.clone().into_owned());
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::time::Duration;

    use lewis_runtime::ipc::Namespace;
    use lewis_runtime::live::ClockSource;

    use super::*;

    #[test]
    fn every_service_learns_where_the_recording_goes_unless_it_says_otherwise() {
        let robot_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml");
        let mut robot = lewis_robot::load(&robot_path, &lewis_interfaces::interface_names())
            .unwrap_or_else(|e| panic!("{e}"));
        robot.services[0]
            .environment
            .insert(RECORDING_ENV.to_owned(), "/elsewhere.mcap".to_owned());
        name_the_recording(&mut robot, Path::new("/logs/run.mcap"));
        assert_eq!(
            robot.services[0].environment[RECORDING_ENV],
            "/elsewhere.mcap"
        );
        for service in &robot.services[1..] {
            assert_eq!(service.environment[RECORDING_ENV], "/logs/run.mcap");
        }
    }

    #[test]
    fn a_stop_handle_ends_the_run_as_a_request() {
        // Every service of the test bench starts on demand: nobody asks, nothing starts.
        let robot_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml");
        let robot = lewis_robot::load(&robot_path, &lewis_interfaces::interface_names())
            .unwrap_or_else(|e| panic!("{e}"));
        let options = LaunchOptions {
            up: UpOptions {
                robot_path,
                namespace: Namespace::unique("launch-stop"),
                lewis_exe: PathBuf::from("/nonexistent/lewis"),
                duration: None,
                stop_grace: Duration::from_millis(100),
                clock: ClockSource::Wall,
            },
            record: None,
            companions: None,
            goal: None,
            mission: None,
        };
        let launch = Launch::new(robot, options).unwrap_or_else(|e| panic!("{e}"));
        let stop = launch.stop_handle();
        let stopper = std::thread::spawn(move || stop.stop());
        let report = launch.run().unwrap_or_else(|e| panic!("{e}"));
        stopper
            .join()
            .unwrap_or_else(|_| panic!("the stopping thread panicked"));
        assert_eq!(report.up.ended_by, "request");
        assert!(report.succeeded(), "nothing was asked, so nothing failed");
    }
}
