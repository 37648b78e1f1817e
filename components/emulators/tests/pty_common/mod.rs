//! Shared by the pseudo-terminal tests: waiting with a watchdog deadline instead of sleeping.

// Helpers of tests, as the files that use them: a failed unwrap is the test failing.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::os::fd::BorrowedFd;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use lewis_drivers::io::{SickNews, SickReader};

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
pub fn conference_world() -> lewis_sim::World {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../robots/worlds/conference");
    assert!(
        dir.join("world.toml").is_file(),
        "the conference world is missing at {}: it ships with the repository",
        dir.display()
    );
    lewis_sim::World::load(&dir).unwrap()
}

/// Waits (watchdog) for the reader to have news and takes it.
pub fn next_news(reader: &SickReader) -> SickNews {
    assert!(
        wait_readable(reader.fd(), WATCHDOG),
        "the SICK reader had no news within {WATCHDOG:?}: {reader:?}"
    );
    reader.take()
}

/// Waits at most `timeout` for `fd` to be readable; whether it was.
pub fn wait_readable(fd: BorrowedFd<'_>, timeout: Duration) -> bool {
    let mut fds = [nix::poll::PollFd::new(fd, nix::poll::PollFlags::POLLIN)];
    let timeout = nix::poll::PollTimeout::try_from(timeout).unwrap_or(nix::poll::PollTimeout::MAX);
    matches!(nix::poll::poll(&mut fds, timeout), Ok(n) if n > 0)
}
