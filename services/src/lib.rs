//! Lewis services: device drivers (SICK laser, RFlex base, camera), the simulator,
//! motion (VectorMover, ObstacleAvoider) and perception (BlobFinder, BlobFinder3D,
//! SignDetector).
//!
//! Services see only the runtime's `Context`: they know nothing of recording or replay.

pub mod camera;
pub mod drivers;
pub mod motion;
pub mod perception;
pub mod sim;
pub mod testing;
