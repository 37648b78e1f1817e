//! Shared by the pseudo-terminal tests: waiting with a watchdog deadline instead of sleeping.

#![allow(dead_code)]

use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The longest any awaited condition may take before a test fails (a watchdog, not a timing
/// assertion: the conditions normally hold within a fraction of it).
pub const WATCHDOG: Duration = Duration::from_secs(15);

/// Calls `step` on `subject` until it returns `Some`, failing with `what` and
/// `context(subject)` past the watchdog.
pub fn await_some<S, T>(
    what: &str,
    subject: &mut S,
    mut step: impl FnMut(&mut S) -> Option<T>,
    context: impl Fn(&S) -> String,
) -> T {
    let deadline = Instant::now() + WATCHDOG;
    loop {
        if let Some(value) = step(subject) {
            return value;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: not within {WATCHDOG:?}; {}",
            context(subject)
        );
    }
}

/// The simulator's conference world, failing clearly when it is missing.
pub fn conference_world() -> lewis_services::sim::World {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../robots/worlds/conference");
    assert!(
        dir.join("world.toml").is_file(),
        "the conference world is missing at {}: it ships with the repository",
        dir.display()
    );
    lewis_services::sim::World::load(&dir).unwrap()
}
