//! Lewis recordings for other tools: [`ros2`] (`lewis export ros2`) copies a recording with
//! companion channels of ROS 2's standard types beside its own.

pub mod ros2;
