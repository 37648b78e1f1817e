//! The Robot Challenge's sub-task programs: DoorNavigator, SignFollower, QueueStander,
//! Register and Recovery, each a small program that the sequencer starts as its own process
//! and whose exit code the mission script routes.
//!
//! It owns what each program decides from what the robot senses. A program is written like
//! a service ([`lewis_service::Service`]: event driven, time only from the context's
//! clock, no threads, no sleeps, no blocking reads) against interfaces only (Mover,
//! RangeFinder, Distance, Egomotion, Blobs, Blobs3D, Signs, Speech), so the broker can fail
//! any provider under it and a lockstep harness can run it like any service. It does not own
//! any device, simulator, world or another component's code, and it never reads the
//! simulator's truth (GroundTruth, WorldState) or the world file: a program sees what the
//! robot's sensors see.

pub mod app;
pub mod common;
pub mod door;
pub mod queue;
pub mod recovery;
pub mod register;
pub mod sign;

pub use app::App;
