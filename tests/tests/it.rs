//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.
//! Own binaries (see `Cargo.toml`): `sim_drive`.

mod b21r_fake;
mod bench_long;
mod failover_cli;
mod failover_crash;
mod failover_health;
mod failover_processes;
mod import_carmen;
mod interop_ros2;
mod layers;
mod play;
mod record_common;
mod record_discover;
mod record_errors;
mod record_failover;
mod record_kill;
mod record_mission;
mod record_stress;
mod record_up;
mod replay_reference;
mod replay_ros2;
mod tune;
