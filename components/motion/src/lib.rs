//! Motion: the two Mover implementations of the paper, as plain structs with no clock and
//! no I/O (time comes in as nanoseconds, poses and readings as arguments).
//!
//! - [`VectorMover`] moves the robot straight to a goal, closed on the odometry pose, and
//!   produces Synchrodrive velocities within velocity and acceleration limits.
//! - [`ObstacleAvoider`] serves the same Mover goals around obstacles, from a RangeFinder
//!   (laser or sonar) or a Distance reading, by the paper's greedy strategy; it yields
//!   [`MoverRequest`]s for a VectorMover, either one in another service or the one
//!   [`AvoiderDrive`] owns. Its steps plan; its reflex ([`ObstacleAvoider::react`]) checks
//!   each reading as it comes against the motion under way and asks for a stop at once.
//!
//! [`goal`] drives a robot to one point through whichever Mover the broker binds (`lewis up
//! --goal`): a pure policy that decides when to send the goal again after a failover, and
//! the thread that runs it over IPC.
//!
//! The service kinds in [`service`] (`vector_mover`, `obstacle_avoider`) feed them
//! Egomotion, readings and commands, and publish their Mover status.
//!
//! It knows no device and no simulator: readings come through the interfaces from whichever
//! provider the broker binds, and vectors, poses and angles are `lewis-geometry`'s.

mod avoider_drive;
pub mod cost_map;
pub mod free_space;
pub mod goal;
mod mover;
mod obstacle_avoider;
pub mod scan;
pub mod service;
mod vector_mover;

pub use avoider_drive::AvoiderDrive;
pub use mover::{ConfigError, GoalError, GoalId, MoverRequest, MoverStatus, VelocityCommand};
pub use obstacle_avoider::{
    AvoiderStep, HoldReason, ObserveError, ObstacleAvoider, ObstacleAvoiderConfig,
};
pub use scan::{Beam, RangeScan, ScanError};
pub use vector_mover::{VectorMover, VectorMoverConfig};
