//! The ROS 2 mappings both ways, in one place for everything that speaks ROS 2: the
//! recorder's companion channels and `lewis export ros2` (Lewis to ROS 2), `lewis import
//! ros2` (ROS 2 to Lewis), and the live ROS 2 gateway (`lewis-ros2`: a real ROS 2
//! robot's `/scan` and `/odom` in, `/cmd_vel` out), which shares them without the recorder
//! or the importers.
//!
//! - [`to_ros2`]: one Lewis message to its ROS 2 message(s), as values of
//!   [`lewis_interfaces::ros2`] that encode to CDR: a RangeFinder to a LaserScan or a
//!   PointCloud2 in its sensor's frame, an Egomotion to an Odometry and the `odom` to
//!   `base_link` transform, an ImageSource to a CompressedImage, Blobs3D, Signs and the
//!   broker's bindings to a MarkerArray, a velocity command to a Twist.
//! - [`robot`]: the messages of a live robot the import does not read (Range,
//!   BatteryState, the Create 3's IR and hazards, TwistStamped), their texts and DDS names.
//! - [`from_ros2`]: one decoded ROS 2 message (a value tree of
//!   [`lewis_interfaces::dynamic`]) to a Lewis one: a LaserScan to a RangeFinder, an
//!   Odometry or a TF odometry transform to a pose, an Image or CompressedImage to an
//!   ImageSource.
//! - [`qos`]: the QoS a publisher offers, as MCAP's `ros2` profile writes it on every
//!   channel (`offered_qos_profiles`).
//!
//! Pure functions over messages: no topics, no channels, no files, no IPC. Where a message
//! goes (its topic, its channel, what is counted when it cannot be converted) is the
//! caller's.

pub mod from_ros2;
pub mod qos;
pub mod robot;
pub mod to_ros2;
