//! The simulated B21r: a world and pure models of its devices (synchro-drive base with
//! odometry, battery and bumpers; SICK laser; sonar ring; camera), each a plain struct with
//! methods, driven by explicit time steps and seeded randomness.
//!
//! Nothing here starts a process, reads a clock or touches a file other than the world's:
//! the services that wrap these models (`sim-base`, `sim-laser`, `sim-sonar`, `sim-camera`)
//! pass time in and publish what comes out. Given a seed and the same commands, every model
//! produces the same outputs, bit for bit. Each device draws from its own generator, so
//! stopping one device does not change what the others produce.
//!
//! It owns the world and the simulated devices; the vocabulary they share with the rest of
//! the robot (poses, vectors, the angle convention, sensor mounts, Distance) is
//! `lewis-geometry`'s, and the emulators that put a world behind a real driver's port are in
//! `lewis-emulators`.

pub mod base;
pub mod camera;
pub mod geometry;
pub mod laser;
pub mod scene;
pub mod service;
pub mod sonar;
pub mod world;

pub use base::{BaseConfig, BaseConfigError, BatteryConfig, OdometryNoise, SimBase};
pub use camera::{CameraConfig, Intrinsics, PixelSource, PrimitivePart, SimCamera};
pub use geometry::{RayHit, Shape};
pub use laser::{LaserConfig, SensorConfigError, SimLaser};
pub use scene::{Scene, ScenePlan};
pub use sonar::{SimSonar, SonarConfig};
pub use world::{Hit, Surface, World, WorldError, WorldLook};
