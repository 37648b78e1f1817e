//! The goal on a thread of its own, over IPC: a `Client<Mover>` that the broker binds to
//! the best Mover provider, plus GroundTruth and Egomotion clients when the robot has a
//! GroundTruth provider (the simulator), fed to a [`GoalPolicy`].

use std::os::fd::AsFd;
use std::rc::Rc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use lewis_interfaces::msg::{Egomotion, GroundTruth, Mover, MoverGoto, MoverStop};
use lewis_robot::Robot;
use lewis_runtime::client::{Client, ClientError};
use lewis_runtime::ipc::{
    CallError, FdSource, Ipc, IpcError, Namespace, WaitError, WaitSet, Waitable, WakeMode,
};
use lewis_runtime::live::{StopHandle, StopSignals};

use lewis_motion::goal::{Goal, GoalFrame, GoalPolicy, GoalStep, Outcome};

/// The client name of the goal thread (and its IPC node).
pub const GOAL_CLIENT: &str = "lewis-goal";

/// How long a call to the Mover may take.
const CALL_TIMEOUT: Duration = Duration::from_secs(2);

/// How often progress is logged while driving.
const PROGRESS_EVERY: Duration = Duration::from_secs(5);

/// Why a goal could not be driven.
#[derive(Debug, thiserror::Error)]
pub enum GoalRunError {
    /// The robot has no Mover provider.
    #[error(
        "--goal: robot `{0}` has no service that provides Mover: add a vector_mover or an obstacle_avoider"
    )]
    NoMover(String),
    /// A world goal on a robot without a GroundTruth provider.
    #[error(
        "--goal in the world frame needs a GroundTruth provider (the simulator's sim-base), which robot `{0}` has not: give --goal-frame odom"
    )]
    NoGroundTruth(String),
    /// The goal client's IPC could not be opened.
    #[error("cannot open the goal client's IPC: {0}")]
    Ipc(#[from] IpcError),
    /// A client failed (a refused goal, a broken channel).
    #[error(transparent)]
    Client(#[from] ClientError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// The thread or its signal handlers could not be set up.
    #[error("cannot start the goal thread: {0}")]
    Setup(#[source] std::io::Error),
    /// The goal thread panicked.
    #[error("the goal thread panicked")]
    Panicked,
}

/// A goal checked against the robot that drives to it.
#[derive(Debug, Clone)]
pub struct GoalPlan {
    goal: Goal,
    frame: GoalFrame,
    has_truth: bool,
    timeout: Duration,
}

impl GoalPlan {
    /// A goal in `frame` for `robot`, to be reached within `timeout`.
    ///
    /// # Errors
    /// When the robot cannot drive it: no Mover provider, or a world goal without a
    /// GroundTruth provider.
    pub fn for_robot(
        goal: Goal,
        frame: GoalFrame,
        timeout: Duration,
        robot: &Robot,
    ) -> Result<Self, GoalRunError> {
        let provides = |interface: &str| {
            robot
                .services
                .iter()
                .any(|s| s.provision(interface).is_some())
        };
        if !provides("Mover") {
            return Err(GoalRunError::NoMover(robot.name.clone()));
        }
        let has_truth = provides("GroundTruth");
        if !has_truth && frame == GoalFrame::World {
            return Err(GoalRunError::NoGroundTruth(robot.name.clone()));
        }
        Ok(Self {
            goal,
            frame,
            has_truth,
            timeout,
        })
    }
}

/// A goal being driven on its thread.
#[derive(Debug)]
pub struct GoalRun {
    thread: JoinHandle<Result<Outcome, GoalRunError>>,
    interrupt: StopHandle,
}

impl GoalRun {
    /// Starts driving to `plan`'s goal in `namespace`; its time counts from now. The thread
    /// waits for the broker to bind it, so call it before the broker runs; `on_end` runs on
    /// the thread when the goal is over, to stop the robot. Ctrl-C and SIGTERM interrupt it.
    ///
    /// # Errors
    /// When the thread or its signal handlers cannot be set up.
    pub fn start(
        plan: GoalPlan,
        namespace: &Namespace,
        on_end: impl FnOnce() + Send + 'static,
    ) -> Result<Self, GoalRunError> {
        // Installed before the thread starts, so that Ctrl-C is never missed.
        let signals = StopSignals::install().map_err(GoalRunError::Setup)?;
        let interrupt = signals.handle();
        let deadline = Instant::now() + plan.timeout;
        let namespace = namespace.clone();
        let thread = std::thread::Builder::new()
            .name("lewis-goal".into())
            .spawn(move || {
                let outcome = drive(&plan, deadline, &namespace, &signals);
                on_end();
                outcome
            })
            .map_err(GoalRunError::Setup)?;
        Ok(Self { thread, interrupt })
    }

    /// Ends the goal if it is still driven (the robot stopped first), waits for its thread
    /// and returns how it ended, which is logged.
    ///
    /// # Errors
    /// When the goal thread failed (IPC, a refused goal).
    pub fn finish(self) -> Result<Outcome, GoalRunError> {
        self.interrupt.stop();
        let outcome = self.thread.join().map_err(|_| GoalRunError::Panicked)??;
        match &outcome {
            Outcome::Arrived => tracing::info!("{outcome}"),
            Outcome::Interrupted => tracing::warn!("{outcome}"),
            _ => tracing::error!("{outcome}"),
        }
        Ok(outcome)
    }
}

/// The clients of the goal thread.
struct Clients {
    mover: Client<Mover>,
    truth: Option<Client<GroundTruth>>,
    odometry: Option<Client<Egomotion>>,
}

fn drive(
    plan: &GoalPlan,
    deadline: Instant,
    namespace: &Namespace,
    signals: &StopSignals,
) -> Result<Outcome, GoalRunError> {
    let ipc = Rc::new(Ipc::open(namespace, GOAL_CLIENT)?);
    let mut clients = Clients {
        mover: Client::connect(&ipc, GOAL_CLIENT)?,
        truth: plan
            .has_truth
            .then(|| Client::connect(&ipc, GOAL_CLIENT))
            .transpose()?,
        odometry: (plan.frame == GoalFrame::World)
            .then(|| Client::connect(&ipc, GOAL_CLIENT))
            .transpose()?,
    };
    let mut policy = GoalPolicy::new(plan.goal, plan.frame, deadline);
    let waits = WaitSet::new(WakeMode::Event);
    let mut next_progress = Instant::now() + PROGRESS_EVERY;
    let outcome = loop {
        if signals.take() {
            break Outcome::Interrupted;
        }
        if let Some(outcome) = receive(&mut clients, &mut policy)? {
            break outcome;
        }
        let mut latest = None;
        while let Some(sample) = clients.mover.try_recv()? {
            latest = Some(sample.message);
        }
        let provider = clients.mover.provider().map(str::to_owned);
        match policy.step(Instant::now(), provider.as_deref(), latest) {
            GoalStep::Done(outcome) => break outcome,
            GoalStep::Send { to, x, y } => {
                send(&mut clients.mover, &mut policy, to, x, y, plan.timeout)?;
                continue;
            }
            GoalStep::Wait => {}
        }
        let now = Instant::now();
        if now >= next_progress {
            if let Some(line) = policy.progress() {
                tracing::info!("{line}");
            }
            next_progress = now + PROGRESS_EVERY;
        }
        let signal_fd = FdSource::new(signals.as_fd());
        let mut sources: Vec<&dyn Waitable> = vec![&signal_fd];
        let mover = clients.mover.raw_mut();
        let mut wake = policy.wake_at().min(next_progress);
        wake = mover.deadline().map_or(wake, |d| d.min(wake));
        sources.extend(mover.waitables());
        for raw in [
            clients.truth.as_mut().map(Client::raw_mut),
            clients.odometry.as_mut().map(Client::raw_mut),
        ]
        .into_iter()
        .flatten()
        {
            wake = raw.deadline().map_or(wake, |d| d.min(wake));
            sources.extend(raw.waitables());
        }
        waits.wait(&sources, Some(wake))?;
    };
    if outcome != Outcome::Interrupted && policy.was_sent() {
        // Best effort: the services stop right after anyway.
        let _ = clients.mover.call(&MoverStop::default(), CALL_TIMEOUT);
    }
    if let Some(line) = policy.ending() {
        tracing::info!("{line}");
    }
    Ok(outcome)
}

/// Hands what the GroundTruth and Egomotion clients received to the policy; the outcome
/// when it ends the goal (a collision).
fn receive(
    clients: &mut Clients,
    policy: &mut GoalPolicy,
) -> Result<Option<Outcome>, GoalRunError> {
    if let Some(truth) = &mut clients.truth {
        while let Some(sample) = truth.try_recv()? {
            if let Some(outcome) = policy.truth(sample.message) {
                return Ok(Some(outcome));
            }
        }
    }
    if let Some(odometry) = &mut clients.odometry {
        while let Some(sample) = odometry.try_recv()? {
            policy.odometry(sample.message.pose);
        }
    }
    Ok(None)
}

/// Sends the goal to `to` and tells the policy how it went.
fn send(
    mover: &mut Client<Mover>,
    policy: &mut GoalPolicy,
    to: String,
    x: f64,
    y: f64,
    timeout: Duration,
) -> Result<(), GoalRunError> {
    let goto = MoverGoto {
        x,
        y,
        ..MoverGoto::default()
    };
    match mover.call(&goto, CALL_TIMEOUT) {
        Ok(reply) => {
            tracing::info!(
                "goal {} sent to {to}: {x:.2},{y:.2} (odometry frame), {} s to arrive",
                reply.goal_id,
                timeout.as_secs_f64()
            );
            policy.sent(to, reply.goal_id, reply.header.publish_time_ns);
            Ok(())
        }
        Err(ClientError::Call(CallError::NoServer { .. })) => {
            tracing::debug!("{to} does not serve commands yet: the goal waits");
            policy.not_serving(Instant::now());
            Ok(())
        }
        Err(e) => Err(e.into()),
    }
}
