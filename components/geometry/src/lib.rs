//! The vocabulary every component crate shares: plane vectors ([`Vec2`]), poses ([`Pose2`]
//! and the change of frame for the interface's `Pose2D`), the one angle convention
//! ([`wrap_angle`]: [-pi, pi)), where sensors sit on the robot ([`SensorMount`], the B21r's
//! sonar ring), and Distance from range readings ([`SectorLayout`],
//! [`distance_from_range_finder`]), which the simulated and the real drivers and the
//! `range_distance` service all publish the same way.
//!
//! It sits below the simulator, the drivers, motion and perception, so that none of them
//! borrows these sideways from another. It owns no service, no device, no world and no
//! image: pure functions and plain types, depending on the interface types alone.

pub mod angle;
pub mod distance;
pub mod mount;
pub mod pose;
pub mod vec2;

pub use angle::wrap_angle;
pub use distance::{
    RangeReading, SectorLayout, distance_from_range_finder, distance_from_readings, range_readings,
};
pub use mount::{B21R_RING_SIZE, RFLEX_BANK_SIZE, SensorMount, b21r_sonar_ring};
pub use pose::{Pose2, RobotToOdom, odom_to_robot, pose_is_finite, position, robot_to_odom};
pub use vec2::Vec2;
