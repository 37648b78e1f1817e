//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.
//! Own binaries (see `Cargo.toml`): `sim_drive` and `record_stress`, which measure the
//! machine's pace (a closed-loop drive in real time, 30 MB/s recorded without a loss) and
//! ran alone before; beside another end-to-end test, the stress recorder lost samples.

mod b21r_fake;
mod bench_long;
mod docs;
mod export_ros2;
mod failover_blame;
mod failover_cli;
mod failover_crash;
mod failover_data;
mod failover_health;
mod failover_processes;
mod import_carmen;
mod import_ros2;
mod interop_ros2;
mod layers;
mod play;
mod record_common;
mod record_discover;
mod record_errors;
mod record_failover;
mod record_kill;
mod record_lost_at_exit;
mod record_mission;
mod record_up;
mod replay_reference;
mod replay_ros2;
mod ros2_live;
mod suite_cli;
mod suite_slurm;
mod tune;
mod tune_labels;
mod tune_open;
mod up_priority;
