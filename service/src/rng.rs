//! The one seeded random source of Lewis: xoshiro256++ seeded through SplitMix64, small,
//! fast and the same on every machine, so that a service fed the same inputs draws the same
//! numbers live and in replay, and the simulator renders the same world from the same seed.
//!
//! Owned here rather than taken from a crate so that the sequence for a seed can never
//! change under a dependency upgrade: recordings made from a seed stay reproducible.
//!
//! Beside it, the noise of emulated serial lines ([`NoiseBytes`]): the garbage bytes the
//! emulators put on a line are an xorshift64 sequence, an older and cheaper generator than
//! [`Rng`] whose bytes the line tests and the emulators' recordings were made with; it
//! stays that generator, written here once.

/// A deterministic random number generator (xoshiro256++).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rng {
    state: [u64; 4],
}

/// One step of SplitMix64: spreads a seed over the generator's state.
fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// FNV-1a of a name: stable across runs and machines.
fn fnv1a(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |hash, byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3)
    })
}

impl Rng {
    /// A generator whose whole sequence is fixed by `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        Self {
            state: [
                splitmix64(&mut x),
                splitmix64(&mut x),
                splitmix64(&mut x),
                splitmix64(&mut x),
            ],
        }
    }

    /// A seed derived from a name (FNV-1a), for services whose robot file gives none.
    #[must_use]
    pub fn seed_from_name(name: &str) -> u64 {
        fnv1a(name)
    }

    /// A generator for one device of a simulated robot, independent of the other devices
    /// seeded with the same `seed`: killing one device does not change what the others draw.
    #[must_use]
    pub fn for_device(seed: u64, device: &str) -> Self {
        Self::new(seed ^ fnv1a(device).rotate_left(17))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.state;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// A number in `[0, 1)`, with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        // 53 bits fit an f64 mantissa exactly.
        let mantissa = (self.next_u64() >> 11) as f64;
        mantissa * (1.0 / (1u64 << 53) as f64)
    }

    /// A number in `[low, high)`.
    pub fn uniform(&mut self, low: f64, high: f64) -> f64 {
        low + (high - low) * self.next_f64()
    }

    /// A standard normal sample (Box-Muller; one sample per call, so the sequence does not
    /// depend on how calls interleave with other draws).
    pub fn standard_normal(&mut self) -> f64 {
        // 1 - next_f64() is in (0, 1]: its logarithm is finite.
        let radius = (-2.0 * (1.0 - self.next_f64()).ln()).sqrt();
        let angle = std::f64::consts::TAU * self.next_f64();
        radius * angle.cos()
    }

    /// A normal sample; a standard deviation of 0 (or less) draws nothing, so a noiseless
    /// model leaves the sequence untouched.
    pub fn normal(&mut self, mean: f64, std_dev: f64) -> f64 {
        if std_dev > 0.0 {
            mean + std_dev * self.standard_normal()
        } else {
            mean
        }
    }

    /// True with probability `p` (0 draws nothing).
    pub fn chance(&mut self, p: f64) -> bool {
        p > 0.0 && self.next_f64() < p
    }
}

/// Noise bytes for emulated serial lines: xorshift64 (shifts 13, 7, 17), each byte taken
/// from the bits at a fixed place of the next number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoiseBytes {
    state: u64,
    shift: u32,
}

impl NoiseBytes {
    /// A sequence from `seed` (not 0: xorshift stays at 0), each byte being bits
    /// `shift..shift + 8` of the next number.
    #[must_use]
    pub const fn new(seed: u64, shift: u32) -> Self {
        Self { state: seed, shift }
    }

    /// The next 64 bits of the sequence.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.state;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.state = x;
        x
    }

    /// The next noise byte.
    pub fn next_byte(&mut self) -> u8 {
        // Truncation intended: the byte at `shift`.
        (self.next_u64() >> self.shift) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_bytes_are_those_the_two_copies_of_the_generator_gave() {
        // Produced by the drivers' (bits 32..40) and the fake device's (bits 24..32) own
        // xorshift before the two were made this one, from their seeds and two others.
        let draw = |seed, shift, n| {
            let mut noise = NoiseBytes::new(seed, shift);
            (0..n).map(|_| noise.next_byte()).collect::<Vec<u8>>()
        };
        assert_eq!(
            draw(0x9E37_79B9_7F4A_7C15, 32, 12),
            [
                0xae, 0xb9, 0x91, 0x0c, 0xe0, 0xce, 0x44, 0x2e, 0x85, 0xd3, 0xff, 0x47
            ]
        );
        assert_eq!(
            draw(0x2545_F491_4F6C_DD1D, 24, 12),
            [
                0xea, 0x1c, 0x58, 0xd8, 0x97, 0xbe, 0x9d, 0x50, 0x12, 0xc9, 0xa7, 0x6e
            ]
        );
        assert_eq!(
            draw(1, 32, 8),
            [0x00, 0x06, 0x2f, 0x03, 0xb0, 0x02, 0x08, 0xc1]
        );
        assert_eq!(
            draw(1, 24, 8),
            [0x40, 0x0c, 0x6e, 0x55, 0x90, 0xe5, 0xeb, 0x14]
        );
        assert_eq!(
            draw(42, 32, 8),
            [0x0a, 0xfd, 0x9c, 0xfe, 0xe3, 0xb4, 0x1a, 0x76]
        );
        assert_eq!(
            draw(42, 24, 8),
            [0x95, 0xf8, 0xd1, 0x5f, 0x8b, 0x33, 0xa5, 0xec]
        );
        let mut noise = NoiseBytes::new(0x9E37_79B9_7F4A_7C15, 32);
        for _ in 0..12 {
            noise.next_byte();
        }
        assert_eq!(noise.state, 0x2ead_8547_56d7_1f03);
    }

    #[test]
    fn the_same_seed_gives_the_same_numbers_and_another_seed_others() {
        let draw = |seed| {
            let mut rng = Rng::new(seed);
            (0..16).map(|_| rng.next_u64()).collect::<Vec<_>>()
        };
        assert_eq!(draw(7), draw(7));
        assert_ne!(draw(7), draw(8));
    }

    #[test]
    fn the_sequence_of_a_seed_never_changes() {
        // Pinned from the simulator's generator before the two were made one: a change here
        // changes every simulated recording.
        let mut laser = Rng::for_device(2, "laser");
        let bits: Vec<u64> = (0..3).map(|_| laser.next_u64()).collect();
        assert_eq!(
            bits,
            [
                0x8601_27b8_2dab_36fa,
                0x8635_b0b7_7701_000f,
                0xd742_fcb6_005c_1569
            ]
        );
        assert_eq!(laser.normal(0.0, 0.01).to_bits(), 0xbf7e_b7a7_5bd8_f2d8);
        assert_eq!(laser.next_f64().to_bits(), 0x3fc5_793d_1543_3e7c);
        assert_eq!(Rng::new(0).next_u64(), 0x5317_5d61_490b_23df);
    }

    #[test]
    fn unit_and_uniform_draws_stay_in_range() {
        let mut rng = Rng::new(Rng::seed_from_name("laser"));
        for _ in 0..10_000 {
            let u = rng.next_f64();
            assert!((0.0..1.0).contains(&u));
            let x = rng.uniform(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&x));
            assert!(rng.normal(0.0, 1.0).is_finite());
        }
    }

    #[test]
    fn normal_samples_have_the_requested_spread() {
        let mut rng = Rng::new(1);
        let n = 20_000;
        let samples: Vec<f64> = (0..n).map(|_| rng.normal(0.0, 2.0)).collect();
        let mean = samples.iter().sum::<f64>() / f64::from(n);
        let var = samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / f64::from(n);
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.05, "std {}", var.sqrt());
    }

    #[test]
    fn devices_seeded_alike_draw_different_sequences() {
        let mut laser = Rng::for_device(3, "laser");
        let mut sonar = Rng::for_device(3, "sonar");
        assert_ne!(laser.next_u64(), sonar.next_u64());
    }

    #[test]
    fn no_spread_draws_nothing() {
        let mut a = Rng::new(5);
        let mut b = Rng::new(5);
        assert_eq!(a.normal(1.5, 0.0), 1.5);
        assert!(!a.chance(0.0));
        assert_eq!(a.next_u64(), b.next_u64());
    }
}
