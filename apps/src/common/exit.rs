//! The programs' exit codes: the contract with the mission script (`robots/missions/*.seq`).
//!
//! 3 and 4 are not listed in `challenge.seq`, so the sequencer goes to its recovery state at
//! once; a panic (101) or a signal is a crash, which it restarts.

/// The sub-task succeeded.
pub const SUCCESS: i32 = 0;
/// SignFollower: the registration desk's sign is in sight (the queue is next).
pub const SAW_DESK: i32 = 1;
/// A required input went silent for too long: the program stopped the robot and ended.
pub const INPUT_LOST: i32 = 3;
/// Nothing to do it with (nothing found, no answer, its own time limit).
pub const GAVE_UP: i32 = 4;
