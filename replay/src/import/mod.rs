//! Importers: logs of other robot software turned into Lewis messages, with times, and
//! written as a Lewis recording that replay can run services over.
//!
//! - [`carmen`]: CARMEN logs (the Radish data sets) as a stream of messages and a robot.
//! - [`ros2`]: ROS 2 bags (rosbag2 MCAP files) as messages, the bag's own kept, and a robot.
//! - [`record`]: an import written through the recorder (`lewis import carmen`, `lewis import ros2`).

pub mod carmen;
pub mod record;
pub mod ros2;
