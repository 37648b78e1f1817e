//! What the two Mover implementations share: the statuses, goal ids, goals, the
//! velocity command they produce, and their errors.

use lewis_interfaces::msg::{
    MoverCommand, MoverGoto, MoverGotoReply, MoverReply, MoverRotate, MoverRotateReply, MoverStop,
    MoverStopReply, MoverTranslate, MoverTranslateReply, SynchrodriveSetVelocity,
};
use std::fmt;

/// The `status` of the Mover publication: the vocabulary declared in `Mover.xml`, with
/// [`MoverStatus::is_final`].
pub use lewis_interfaces::msg::MoverStatus;

/// The id of an accepted goal, as returned in the reply to goto, rotate and translate.
/// Ids start at 1 and increase; 0 in the publication means no goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct GoalId(i32);

impl GoalId {
    /// The first id a mover hands out.
    pub const FIRST: Self = Self(1);

    /// The id as the Mover interface carries it.
    #[must_use]
    pub const fn get(self) -> i32 {
        self.0
    }

    /// The id after this one; after `i32::MAX` it starts again at 1 (never 0, which means
    /// no goal).
    #[must_use]
    pub const fn next(self) -> Self {
        if self.0 == i32::MAX {
            Self::FIRST
        } else {
            Self(self.0 + 1)
        }
    }
}

impl fmt::Display for GoalId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// A request in terms of the Mover interface: what a client asks of a mover, and what
/// ObstacleAvoider asks of the VectorMover it moves through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MoverRequest {
    /// Go to this point of the odometry frame.
    Goto {
        /// In m.
        x_m: f64,
        /// In m.
        y_m: f64,
    },
    /// Turn in place by this angle, relative to the current heading (beyond a turn allowed).
    Rotate {
        /// Counter-clockwise positive, in rad.
        angle_rad: f64,
    },
    /// Drive straight along the current heading.
    Translate {
        /// Forward positive, backwards negative, in m.
        distance_m: f64,
    },
    /// Drop the goal and come to rest.
    Stop,
}

impl MoverRequest {
    /// The request as a Mover command message (header left empty for the sender to fill).
    #[must_use]
    pub fn to_command(self) -> MoverCommand {
        match self {
            Self::Goto { x_m, y_m } => MoverCommand::Goto(MoverGoto {
                x: x_m,
                y: y_m,
                ..Default::default()
            }),
            Self::Rotate { angle_rad } => MoverCommand::Rotate(MoverRotate {
                angle: angle_rad,
                ..Default::default()
            }),
            Self::Translate { distance_m } => MoverCommand::Translate(MoverTranslate {
                distance: distance_m,
                ..Default::default()
            }),
            Self::Stop => MoverCommand::Stop(MoverStop::default()),
        }
    }

    /// The request a Mover command message asks for.
    #[must_use]
    pub fn from_command(command: &MoverCommand) -> Self {
        match command {
            MoverCommand::Goto(m) => Self::Goto { x_m: m.x, y_m: m.y },
            MoverCommand::Rotate(m) => Self::Rotate { angle_rad: m.angle },
            MoverCommand::Translate(m) => Self::Translate {
                distance_m: m.distance,
            },
            MoverCommand::Stop(_) => Self::Stop,
        }
    }
}

/// Carries out a Mover command with `carry_out` (a mover's `request`) and builds its reply
/// (headers left empty): the goal id for goto, rotate and translate. The one place where
/// both movers turn commands into requests and goal ids into replies.
pub(crate) fn answer_command(
    command: &MoverCommand,
    carry_out: impl FnOnce(MoverRequest) -> Result<Option<GoalId>, GoalError>,
) -> Result<MoverReply, GoalError> {
    let goal_id = carry_out(MoverRequest::from_command(command))?.map_or(0, GoalId::get);
    Ok(match command {
        MoverCommand::Goto(_) => MoverReply::Goto(MoverGotoReply {
            goal_id,
            ..Default::default()
        }),
        MoverCommand::Rotate(_) => MoverReply::Rotate(MoverRotateReply {
            goal_id,
            ..Default::default()
        }),
        MoverCommand::Translate(_) => MoverReply::Translate(MoverTranslateReply {
            goal_id,
            ..Default::default()
        }),
        MoverCommand::Stop(_) => MoverReply::Stop(MoverStopReply::default()),
    })
}

/// The velocities a mover asks the synchro-drive for at one control step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VelocityCommand {
    /// Forward positive, in m/s.
    pub translation_m_s: f64,
    /// Counter-clockwise positive, in rad/s.
    pub rotation_rad_s: f64,
}

impl VelocityCommand {
    /// Both velocities zero.
    pub const ZERO: Self = Self {
        translation_m_s: 0.0,
        rotation_rad_s: 0.0,
    };

    /// The command as a Synchrodrive `set_velocity` message (header left empty).
    #[must_use]
    pub fn to_set_velocity(self) -> SynchrodriveSetVelocity {
        SynchrodriveSetVelocity {
            translation_velocity: self.translation_m_s,
            rotation_velocity: self.rotation_rad_s,
            ..Default::default()
        }
    }
}

impl From<VelocityCommand> for SynchrodriveSetVelocity {
    fn from(command: VelocityCommand) -> Self {
        command.to_set_velocity()
    }
}

/// A goal that a mover refuses.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum GoalError {
    /// An argument is NaN or infinite.
    #[error("Mover.{command}: argument {arg} is {value}, expected a finite number")]
    NotFinite {
        /// The command (goto, rotate, translate).
        command: &'static str,
        /// The argument's name in Mover.xml.
        arg: &'static str,
        /// The value received.
        value: f64,
    },
}

impl GoalError {
    pub(crate) fn check(command: &'static str, arg: &'static str, value: f64) -> Result<f64, Self> {
        if value.is_finite() {
            Ok(value)
        } else {
            Err(Self::NotFinite {
                command,
                arg,
                value,
            })
        }
    }
}

/// A configuration value out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("motion configuration: {field} = {value} is invalid, expected {expected}")]
pub struct ConfigError {
    /// The field's name.
    pub field: &'static str,
    /// The value given.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

pub(crate) fn require_positive(field: &'static str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ConfigError {
            field,
            value,
            expected: "a finite number > 0",
        })
    }
}

pub(crate) fn require_non_negative(field: &'static str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ConfigError {
            field,
            value,
            expected: "a finite number >= 0",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_round_trip_through_their_strings() {
        for status in MoverStatus::ALL {
            assert_eq!(status.as_str().parse::<MoverStatus>(), Ok(status));
        }
        assert_eq!("lost".parse::<MoverStatus>().unwrap_err().word, "lost");
    }

    #[test]
    fn goal_ids_skip_zero_when_they_wrap() {
        assert_eq!(GoalId::FIRST.get(), 1);
        assert_eq!(GoalId(i32::MAX).next(), GoalId::FIRST);
        assert_eq!(GoalId::FIRST.next().get(), 2);
    }

    #[test]
    fn requests_round_trip_through_commands() {
        for request in [
            MoverRequest::Goto {
                x_m: 1.0,
                y_m: -2.0,
            },
            MoverRequest::Rotate { angle_rad: 0.5 },
            MoverRequest::Translate { distance_m: -0.3 },
            MoverRequest::Stop,
        ] {
            assert_eq!(MoverRequest::from_command(&request.to_command()), request);
        }
    }
}
