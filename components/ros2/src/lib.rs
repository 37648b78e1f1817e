//! The live ROS 2 gateway.

pub mod dds;
