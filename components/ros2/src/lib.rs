//! The live ROS 2 gateway: a ROS 2 robot's topics as providers of Lewis interfaces, and its
//! base as Lewis's Synchrodrive, over DDS (`rustdds`: pure Rust, no ROS installation).
//!
//! One kind per sensor, so that each runs as its own process with its own health: a silent
//! `/scan` fails over alone while odometry and the base keep serving (the broker stops a
//! provider whole when its data fails a check).
//!
//! - [`sensors`]: `ros2-laser` (LaserScan), `ros2-ir` (the Create 3's IR intensities, with
//!   [`ir`]'s model), `ros2-range` (Range), `ros2-odometry` (Odometry), `ros2-battery`
//!   (BatteryState), `ros2-camera` (Image or CompressedImage);
//! - [`base`]: `ros2-base`, Synchrodrive to Twist or TwistStamped, bumpers from the Create
//!   3's hazards;
//! - [`gateway`]: what they share (the robot file's `dds` table, decoding and counting bad
//!   samples, health from the data); [`dds`]: raw CDR over rustdds.
//!
//! All are devices: a replay feeds their recorded publications.

pub mod base;
pub mod dds;
pub mod gateway;
pub mod ir;
pub mod sensors;

use lewis_service::{Role, ServiceRegistry};

/// Every kind of the gateway, by the name robot files give it.
pub const KINDS: &[&str] = &[
    base::KIND,
    sensors::LASER,
    sensors::IR,
    sensors::RANGE_KIND,
    sensors::ODOMETRY_KIND,
    sensors::BATTERY,
    sensors::CAMERA,
];

/// Registers the gateway's kinds, as devices.
pub fn register(registry: &mut ServiceRegistry) {
    sensors::register(registry);
    base::register(registry);
    for kind in KINDS {
        registry.set_role(kind, Role::Device);
    }
}
