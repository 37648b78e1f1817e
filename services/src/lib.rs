//! Lewis services: device drivers (SICK laser, RFlex base, camera), the simulator,
//! motion (VectorMover, ObstacleAvoider), perception (BlobFinder, BlobFinder3D,
//! SignDetector) and Distance from any RangeFinder (`range_distance`).
//!
//! Services see only the runtime's `Context`: they know nothing of recording or replay.

pub mod camera;
pub mod drivers;
pub mod motion;
pub mod perception;
pub mod range_distance;
pub mod sim;
pub mod testing;
