//! The machine's cores kept out of deep idle while the robot runs (`[broker]
//! keep_cores_awake`), as real-time setups do (`cyclictest`, `tuned`'s latency-performance
//! profile): `lewis up` asks the kernel, through `/dev/cpu_dma_latency`, for idle states
//! that take no time to leave, so an idle core polls rather than sleeps.
//!
//! Every hop between two processes that do not spin wakes a sleeping thread. On the same
//! core that costs 2 to 5 µs; on another core it also wakes the core, 24 to 28 µs on the
//! virtual machine this was measured on, and more from the deep idle states of a laptop
//! processor. Kept awake, the other core answers in 4 to 9 µs
//! (`cargo bench -p lewis-runtime --bench wake`). The price is power: idle cores stay busy
//! polling, which a robot on batteries may not want, so it is off unless asked for.
//!
//! The kernel keeps the request only while the file is open: it ends with [`CoresAwake`],
//! or with the process however it ends, and never outlives the robot.

use std::fs::File;
use std::io::{ErrorKind, Read as _, Write as _};

/// The kernel's CPU latency request (PM QoS).
pub const CPU_LATENCY_DEVICE: &str = "/dev/cpu_dma_latency";

/// The cores kept awake while this lives.
#[derive(Debug)]
pub struct CoresAwake {
    _request: File,
}

/// Why the cores could not be kept awake.
#[derive(Debug, thiserror::Error)]
pub enum AwakeError {
    /// The device is writable by root only, unless the machine says otherwise.
    #[error(
        "not allowed to keep the cores awake: {CPU_LATENCY_DEVICE} is writable by root only \
         unless a udev rule opens it to lewis's group \
         (robots/systemd/99-lewis-cpu-latency.rules)"
    )]
    NotAllowed,
    /// No such device (a kernel without PM QoS, a container without the device), or the
    /// kernel refused the request.
    #[error("cannot keep the cores awake through {CPU_LATENCY_DEVICE}: {0}")]
    System(std::io::Error),
}

/// Keeps every core of this machine out of idle states slower to leave than 0 µs until the
/// returned value is dropped.
///
/// # Errors
/// When this process may not write the request, or the machine has no way to take it.
pub fn keep_cores_awake() -> Result<CoresAwake, AwakeError> {
    let mut request = std::fs::OpenOptions::new()
        .write(true)
        .open(CPU_LATENCY_DEVICE)
        .map_err(|e| match e.kind() {
            ErrorKind::PermissionDenied => AwakeError::NotAllowed,
            _ => AwakeError::System(e),
        })?;
    request
        .write_all(&0i32.to_ne_bytes())
        .map_err(AwakeError::System)?;
    Ok(CoresAwake { _request: request })
}

/// The machine's CPU latency target in µs, all requests taken together (2,000,000,000 when
/// none is made), where this process may read it.
#[must_use]
pub fn cpu_latency_target_us() -> Option<i32> {
    let mut value = [0u8; 4];
    File::open(CPU_LATENCY_DEVICE)
        .and_then(|mut f| f.read_exact(&mut value))
        .ok()?;
    Some(i32::from_ne_bytes(value))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cores_are_kept_awake_while_the_request_lives() {
        // Another process (a benchmark, tuned's latency profile) may hold the cores awake
        // already: the request's end could not be seen then.
        let before = cpu_latency_target_us();
        if before == Some(0) {
            lewis_testkit::skip_unless_ci!("the cores are kept awake by another process");
        }
        let held = match keep_cores_awake() {
            Ok(held) => held,
            Err(e) => {
                lewis_testkit::skip_unless_ci!("{e}");
            }
        };
        assert_eq!(cpu_latency_target_us(), Some(0));
        drop(held);
        assert_eq!(cpu_latency_target_us(), before);
    }
}
