//! The ROS 2 mappings, in one place for everything that speaks ROS 2: `lewis import ros2`
//! (ROS 2 to Lewis) and the coming live ROS 2 gateway (`lewis-ros2`: a real ROS 2 robot's
//! `/scan` and `/odom` in), which shares them without the importers.
//!
//! - [`from_ros2`]: one decoded ROS 2 message (a value tree of
//!   [`lewis_interfaces::dynamic`]) to a Lewis one: a LaserScan to a RangeFinder, an
//!   Odometry or a TF odometry transform to a pose, an Image or CompressedImage to an
//!   ImageSource.
//!
//! Pure functions over messages: no topics, no channels, no files, no IPC. Where a message
//! goes (its topic, its channel, what is counted when it cannot be converted) is the
//! caller's.

pub mod from_ros2;
