//! Driving a robot to one goal, as `lewis up --goal X,Y` does: a client of the robot like
//! any other, bound by the broker to the best Mover provider.
//!
//! [`GoalPolicy`] is the pure core: it takes what the clients received and the time as
//! arguments and says what to do next (send the goal to the Mover that serves now, wait,
//! or stop with an [`Outcome`]). It decides when a goal is sent again: after a failover to
//! another provider, or when a restarted provider no longer pursues it. `lewis_launch::goal`
//! runs it on a thread over IPC clients.
//!
//! Goals are in the world frame by default: the first GroundTruth and Egomotion samples
//! (taken while the robot is still at rest) give the odometry frame's place in the world,
//! and the goal is sent in the odometry frame, which is the Mover's. [`GoalFrame::Odom`]
//! sends it as given (a robot without a simulator).

mod policy;

pub use policy::{
    Goal, GoalFrame, GoalPolicy, GoalStep, NOT_SERVING_RETRY, Outcome, UnknownFrame, goal_in_odom,
};
