//! Fault injection for the device emulators: noise before frames, corrupted checksums and
//! silence, so that the drivers' resynchronisation and health reporting can be exercised.
//!
//! The faults are the serial-line family of the one fault vocabulary
//! ([`lewis_service::fault`]); the noise is the lines' fixed-seed generator ([`NoiseBytes`]):
//! runs are deterministic.

use lewis_service::NoiseBytes;
/// The knobs of the injected faults; the default injects none.
pub use lewis_service::fault::LineFaults as Faults;

/// The seed of the noise, and where in each number its byte is taken.
const NOISE: NoiseBytes = NoiseBytes::new(0x9E37_79B9_7F4A_7C15, 32);

/// Applies [`Faults`] to outgoing frames and counts what it did.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    faults: Faults,
    noise: NoiseBytes,
    frames_seen: u64,
    noise_bytes_sent: u64,
    frames_corrupted: u64,
}

impl FaultInjector {
    /// An injector applying `faults`.
    pub fn new(faults: Faults) -> Self {
        Self {
            faults,
            noise: NOISE,
            frames_seen: 0,
            noise_bytes_sent: 0,
            frames_corrupted: 0,
        }
    }

    /// The knobs in force.
    pub fn faults(&self) -> Faults {
        self.faults
    }

    /// Changes the knobs; counters are kept.
    pub fn set_faults(&mut self, faults: Faults) {
        self.faults = faults;
    }

    /// Noise bytes sent so far.
    pub fn noise_bytes_sent(&self) -> u64 {
        self.noise_bytes_sent
    }

    /// Frames sent with a corrupted checksum so far.
    pub fn frames_corrupted(&self) -> u64 {
        self.frames_corrupted
    }

    /// Appends `frame` to `out` with the faults applied: noise first, then the frame with the
    /// byte at `checksum_index` inverted when this frame is due for corruption.
    pub fn emit(&mut self, frame: &[u8], checksum_index: usize, out: &mut Vec<u8>) {
        for _ in 0..self.faults.noise_bytes {
            out.push(self.noise.next_byte());
        }
        self.noise_bytes_sent += self.faults.noise_bytes as u64;
        self.frames_seen += 1;
        let every = u64::from(self.faults.corrupt_checksum_every);
        let start = out.len();
        out.extend_from_slice(frame);
        if every > 0
            && self.frames_seen.is_multiple_of(every)
            && let Some(byte) = out.get_mut(start + checksum_index)
        {
            *byte = !*byte;
            self.frames_corrupted += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_faults_pass_frames_through_unchanged() {
        let mut injector = FaultInjector::new(Faults::default());
        let mut out = Vec::new();
        injector.emit(&[1, 2, 3], 2, &mut out);
        assert_eq!(out, vec![1, 2, 3]);
    }

    #[test]
    fn every_second_frame_is_corrupted_at_its_checksum() {
        let faults = Faults {
            corrupt_checksum_every: 2,
            ..Faults::default()
        };
        let mut injector = FaultInjector::new(faults);
        let mut out = Vec::new();
        injector.emit(&[1, 2, 3], 2, &mut out);
        injector.emit(&[1, 2, 3], 2, &mut out);
        assert_eq!(out, vec![1, 2, 3, 1, 2, !3]);
        assert_eq!(injector.frames_corrupted(), 1);
    }

    #[test]
    fn noise_comes_before_the_frame() {
        let faults = Faults {
            noise_bytes: 5,
            ..Faults::default()
        };
        let mut injector = FaultInjector::new(faults);
        let mut out = Vec::new();
        injector.emit(&[7], 0, &mut out);
        // The bytes the injector's own xorshift gave before it was made the one.
        assert_eq!(out, [0xae, 0xb9, 0x91, 0x0c, 0xe0, 7]);
        assert_eq!(injector.noise_bytes_sent(), 5);
    }
}
