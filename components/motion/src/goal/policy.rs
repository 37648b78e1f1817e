//! The goal's decisions, with no I/O and no clock: samples and the time come in as
//! arguments.

use std::fmt;
use std::str::FromStr;
use std::time::{Duration, Instant};

use lewis_interfaces::msg::{GroundTruth, Mover, Pose2D};

use crate::MoverStatus;

/// How soon the goal is sent again to a Mover whose process is not serving commands yet:
/// the broker binds a client to a provider it starts at once, while the process comes up.
pub const NOT_SERVING_RETRY: Duration = Duration::from_millis(20);

/// A goal point, in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// In m.
    pub x_m: f64,
    /// In m.
    pub y_m: f64,
}

impl FromStr for Goal {
    type Err = String;

    /// Reads `X,Y` in metres (`12.5,13`); anything else is refused with an example.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || format!("`{text}`: give the goal as X,Y in metres, e.g. 12.5,13");
        let (x, y) = text.split_once(',').ok_or_else(bad)?;
        let number = |s: &str| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(bad)
        };
        Ok(Self {
            x_m: number(x)?,
            y_m: number(y)?,
        })
    }
}

/// The frame a goal is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GoalFrame {
    /// The world (map) frame of the simulator.
    #[default]
    World,
    /// The odometry frame.
    Odom,
}

/// A frame name that is neither `world` nor `odom`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown goal frame `{0}`: expected world or odom")]
pub struct UnknownFrame(pub String);

impl FromStr for GoalFrame {
    type Err = UnknownFrame;
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text {
            "world" => Ok(Self::World),
            "odom" => Ok(Self::Odom),
            other => Err(UnknownFrame(other.to_owned())),
        }
    }
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
    /// A stop came first (Ctrl-C, the end of the run).
    Interrupted,
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Arrived => write!(f, "goal reached"),
            Self::Failed => write!(f, "goal not reached: the Mover gave it up"),
            Self::TimedOut => write!(f, "goal not reached: --goal-timeout ran out"),
            Self::Collision { count } => {
                write!(
                    f,
                    "goal not reached: the robot collided ({count} collisions)"
                )
            }
            Self::Interrupted => write!(f, "goal not reached: interrupted"),
        }
    }
}

/// What the driver does next.
#[derive(Debug, Clone, PartialEq)]
pub enum GoalStep {
    /// Nothing to do until something arrives or [`GoalPolicy::wake_at`].
    Wait,
    /// Send `goto` to the Mover provider `to`, then say how it went
    /// ([`GoalPolicy::sent`], [`GoalPolicy::not_serving`]).
    Send {
        /// The provider that serves Mover now.
        to: String,
        /// The goal in the odometry frame, in m.
        x: f64,
        /// In m.
        y: f64,
    },
    /// The goal is over.
    Done(Outcome),
}

/// The goal to one point and everything seen on the way to it.
#[derive(Debug, Clone)]
pub struct GoalPolicy {
    goal: Goal,
    deadline: Instant,
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

impl GoalPolicy {
    /// A goal in `frame`, to be reached before `deadline`.
    #[must_use]
    pub fn new(goal: Goal, frame: GoalFrame, deadline: Instant) -> Self {
        Self {
            goal,
            deadline,
            goal_in_odom: (frame == GoalFrame::Odom).then_some((goal.x_m, goal.y_m)),
            first_truth: None,
            first_odometry: None,
            sent: None,
            collisions_at_start: None,
            last_truth: None,
            last_status: None,
            retry_at: None,
        }
    }

    /// Takes a GroundTruth sample; the outcome when the simulator counted a collision
    /// since the first sample.
    pub fn truth(&mut self, sample: GroundTruth) -> Option<Outcome> {
        let start = *self.collisions_at_start.get_or_insert(sample.collisions);
        if sample.collisions > start {
            let count = sample.collisions - start;
            self.last_truth = Some(sample);
            return Some(Outcome::Collision { count });
        }
        if self.first_truth.is_none() {
            self.first_truth = Some(sample.clone());
        }
        self.last_truth = Some(sample);
        None
    }

    /// Takes an Egomotion pose.
    pub fn odometry(&mut self, pose: Pose2D) {
        if self.first_odometry.is_none() {
            self.first_odometry = Some(pose);
        }
    }

    /// What to do at `now`, with the Mover's current `provider` and its latest status since
    /// the last step.
    pub fn step(
        &mut self,
        now: Instant,
        provider: Option<&str>,
        latest: Option<Mover>,
    ) -> GoalStep {
        match self.decide(now, provider, latest) {
            GoalStep::Wait if now >= self.deadline => GoalStep::Done(Outcome::TimedOut),
            step => step,
        }
    }

    fn decide(&mut self, now: Instant, provider: Option<&str>, latest: Option<Mover>) -> GoalStep {
        if self.goal_in_odom.is_none()
            && let (Some(truth), Some(odometry)) = (&self.first_truth, &self.first_odometry)
        {
            let (x, y) = goal_in_odom(self.goal, &truth.pose, odometry);
            tracing::info!(
                "goal {:.2},{:.2} (world) is {x:.2},{y:.2} in the odometry frame",
                self.goal.x_m,
                self.goal.y_m
            );
            self.goal_in_odom = Some((x, y));
        }
        let (Some(provider), Some((x, y))) = (provider, self.goal_in_odom) else {
            return GoalStep::Wait;
        };
        if let Some(status) = latest {
            self.last_status = Some(status);
        }
        if self.needs_sending(provider) {
            if self.retry_at.is_some_and(|at| now < at) {
                return GoalStep::Wait;
            }
            return GoalStep::Send {
                to: provider.to_owned(),
                x,
                y,
            };
        }
        let (Some((to, goal_id, _)), Some(status)) = (&self.sent, &self.last_status) else {
            return GoalStep::Wait;
        };
        if status.header.provider != *to || status.goal_id != *goal_id {
            return GoalStep::Wait;
        }
        match status.status.parse() {
            Ok(MoverStatus::Arrived) => GoalStep::Done(Outcome::Arrived),
            Ok(MoverStatus::Failed) => GoalStep::Done(Outcome::Failed),
            _ => GoalStep::Wait,
        }
    }

    /// Whether the goal must go (again) to `provider`: never sent, the Mover moved to
    /// another provider, or the provider says it pursues another goal (it restarted).
    fn needs_sending(&self, provider: &str) -> bool {
        match (&self.sent, &self.last_status) {
            (None, _) => true,
            (Some((to, _, _)), _) if to != provider => {
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
        }
    }

    /// The goal went to `provider`, which gave it `goal_id` at its time `replied_ns`.
    pub fn sent(&mut self, provider: String, goal_id: i32, replied_ns: i64) {
        self.retry_at = None;
        self.sent = Some((provider, goal_id, replied_ns));
        self.last_status = None;
    }

    /// The provider does not serve commands yet (at `now`): the goal waits a little.
    pub fn not_serving(&mut self, now: Instant) {
        self.retry_at = Some(now + NOT_SERVING_RETRY);
    }

    /// The latest time the driver must look again, whatever arrives: the goal's deadline
    /// or a retry.
    #[must_use]
    pub fn wake_at(&self) -> Instant {
        self.retry_at
            .map_or(self.deadline, |at| at.min(self.deadline))
    }

    /// Whether the goal was ever sent (then the Mover is asked to stop at the end).
    #[must_use]
    pub fn was_sent(&self) -> bool {
        self.sent.is_some()
    }

    /// Where the robot is on the way, for a progress line.
    #[must_use]
    pub fn progress(&self) -> Option<String> {
        if let Some(status) = &self.last_status {
            Some(format!(
                "{} {}: {:.2} m to go, waypoint {:.2},{:.2}",
                status.header.provider,
                status.status,
                status.distance_to_goal,
                status.waypoint.x,
                status.waypoint.y
            ))
        } else if self.sent.is_none() {
            Some("waiting for the broker to bind Mover and for the robot's pose".to_owned())
        } else {
            None
        }
    }

    /// Where the robot ended and how many collisions it had, when the simulator said.
    #[must_use]
    pub fn ending(&self) -> Option<String> {
        let truth = self.last_truth.as_ref()?;
        Some(format!(
            "the robot ends at x {:.2} m, y {:.2} m (world), {} collisions",
            truth.pose.x,
            truth.pose.y,
            truth.collisions - self.collisions_at_start.unwrap_or(0)
        ))
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
            let got = text.parse::<Goal>().ok().map(|g| (g.x_m, g.y_m));
            assert_eq!(got, expected, "{text}");
        }
        check("12.5,13", Some((12.5, 13.0)));
        check("-1, 2", Some((-1.0, 2.0)));
        check("12.5", None);
        check("a,b", None);
        check("1,inf", None);
        check("1,2,3", None);
        assert_eq!(
            "x".parse::<Goal>().unwrap_err(),
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

    /// A goal to 2,1 in the odometry frame, a minute from now, and now.
    fn odometry_goal() -> (Instant, GoalPolicy) {
        let start = Instant::now();
        let goal = Goal { x_m: 2.0, y_m: 1.0 };
        let deadline = start + Duration::from_secs(60);
        (start, GoalPolicy::new(goal, GoalFrame::Odom, deadline))
    }

    fn status(provider: &str, goal_id: i32, word: &str, at_ns: i64) -> Mover {
        let mut status = Mover {
            goal_id,
            status: word.to_owned(),
            ..Mover::default()
        };
        status.header.provider = provider.to_owned();
        status.header.publish_time_ns = at_ns;
        status
    }

    #[test]
    fn the_goal_goes_again_to_a_new_provider_and_ends_when_it_arrives() {
        let (start, mut policy) = odometry_goal();
        assert_eq!(
            policy.step(start, None, None),
            GoalStep::Wait,
            "no provider yet"
        );
        let send = |to: &str| GoalStep::Send {
            to: to.to_owned(),
            x: 2.0,
            y: 1.0,
        };
        assert_eq!(policy.step(start, Some("avoider"), None), send("avoider"));
        policy.sent("avoider".into(), 1, 100);
        let moving = status("avoider", 1, "moving", 200);
        assert_eq!(
            policy.step(start, Some("avoider"), Some(moving)),
            GoalStep::Wait
        );
        // A failover: the goal goes to whoever serves Mover now.
        assert_eq!(policy.step(start, Some("mover"), None), send("mover"));
        policy.sent("mover".into(), 1, 300);
        // A late word of the old provider is not the new one's.
        let old = status("avoider", 1, "arrived", 310);
        assert_eq!(policy.step(start, Some("mover"), Some(old)), GoalStep::Wait);
        let arrived = status("mover", 1, "arrived", 400);
        assert_eq!(
            policy.step(start, Some("mover"), Some(arrived)),
            GoalStep::Done(Outcome::Arrived)
        );
    }

    #[test]
    fn a_restarted_provider_that_forgot_the_goal_gets_it_again() {
        let (start, mut policy) = odometry_goal();
        let _ = policy.step(start, Some("avoider"), None);
        policy.sent("avoider".into(), 3, 100);
        // Its status from before the reply says nothing of the new goal.
        let before = status("avoider", 0, "idle", 90);
        assert_eq!(
            policy.step(start, Some("avoider"), Some(before)),
            GoalStep::Wait
        );
        let forgot = status("avoider", 0, "idle", 500);
        assert!(matches!(
            policy.step(start, Some("avoider"), Some(forgot)),
            GoalStep::Send { .. }
        ));
    }

    #[test]
    fn a_provider_not_serving_yet_is_asked_again_after_a_pause() {
        let (start, mut policy) = odometry_goal();
        let _ = policy.step(start, Some("avoider"), None);
        policy.not_serving(start);
        assert_eq!(policy.wake_at(), start + NOT_SERVING_RETRY);
        assert_eq!(policy.step(start, Some("avoider"), None), GoalStep::Wait);
        assert!(matches!(
            policy.step(start + NOT_SERVING_RETRY, Some("avoider"), None),
            GoalStep::Send { .. }
        ));
    }

    #[test]
    fn time_runs_out_and_collisions_end_the_goal() {
        let start = Instant::now();
        let deadline = start + Duration::from_secs(5);
        let mut policy = GoalPolicy::new(Goal { x_m: 2.0, y_m: 1.0 }, GoalFrame::World, deadline);
        // A world goal waits for the robot's pose.
        assert_eq!(policy.step(start, Some("avoider"), None), GoalStep::Wait);
        assert_eq!(
            policy.step(deadline, Some("avoider"), None),
            GoalStep::Done(Outcome::TimedOut)
        );
        let truth = |collisions| GroundTruth {
            collisions,
            ..GroundTruth::default()
        };
        assert_eq!(
            policy.truth(truth(2)),
            None,
            "counted from the first sample"
        );
        assert_eq!(policy.truth(truth(2)), None);
        assert_eq!(
            policy.truth(truth(3)),
            Some(Outcome::Collision { count: 1 })
        );
    }
}
