//! The goal options of `lewis up` (`--goal X,Y`): what `lewis_motion::goal` drives to.

use std::time::Duration;

use clap::Args;
use lewis_launch::goal::{GoalPlan, GoalRunError};
use lewis_motion::goal::{Goal, GoalFrame};
use lewis_robot::Robot;

/// The goal options of `lewis up`.
#[derive(Debug, Clone, Args)]
pub struct GoalArgs {
    /// Drive to this point (metres, `X,Y`), then stop: exit 0 when the Mover says arrived,
    /// 1 on timeout, on a collision counted by the simulator, or when the Mover gives up.
    #[arg(long, value_name = "X,Y", value_parser = str::parse::<Goal>, allow_hyphen_values = true)]
    pub goal: Option<Goal>,
    /// The frame of --goal: `world` (the simulator's map; needs a GroundTruth provider) or
    /// `odom` (odometry: the robot starts at 0,0 facing +x).
    #[arg(long, value_parser = str::parse::<GoalFrame>, default_value = "world", value_name = "FRAME")]
    pub goal_frame: GoalFrame,
    /// How long the robot has to arrive (`120s`, `5m`), counted from the start of `lewis up`.
    #[arg(long, value_name = "DURATION", default_value = "5m", value_parser = lewis_stdx::parse_duration)]
    pub goal_timeout: Duration,
}

impl GoalArgs {
    /// The goal checked against `robot`, if one was given.
    ///
    /// # Errors
    /// When the robot cannot drive it.
    pub fn plan(&self, robot: &Robot) -> Result<Option<GoalPlan>, GoalRunError> {
        self.goal
            .map(|goal| GoalPlan::for_robot(goal, self.goal_frame, self.goal_timeout, robot))
            .transpose()
    }
}
