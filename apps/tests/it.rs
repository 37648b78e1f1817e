//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.
//!
//! The programs run in closed loop with the simulated robot's services
//! (`robots/sim.toml`, built with `lewis_kinds::registry()`) in a
//! [`lewis_testkit::scene::Scene`] on a virtual clock.

mod anywhere;
mod door;
mod failsafe;
mod mover;
mod queue;
mod recovery;
mod register;
mod sign;
mod support;
