//! ROS 2 bags (`lewis import ros2 BAG.mcap`): the laser, odometry and camera of a rosbag2
//! MCAP file as Lewis messages, with the robot description replay needs, and the bag's own
//! messages kept beside them.
//!
//! - [`bag`] reads the bag in file order through `lewis-mcap` (damage ends the reading, it
//!   is not an error); messages are decoded by the schema-driven decoder of
//!   `lewis_interfaces::dynamic`, the one `lewis info` uses: there is no second CDR decoder.
//! - [`topics`] chooses the topic of each interface: by type when there is one of a kind,
//!   by `--map TOPIC=INTERFACE` otherwise (several candidates without a map stop the
//!   import with a list of them, never a question).
//! - [`lewis_ros2_map::from_ros2`] (the ROS 2 -> Lewis mappings, which the coming live
//!   ROS 2 gateway shares) turns a decoded message into a Lewis one: LaserScan to
//!   RangeFinder, Odometry (or TF's odom to base_link) to Egomotion, Image (rgb8, bgr8,
//!   mono8, yuv422) and CompressedImage (JPEG, PNG) to ImageSource in rgb8.
//! - [`import`] runs the passes: [`Ros2Import::open`] chooses and checks everything
//!   (range counts that change, unknown image encodings, time going backwards on a topic
//!   are refused with the topic, the message's index and its time), then
//!   [`Ros2Import::stream`] hands out the messages: the Distance computed by the
//!   `range_distance` service's code, a sonar-like fallback derived from the laser (or a
//!   second range sensor of the bag, mapped with `--map`), and the sources' heartbeats.
//! - [`robot`] writes the robot description ([`robot_toml`]).
//!
//! **Time.** A message's Lewis time (log and publish time) is its MCAP log time, the time
//! the ROS 2 recorder received it, which rosbag2 writes in order. The header stamp is the
//! publisher's clock (a sensor driver's, a simulator's, sometimes zero): it is compared to
//! the log time and the report says how far apart they are, how many differ by more than a
//! second, are zero or go backwards; it is kept unchanged in the original message. A log
//! time that goes backwards on a topic refuses the bag.
//!
//! Writing MCAP is the recorder's job (`import::record::write_ros2`).

pub mod bag;
pub mod import;
pub mod robot;
pub mod topics;

pub use import::{
    BASE, BLOBFINDER, CAMERA, DISTANCE, ImageStats, ImportError, ImportOptions, ImportReport,
    LASER, LaserStats, OdometryStats, Out, Ros2Import, SECOND_LASER, SONAR, STAMP_TOLERANCE_NS,
    StampStats,
};
pub use robot::{has_avoider, robot_name, robot_toml};
pub use topics::{Choice, ChoiceError, Role, TopicStats};
