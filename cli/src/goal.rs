//! `lewis up ROBOT --goal X,Y`: drive the robot to a goal, then stop.
//!
//! Beside the broker, a thread of `lewis up` is a client of the robot like any other (IPC,
//! node `lewis-goal`): a `Client<Mover>` that the broker binds to the best Mover provider
//! (ObstacleAvoider on the simulated B21r), plus GroundTruth and Egomotion clients when the
//! robot has a GroundTruth provider (the simulator). It sends `goto`, follows the Mover
//! status, and when the goal ends (arrived, failed, timed out, or the simulator counted a
//! collision) it asks the Mover to stop and sends SIGTERM to its own process, which stops
//! the broker and the services as Ctrl-C would. The exit code says how the goal ended.
//!
//! Goals are in the world frame by default: the first GroundTruth and Egomotion samples
//! (taken while the robot is still at rest) give the odometry frame's place in the world,
//! and the goal is sent in the odometry frame, which is the Mover's. `--goal-frame odom`
//! sends it as given (a robot without a simulator).
//!
//! When the Mover provider changes (failover, or a restart that lost the goal), the goal is
//! sent again to whoever serves Mover now.

use std::os::fd::AsFd;
use std::process::ExitCode;
use std::rc::Rc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::{Args, ValueEnum};
use lewis_interfaces::msg::{Egomotion, GroundTruth, Mover, MoverGoto, MoverStop, Pose2D};
use lewis_runtime::client::{Client, ClientError};
use lewis_runtime::ipc::{CallError, FdSource, Ipc, Namespace, WaitSet, Waitable, WakeMode};
use lewis_runtime::live::StopSignals;
use lewis_runtime::robot::Robot;

/// The client name of the goal thread (and its IPC node).
pub const GOAL_CLIENT: &str = "lewis-goal";

/// How long a call to the Mover may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// How often progress is logged while driving.
const PROGRESS_EVERY: Duration = Duration::from_secs(5);

/// How soon the goal is sent again to a Mover whose process is not serving commands yet:
/// the broker binds a client to a provider it starts at once, while the process comes up.
const NOT_SERVING_RETRY: Duration = Duration::from_millis(20);

/// The goal options of `lewis up`.
#[derive(Debug, Clone, Args)]
pub struct GoalArgs {
    /// Drive to this point (metres, `X,Y`), then stop: exit 0 when the Mover says arrived,
    /// 1 on timeout, on a collision counted by the simulator, or when the Mover gives up.
    #[arg(long, value_name = "X,Y", value_parser = parse_goal, allow_hyphen_values = true)]
    pub goal: Option<Goal>,
    /// The frame of --goal: `world` (the simulator's map; needs a GroundTruth provider) or
    /// `odom` (odometry: the robot starts at 0,0 facing +x).
    #[arg(long, value_enum, default_value_t = GoalFrame::World, value_name = "FRAME")]
    pub goal_frame: GoalFrame,
    /// How long the robot has to arrive (`120s`, `5m`), counted from the start of `lewis up`.
    #[arg(long, value_name = "DURATION", default_value = "5m", value_parser = lewis_stdx::parse_duration)]
    pub goal_timeout: Duration,
}

/// A goal point, in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// In m.
    pub x_m: f64,
    /// In m.
    pub y_m: f64,
}

/// The frame a goal is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GoalFrame {
    /// The world (map) frame of the simulator.
    World,
    /// The odometry frame.
    Odom,
}

fn parse_goal(text: &str) -> Result<Goal, String> {
    let bad = || format!("`{text}`: give the goal as X,Y in metres, e.g. 12.5,13");
    let (x, y) = text.split_once(',').ok_or_else(bad)?;
    let number = |s: &str| {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(bad)
    };
    Ok(Goal {
        x_m: number(x)?,
        y_m: number(y)?,
    })
}

/// How a goal ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The Mover said arrived.
    Arrived,
    /// The Mover gave the goal up.
    Failed,
    /// The time ran out.
    TimedOut,
    /// The simulator counted a collision.
    Collision {
        /// Collisions counted since the goal was sent.
        count: i32,
    },
    /// A stop signal came first.
    Interrupted,
}

impl Outcome {
    /// The exit code of `lewis up` for this outcome.
    #[must_use]
    pub fn exit_code(&self) -> ExitCode {
        match self {
            Self::Arrived => ExitCode::SUCCESS,
            _ => ExitCode::from(1),
        }
    }
}

/// The goal thread, running beside the broker.
#[derive(Debug)]
pub struct GoalRun {
    thread: JoinHandle<anyhow::Result<Outcome>>,
}

/// Starts driving to the goal, if one was given. Call before the broker runs: the thread
/// waits for the broker to bind it.
///
/// # Errors
/// When the goal cannot be driven on this robot (a world goal without GroundTruth, a
/// timeout that is not a number of seconds) or the thread cannot start.
pub fn start(
    args: &GoalArgs,
    robot: &Robot,
    namespace: &Namespace,
) -> anyhow::Result<Option<GoalRun>> {
    let Some(goal) = args.goal else {
        return Ok(None);
    };
    let timeout = args.goal_timeout;
    let provides = |interface: &str| {
        robot
            .services
            .iter()
            .any(|s| s.provision(interface).is_some())
    };
    anyhow::ensure!(
        provides("Mover"),
        "--goal: robot `{}` has no service that provides Mover: add a vector_mover or an obstacle_avoider",
        robot.name
    );
    let has_truth = provides("GroundTruth");
    anyhow::ensure!(
        has_truth || args.goal_frame == GoalFrame::Odom,
        "--goal in the world frame needs a GroundTruth provider (the simulator's sim-base), which robot `{}` has not: give --goal-frame odom",
        robot.name
    );
    // Installed before the thread starts, so that its SIGTERM at the end can never meet a
    // process without a handler, and so that Ctrl-C ends it too.
    let signals = StopSignals::install().context("cannot catch SIGTERM and SIGINT")?;
    let plan = Plan {
        goal,
        frame: args.goal_frame,
        has_truth,
        deadline: Instant::now() + timeout,
        timeout,
        namespace: namespace.clone(),
    };
    let thread = std::thread::Builder::new()
        .name("lewis-goal".into())
        .spawn(move || {
            let outcome = plan.drive(&signals);
            // Whatever happened, the run is over: stop the broker as Ctrl-C would.
            let _ = nix::sys::signal::kill(nix::unistd::Pid::this(), nix::sys::signal::SIGTERM);
            outcome
        })
        .context("cannot start the goal thread")?;
    Ok(Some(GoalRun { thread }))
}

impl GoalRun {
    /// Waits for the goal thread (the broker has stopped) and returns the exit code.
    ///
    /// # Errors
    /// When the goal thread failed (IPC, a refused goal).
    pub fn finish(self) -> anyhow::Result<ExitCode> {
        let outcome = self
            .thread
            .join()
            .map_err(|_| anyhow::anyhow!("the goal thread panicked"))??;
        match &outcome {
            Outcome::Arrived => tracing::info!("goal reached"),
            Outcome::Failed => tracing::error!("goal not reached: the Mover gave it up"),
            Outcome::TimedOut => tracing::error!("goal not reached: --goal-timeout ran out"),
            Outcome::Collision { count } => {
                tracing::error!("goal not reached: the robot collided ({count} collisions)");
            }
            Outcome::Interrupted => tracing::warn!("goal not reached: interrupted"),
        }
        Ok(outcome.exit_code())
    }
}

/// What the goal thread does.
struct Plan {
    goal: Goal,
    frame: GoalFrame,
    has_truth: bool,
    deadline: Instant,
    timeout: Duration,
    namespace: Namespace,
}

/// The clients of the goal thread.
struct Clients {
    mover: Client<Mover>,
    truth: Option<Client<GroundTruth>>,
    odometry: Option<Client<Egomotion>>,
}

/// What the goal thread has seen.
#[derive(Debug, Default)]
struct Watch {
    /// The goal in the odometry frame, once known.
    goal_in_odom: Option<(f64, f64)>,
    first_truth: Option<GroundTruth>,
    first_odometry: Option<Pose2D>,
    /// The provider the goal was sent to, its goal id, and the provider's time of the reply.
    sent: Option<(String, i32, i64)>,
    collisions_at_start: Option<i32>,
    last_truth: Option<GroundTruth>,
    last_status: Option<Mover>,
    /// When to send the goal again to a Mover that was not serving commands yet.
    retry_at: Option<Instant>,
}

impl Watch {
    fn log_progress(&self) {
        if let Some(status) = &self.last_status {
            tracing::info!(
                "{} {}: {:.2} m to go, waypoint {:.2},{:.2}",
                status.header.provider,
                status.status,
                status.distance_to_goal,
                status.waypoint.x,
                status.waypoint.y
            );
        } else if self.sent.is_none() {
            tracing::info!("waiting for the broker to bind Mover and for the robot's pose");
        }
    }
}

impl Plan {
    fn drive(&self, signals: &StopSignals) -> anyhow::Result<Outcome> {
        let ipc = Rc::new(
            Ipc::open(&self.namespace, GOAL_CLIENT).context("cannot open the goal client's IPC")?,
        );
        let mut clients = Clients {
            mover: Client::connect(&ipc, GOAL_CLIENT)?,
            truth: self
                .has_truth
                .then(|| Client::connect(&ipc, GOAL_CLIENT))
                .transpose()?,
            odometry: (self.frame == GoalFrame::World)
                .then(|| Client::connect(&ipc, GOAL_CLIENT))
                .transpose()?,
        };
        let mut watch = Watch::default();
        if self.frame == GoalFrame::Odom {
            watch.goal_in_odom = Some((self.goal.x_m, self.goal.y_m));
        }
        let waits = WaitSet::new(WakeMode::Event);
        let mut next_progress = Instant::now() + PROGRESS_EVERY;
        let outcome = loop {
            if signals.take() {
                break Outcome::Interrupted;
            }
            if let Some(outcome) = self.step(&mut clients, &mut watch)? {
                break outcome;
            }
            let now = Instant::now();
            if now >= self.deadline {
                break Outcome::TimedOut;
            }
            if now >= next_progress {
                watch.log_progress();
                next_progress = now + PROGRESS_EVERY;
            }
            let signal_fd = FdSource::new(signals.as_fd());
            let mut sources: Vec<&dyn Waitable> = vec![&signal_fd];
            let mover = clients.mover.raw_mut();
            let mut deadline = self.deadline.min(next_progress);
            deadline = watch.retry_at.map_or(deadline, |d| d.min(deadline));
            deadline = mover.deadline().map_or(deadline, |d| d.min(deadline));
            sources.extend(mover.waitables());
            for raw in [
                clients.truth.as_mut().map(Client::raw_mut),
                clients.odometry.as_mut().map(Client::raw_mut),
            ]
            .into_iter()
            .flatten()
            {
                deadline = raw.deadline().map_or(deadline, |d| d.min(deadline));
                sources.extend(raw.waitables());
            }
            waits.wait(&sources, Some(deadline))?;
        };
        if outcome != Outcome::Interrupted && watch.sent.is_some() {
            // Best effort: the services stop right after anyway.
            let _ = clients.mover.call(&MoverStop::default(), CALL_TIMEOUT);
        }
        if let Some(truth) = &watch.last_truth {
            tracing::info!(
                "the robot ends at x {:.2} m, y {:.2} m (world), {} collisions",
                truth.pose.x,
                truth.pose.y,
                truth.collisions - watch.collisions_at_start.unwrap_or(0)
            );
        }
        Ok(outcome)
    }

    /// Takes in what arrived; the outcome once the goal is over.
    fn step(&self, clients: &mut Clients, watch: &mut Watch) -> anyhow::Result<Option<Outcome>> {
        if let Some(truth) = &mut clients.truth {
            while let Some(sample) = truth.try_recv()? {
                let sample = sample.message;
                let start = *watch.collisions_at_start.get_or_insert(sample.collisions);
                if sample.collisions > start {
                    let count = sample.collisions - start;
                    watch.last_truth = Some(sample);
                    return Ok(Some(Outcome::Collision { count }));
                }
                if watch.first_truth.is_none() {
                    watch.first_truth = Some(sample.clone());
                }
                watch.last_truth = Some(sample);
            }
        }
        if let Some(odometry) = &mut clients.odometry {
            while let Some(sample) = odometry.try_recv()? {
                if watch.first_odometry.is_none() {
                    watch.first_odometry = Some(sample.message.pose);
                }
            }
        }
        if watch.goal_in_odom.is_none()
            && let (Some(truth), Some(odometry)) = (&watch.first_truth, &watch.first_odometry)
        {
            let (x, y) = goal_in_odom(self.goal, &truth.pose, odometry);
            tracing::info!(
                "goal {:.2},{:.2} (world) is {x:.2},{y:.2} in the odometry frame",
                self.goal.x_m,
                self.goal.y_m
            );
            watch.goal_in_odom = Some((x, y));
        }
        let mut latest = None;
        while let Some(sample) = clients.mover.try_recv()? {
            latest = Some(sample.message);
        }
        let provider = clients.mover.provider().map(str::to_owned);
        let (Some(provider), Some(goal)) = (provider, watch.goal_in_odom) else {
            return Ok(None);
        };
        if let Some(status) = latest {
            watch.last_status = Some(status);
        }
        let resend = match (&watch.sent, &watch.last_status) {
            (None, _) => true,
            (Some((to, _, _)), _) if *to != provider => {
                tracing::warn!("Mover moved from {to} to {provider}: sending the goal again");
                true
            }
            (Some((_, goal_id, replied_ns)), Some(status))
                if status.header.provider == provider
                    && status.header.publish_time_ns > *replied_ns
                    && status.goal_id != *goal_id =>
            {
                tracing::warn!(
                    "{provider} no longer pursues goal {goal_id} (it says goal {}, {}): sending the goal again",
                    status.goal_id,
                    status.status
                );
                true
            }
            _ => false,
        };
        if resend {
            if watch.retry_at.is_some_and(|at| Instant::now() < at) {
                return Ok(None);
            }
            let goto = MoverGoto {
                x: goal.0,
                y: goal.1,
                ..MoverGoto::default()
            };
            let reply = match clients.mover.call(&goto, CALL_TIMEOUT) {
                Ok(reply) => reply,
                Err(ClientError::Call(CallError::NoServer { .. })) => {
                    tracing::debug!("{provider} does not serve commands yet: the goal waits");
                    watch.retry_at = Some(Instant::now() + NOT_SERVING_RETRY);
                    return Ok(None);
                }
                Err(e) => return Err(e.into()),
            };
            watch.retry_at = None;
            tracing::info!(
                "goal {} sent to {provider}: {:.2},{:.2} (odometry frame), {} s to arrive",
                reply.goal_id,
                goal.0,
                goal.1,
                self.timeout.as_secs_f64()
            );
            watch.sent = Some((provider, reply.goal_id, reply.header.publish_time_ns));
            watch.last_status = None;
            return Ok(None);
        }
        let (Some((to, goal_id, _)), Some(status)) = (&watch.sent, &watch.last_status) else {
            return Ok(None);
        };
        if status.header.provider != *to || status.goal_id != *goal_id {
            return Ok(None);
        }
        Ok(match status.status.as_str() {
            "arrived" => Some(Outcome::Arrived),
            "failed" => Some(Outcome::Failed),
            _ => None,
        })
    }
}

/// The goal, given in the world frame, in the odometry frame, from the robot's true pose
/// (world) and its odometry pose at the same moment.
#[must_use]
pub fn goal_in_odom(goal: Goal, truth: &Pose2D, odometry: &Pose2D) -> (f64, f64) {
    // The goal in the robot's frame, from the truth...
    let (dx, dy) = (goal.x_m - truth.x, goal.y_m - truth.y);
    let (sin, cos) = truth.theta.sin_cos();
    let (rx, ry) = (cos * dx + sin * dy, -sin * dx + cos * dy);
    // ...then into the odometry frame, from the odometry pose.
    let (sin, cos) = odometry.theta.sin_cos();
    (
        odometry.x + cos * rx - sin * ry,
        odometry.y + sin * rx + cos * ry,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goals_are_read_as_two_numbers_and_anything_else_is_refused() {
        fn check(text: &str, expected: Option<(f64, f64)>) {
            let got = parse_goal(text).ok().map(|g| (g.x_m, g.y_m));
            assert_eq!(got, expected, "{text}");
        }
        check("12.5,13", Some((12.5, 13.0)));
        check("-1, 2", Some((-1.0, 2.0)));
        check("12.5", None);
        check("a,b", None);
        check("1,inf", None);
        check("1,2,3", None);
        assert_eq!(
            parse_goal("x").unwrap_err(),
            "`x`: give the goal as X,Y in metres, e.g. 12.5,13"
        );
    }

    #[test]
    fn world_goals_are_moved_into_the_odometry_frame() {
        fn check(
            goal: (f64, f64),
            truth: (f64, f64, f64),
            odom: (f64, f64, f64),
            expected: (f64, f64),
        ) {
            let pose = |(x, y, theta)| Pose2D { x, y, theta };
            let (x, y) = goal_in_odom(
                Goal {
                    x_m: goal.0,
                    y_m: goal.1,
                },
                &pose(truth),
                &pose(odom),
            );
            assert!(
                (x - expected.0).abs() < 1e-9 && (y - expected.1).abs() < 1e-9,
                "{goal:?} from {truth:?}/{odom:?}: got {x},{y}, expected {expected:?}"
            );
        }
        let half_pi = std::f64::consts::FRAC_PI_2;
        // Odometry starts at zero where the robot stands: the goal relative to the start.
        check((12.0, 13.0), (3.0, 12.5, 0.0), (0.0, 0.0, 0.0), (9.0, 0.5));
        // Facing north: ahead is +y of the world.
        check(
            (3.0, 15.5),
            (3.0, 12.5, half_pi),
            (0.0, 0.0, 0.0),
            (3.0, 0.0),
        );
        // Odometry that reads 1,1 facing -y.
        check(
            (4.0, 12.5),
            (3.0, 12.5, 0.0),
            (1.0, 1.0, -half_pi),
            (1.0, 0.0),
        );
    }
}
